//! Times `N` slice3d frames of one grid scene with everything prepared,
//! the scalar texture tiled and linear alternately (for profiling the frame
//! loop: `perf record` around it; `LAYOUT=tiled|linear` runs one only).
//!
//! ```text
//! cargo run --release --example slice3d_frames -- SCENE [N]
//! ```
//!
//! Prints the median frame time per layout. `RENDERER=shearwarp` times the
//! shear-warp renderer instead (its run-length encodings prepared once).

use std::path::Path;
use std::sync::Arc;

use pvrsim::render::shearwarp::{self, ShearWarpOptions};
use pvrsim::render::slice3d::{self, Layout, Slice3dOptions};
use pvrsim::render::VolumeInput;
use pvrsim::scene::Scene;

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some(path) = args.first() else {
        anyhow::bail!("usage: slice3d_frames SCENE [N]");
    };
    let n: usize = args.get(1).map_or(Ok(10), |s| s.parse())?;
    let scene = Scene::load(Path::new(path))?;
    let vol = pvrsim::data::io::read_volume(&scene.data.path, &scene.data.field)?;
    let input = VolumeInput::new(scene, Arc::new(vol))?;
    if std::env::var("RENDERER").as_deref() == Ok("shearwarp") {
        return shearwarp_frames(&input, n);
    }
    let opts = Slice3dOptions::default();
    let layouts: Vec<Layout> = match std::env::var("LAYOUT").as_deref() {
        Ok("tiled") => vec![Layout::Tiled],
        Ok("linear") => vec![Layout::Linear],
        _ => vec![Layout::Tiled, Layout::Linear],
    };
    let preps: Vec<_> = layouts
        .iter()
        .map(|&l| slice3d::prepare_with(&input, opts.classify, l))
        .collect();
    let mut times = vec![Vec::with_capacity(n); layouts.len()];
    let mut images = vec![None; layouts.len()];
    for _ in 0..n {
        for (i, prep) in preps.iter().enumerate() {
            let (img, st) = slice3d::render_prepared(&input, prep, &opts)?;
            times[i].push(st.time_render_s * 1e3);
            images[i] = Some(img.pixels);
        }
    }
    for (l, t) in layouts.iter().zip(&mut times) {
        t.sort_by(f64::total_cmp);
        println!("{l:?}: median {:.1} ms of {n}", t[n / 2]);
    }
    println!("same image: {}", images.iter().all(|x| *x == images[0]));
    Ok(())
}

/// Times `n` shear-warp frames with the encodings prepared once.
fn shearwarp_frames(input: &VolumeInput, n: usize) -> anyhow::Result<()> {
    let opts = ShearWarpOptions::default();
    shearwarp::check(input, &opts)?;
    let prep = shearwarp::prepare(input);
    let mut times = Vec::with_capacity(n);
    for _ in 0..n.max(1) {
        let (_, st) = shearwarp::render_prepared(input, &prep, &opts)?;
        times.push(st.time_render_s * 1e3);
    }
    times.sort_by(f64::total_cmp);
    println!(
        "ShearWarp: median {:.1} ms of {} (prepare {:.3} s)",
        times[times.len() / 2],
        times.len(),
        prep.time_s
    );
    // What a transfer-function edit costs: a recolouring keeps the runs;
    // opacity 0.005 at every transparent control point but s = 0 reveals
    // the faint values below the first visible one (skin, say): runs over
    // min-max blocks, then `refine` re-encodes per cell.
    let frame = |p: &shearwarp::Prepared, inp: &VolumeInput| -> anyhow::Result<f64> {
        let mut t: Vec<f64> = (0..n.max(1))
            .map(|_| Ok(shearwarp::render_prepared(inp, p, &opts)?.1.time_render_s * 1e3))
            .collect::<anyhow::Result<_>>()?;
        t.sort_by(f64::total_cmp);
        Ok(t[t.len() / 2])
    };
    let mut prep = prep;
    let mut edited = input.clone();
    for p in &mut edited.scene.transfer.points {
        p.rgb = [p.rgb[2], p.rgb[0], p.rgb[1]];
    }
    let t = std::time::Instant::now();
    let kept = !prep.reclassify(&edited);
    let recolour = t.elapsed().as_secs_f64();
    for p in &mut edited.scene.transfer.points {
        if p.opacity == 0.0 && p.s > 0.0 {
            p.opacity = 0.005;
        }
    }
    let mut coarse = prep.clone();
    let t = std::time::Instant::now();
    let revealed = coarse.reclassify(&edited);
    let reveal = t.elapsed().as_secs_f64() * 1e3;
    let after = frame(&coarse, &edited)?;
    let t = std::time::Instant::now();
    coarse.refine(&edited);
    let refine = t.elapsed().as_secs_f64() * 1e3;
    let refined = frame(&coarse, &edited)?;
    println!(
        "ShearWarp TF edits: recolour {:.1} us (runs kept: {kept}); faint values revealed: \
         reclassify {reveal:.2} ms (block runs: {revealed}), frame {after:.1} ms on them; refine \
         {refine:.1} ms (3 axes), frame {refined:.1} ms",
        recolour * 1e6,
    );
    Ok(())
}
