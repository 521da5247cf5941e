//! Where does slice3d's error against the grid reference sit? Prints the
//! worst pixels and, for the worst one, the trilinear scalar and the
//! transfer function's opacity along its ray beside the slicer's samples.
//!
//! ```text
//! cargo run --release --example slice3d_diag -- SCENE [SLICES] [REF_CACHE]
//! ```
//!
//! `REF_CACHE` (a file path) keeps the reference image between runs (raw
//! f32 RGBA, written when absent). Environment: `CLASSIFY=post|pre|preint`
//! (default: slice3d's), `ERT=threshold` (1 = off), `PROFILE=1` (print the
//! worst pixel's ray), `PIXEL=index` (profile that pixel instead).

use std::path::Path;
use std::sync::Arc;

use pvrsim::render::slice3d::{self, planes, Slice3dOptions, SliceCount};
use pvrsim::render::VolumeInput;
use pvrsim::scene::Scene;

#[path = "support/ref_cache.rs"]
mod ref_cache;

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let scene = Scene::load(Path::new(&args[0]))?;
    let vol = pvrsim::data::io::read_volume(&scene.data.path, &scene.data.field)?;
    let input = VolumeInput::new(scene, Arc::new(vol))?;
    let slices = match args.get(1).map(|s| s.parse::<u64>()) {
        Some(Ok(0)) | None => SliceCount::Default,
        Some(Ok(n)) => SliceCount::Count(n),
        Some(Err(e)) => anyhow::bail!("{e}"),
    };
    let ert: f32 = std::env::var("ERT")
        .ok()
        .map_or(0.99, |v| v.parse().unwrap());
    let refimg = ref_cache::reference(&input, args.get(2).map(|s| s.as_str()))?;
    let classify = match std::env::var("CLASSIFY").as_deref() {
        Ok("post") => pvrsim::render::slicing::Classify::Post,
        Ok("pre") => pvrsim::render::slicing::Classify::Pre,
        Ok("preint") => pvrsim::render::slicing::Classify::Preint,
        _ => Slice3dOptions::default().classify,
    };
    let opts = Slice3dOptions {
        slices,
        ert,
        classify,
        ..Default::default()
    };
    let (img, st) = slice3d::render(&input, &opts)?;
    let err = img.error_against(&refimg);
    println!(
        "{err}; slices {} spacing {:.4}",
        st.slices, st.slice_spacing
    );
    let w = img.width as usize;
    let mut e: Vec<(f32, usize)> = img
        .pixels
        .iter()
        .zip(&refimg.pixels)
        .enumerate()
        .map(|(k, (a, b))| {
            (
                (0..3).map(|c| (a[c] - b[c]).abs()).fold(0.0, f32::max) * 255.0,
                k,
            )
        })
        .collect();
    e.sort_by(|a, b| b.0.total_cmp(&a.0));
    for &(v, k) in e.iter().take(12) {
        println!(
            "  ({:3},{:3}) err {v:6.2}  slicer {:?} ref {:?}",
            k % w,
            k / w,
            img.pixels[k].map(|x| (x * 255.0).round()),
            refimg.pixels[k].map(|x| (x * 255.0).round())
        );
    }
    if std::env::var("PROFILE").is_err() {
        return Ok(());
    }
    let k = std::env::var("PIXEL")
        .ok()
        .map_or(e[0].1, |v| v.parse().unwrap());
    let (i, j) = ((k % w) as u32, (k / w) as u32);
    let view = input.scene.camera.view(img.width, img.height);
    let vol = &*input.volume;
    let pl = planes::Planes::new(&view, vol, opts.slices).unwrap();
    let r = planes::ray_samples(&view, &pl, vol, input.scene.transfer.unit_distance, i, j).unwrap();
    println!(
        "pixel ({i},{j}): k {}..{} step {:?}",
        r.k_first, r.k_last, r.step
    );
    let tri = |p: [f64; 3]| -> f64 {
        let c = [0, 1, 2].map(|a| (p[a].floor() as i64).clamp(0, vol.dims[a] as i64 - 2) as u64);
        let f = [0, 1, 2].map(|a| p[a] - c[a] as f64);
        let mut s = 0.0;
        for n in 0..8u64 {
            let (dx, dy, dz) = (n & 1, (n >> 1) & 1, (n >> 2) & 1);
            let wgt = (if dx == 1 { f[0] } else { 1.0 - f[0] })
                * (if dy == 1 { f[1] } else { 1.0 - f[1] })
                * (if dz == 1 { f[2] } else { 1.0 - f[2] });
            s += wgt * vol.get(c[0] + dx, c[1] + dy, c[2] + dz) as f64;
        }
        s
    };
    let tf = &input.scene.transfer;
    let lut = pvrsim::render::slicing::Lut::new(tf, input.range);
    let table =
        slice3d::preint::PreintTable::new(&lut, input.range, (pl.delta / tf.unit_distance) as f32);
    println!(
        "head {} tail {} k_ud {} table k {}",
        r.head, r.tail, r.k_ud, table.k
    );
    let mut sprev = 0.0f32;
    // Fine profile: 8 sub-steps per slice.
    let mut acc_a = 0.0f64;
    for k in r.k_first..=r.k_last {
        let p = [0, 1, 2].map(|a| r.start[a] as f64 + k as f64 * r.step[a] as f64);
        let s = tri(p);
        let (_, o) = tf.eval(input.normalise(s));
        let a = 1.0 - (1.0 - o).powf(r.k_ud as f64);
        let mut line = String::new();
        let mut omax = 0.0f64;
        for q in 0..8 {
            let kk = k as f64 - 0.5 + (q as f64 + 0.5) / 8.0;
            let pq = [0, 1, 2].map(|a| r.start[a] as f64 + kk * r.step[a] as f64);
            let sq = tri(pq);
            let (_, oq) = tf.eval(input.normalise(sq));
            omax = omax.max(oq);
            line += &format!("{:5.1} ", sq);
        }
        let seg =
            table.baked[table.index(sprev) * slice3d::preint::PREINT_SIZE + table.index(s as f32)];
        sprev = s as f32;
        if omax > 0.0 || o > 0.0 {
            acc_a += (1.0 - acc_a) * a;
            println!(
                "  k {k}: s {s:6.1} o {o:.3} a {a:.3} A {acc_a:.3} seg {seg:?} | fine s: {line}"
            );
        }
        if acc_a > 0.995 {
            break;
        }
    }
    Ok(())
}
