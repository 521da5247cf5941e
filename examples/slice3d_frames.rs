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
    Ok(())
}
