//! `pvrsim calibrate`, splat part: the EWA splatting renderer's unit costs
//! on this host. The hydrogen grid (`pvrsim generate hydrogen`) is made in
//! memory at 32³, 64³ and 96³, seen at 128 and 256 pixels through its own
//! transfer function cut at three thresholds (opacity 0 below them), so
//! fill rate and footprint sizes vary; each frame is rendered in one
//! one-thread pool (default options: DDA order, footprint table, ERT 0.99).
//! A frame is a sample `t = voxels_total · per_splat_voxel + voxels_drawn ·
//! per_splat + pieces composited · per_splat_piece + pixels ·
//! per_splat_pixel` ([`CostProfile::splat_time`]),
//! fitted by non-negative least squares on relative errors
//! ([`crate::node::lsq`]).
//!
//! [`CostProfile::splat_time`]: crate::node::cost::CostProfile::splat_time

use std::path::Path;
use std::sync::Arc;

use super::timer::Timer;
use crate::node::lsq::nnls;
use crate::render::splat::{render_splat, SplatOptions, SplatStats};
use crate::render::VolumeInput;
use crate::scene::{Scene, TransferFunction};

/// One timed splat frame.
#[derive(Debug, Clone, Copy)]
pub struct SplatSample {
    /// Voxels in the grid.
    pub voxels: u64,
    /// Footprints drawn.
    pub drawn: u64,
    /// (splat, band) pieces composited (walked and not skipped by ERT).
    pub pieces: u64,
    /// Image pixels.
    pub pixels: u64,
    /// Seconds (process CPU, or wall with `--timer wall`).
    pub secs: f64,
}

impl SplatSample {
    /// The sample of a frame's statistics (`order_cpu_ms + splat_cpu_ms`
    /// with the CPU timer, `order_ms + splat_ms` with the wall timer).
    pub fn of(st: &SplatStats, timer: Timer) -> SplatSample {
        SplatSample {
            voxels: st.voxels_total,
            drawn: st.voxels_drawn,
            pieces: st.pieces.saturating_sub(st.pieces_skipped_ert),
            pixels: st.pixels,
            secs: 1e-3
                * match timer {
                    Timer::Cpu => st.order_cpu_ms + st.splat_cpu_ms,
                    Timer::Wall => st.order_ms + st.splat_ms,
                },
        }
    }
}

/// The fitted splat costs and the fit's quality.
#[derive(Debug, Clone, Copy)]
pub struct SplatFit {
    /// Seconds per grid voxel.
    pub per_splat_voxel: f64,
    /// Seconds per footprint drawn.
    pub per_splat: f64,
    /// Seconds per (splat, band) piece composited.
    pub per_splat_piece: f64,
    /// Seconds per image pixel.
    pub per_splat_pixel: f64,
    /// Samples.
    pub samples: usize,
    /// Weighted R².
    pub r2: f64,
    /// RMS of the relative residuals.
    pub rel_rms: f64,
    /// Largest relative residual (|model - measured| / measured).
    pub rel_max: f64,
    /// Sum of measured and of modelled seconds.
    pub total: (f64, f64),
}

/// The hydrogen frame of side `n`, `size`² pixels, its transfer function
/// with opacity 0 below normalised value `threshold`.
pub fn hydrogen_input(n: u64, size: u32, threshold: f64) -> anyhow::Result<VolumeInput> {
    let v = crate::data::volume::generate::hydrogen(n);
    let text = crate::data::volume::scene::hydrogen_scene("hydrogen.nrrd", &v);
    let mut scene = Scene::parse(&text, Path::new("hydrogen.toml"))?;
    let tf = &scene.transfer;
    let mut rows: Vec<[f64; 5]> = vec![[0.0, 0.0, 0.0, 0.0, 0.0]];
    let at = |s: f64| {
        let (c, o) = tf.eval(s);
        [s, c[0], c[1], c[2], o]
    };
    let mut below = at(threshold);
    below[4] = 0.0;
    rows.push(below);
    rows.push(at(threshold + 1e-3));
    for p in tf.points.iter().filter(|p| p.s > threshold + 1e-3) {
        rows.push([p.s, p.rgb[0], p.rgb[1], p.rgb[2], p.opacity]);
    }
    scene.transfer = TransferFunction::from_rows(&rows, tf.unit_distance);
    Ok(VolumeInput::new(scene, Arc::new(v))?.with_size(size, size))
}

/// A one-thread rayon pool (built once: building a pool is not the
/// renderer's work).
pub fn one_thread_pool() -> anyhow::Result<rayon::ThreadPool> {
    Ok(rayon::ThreadPoolBuilder::new().num_threads(1).build()?)
}

/// Renders `input` in `pool` with the default options; its statistics.
pub fn render_in(pool: &rayon::ThreadPool, input: &VolumeInput) -> anyhow::Result<SplatStats> {
    let (_, st) = pool.install(|| render_splat(input, &SplatOptions::default()))?;
    Ok(st)
}

/// The calibration frames: hydrogen 32³, 64³, 96³ at 128 and 256 pixels,
/// thresholds 0.02, 0.1 and 0.4; every frame once per pass, `repeats`
/// passes, the fastest of each kept (a warm-up frame first).
pub fn measure(repeats: usize, timer: Timer) -> anyhow::Result<Vec<SplatSample>> {
    let mut inputs = Vec::new();
    for n in [32u64, 64, 96] {
        for size in [128u32, 256] {
            for t in [0.02, 0.1, 0.4] {
                inputs.push(hydrogen_input(n, size, t)?);
            }
        }
    }
    let pool = one_thread_pool()?;
    render_in(&pool, &inputs[0])?;
    let mut best: Vec<SplatSample> = Vec::new();
    for _ in 0..repeats.max(1) {
        let run = inputs
            .iter()
            .map(|i| Ok(SplatSample::of(&render_in(&pool, i)?, timer)))
            .collect::<anyhow::Result<Vec<_>>>()?;
        super::timer::keep_fastest(&mut best, run, |s| &mut s.secs);
    }
    Ok(best)
}

/// Fits the three costs to `samples`.
pub fn fit(samples: &[SplatSample]) -> anyhow::Result<SplatFit> {
    let s: Vec<&SplatSample> = samples.iter().filter(|s| s.secs > 0.0).collect();
    anyhow::ensure!(s.len() >= 3, "splat calibration: fewer than 3 timed frames");
    let x: Vec<Vec<f64>> = s
        .iter()
        .map(|s| {
            vec![
                s.voxels as f64,
                s.drawn as f64,
                s.pieces as f64,
                s.pixels as f64,
            ]
        })
        .collect();
    let y: Vec<f64> = s.iter().map(|s| s.secs).collect();
    let w: Vec<f64> = y.iter().map(|v| 1.0 / (v * v)).collect();
    let f = nnls(&x, &y, &w);
    let rel: Vec<f64> = f.residuals.iter().zip(&y).map(|(r, v)| r / v).collect();
    let measured: f64 = y.iter().sum();
    Ok(SplatFit {
        per_splat_voxel: f.coef[0],
        per_splat: f.coef[1],
        per_splat_piece: f.coef[2],
        per_splat_pixel: f.coef[3],
        samples: s.len(),
        r2: f.r2,
        rel_rms: (rel.iter().map(|r| r * r).sum::<f64>() / rel.len() as f64).sqrt(),
        rel_max: rel.iter().fold(0.0, |a, r| a.max(r.abs())),
        total: (measured, measured - f.residuals.iter().sum::<f64>()),
    })
}

/// The profile header lines of a fit.
pub fn header(f: &SplatFit, repeats: usize, timer: Timer) -> String {
    format!(
        "# Splat (EWA splatting, one thread, default options; built-in hydrogen 32^3, 64^3 and 96^3 at\n\
         # 128 and 256 px, TF thresholds 0.02, 0.1 and 0.4; {timer:?} clock, fastest of {} passes):\n\
         # per_splat_voxel {:.3e} s, per_splat {:.3e} s, per_splat_piece {:.3e} s, per_splat_pixel {:.3e} s\n\
         # by NNLS: {} samples, R2 {:.4} (weighted), relative residual rms {:.1} %, max {:.1} %,\n\
         # total {:.3} s measured vs {:.3} s model\n",
        repeats.max(1),
        f.per_splat_voxel,
        f.per_splat,
        f.per_splat_piece,
        f.per_splat_pixel,
        f.samples,
        f.r2,
        100.0 * f.rel_rms,
        100.0 * f.rel_max,
        f.total.0,
        f.total.1
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fit_recovers_synthetic_splat_costs() {
        let samples: Vec<SplatSample> = (1..10u64)
            .map(|i| {
                let voxels = 30_000 * (i % 3 + 1) * (i % 3 + 1);
                let drawn = 2_000 * i + 700 * (i % 4);
                let pieces = drawn + 500 * (i * 7 % 5);
                let pixels = 4096 * (i * 5 % 4 + 1);
                SplatSample {
                    voxels,
                    drawn,
                    pieces,
                    pixels,
                    secs: voxels as f64 * 3e-9
                        + drawn as f64 * 8e-8
                        + pieces as f64 * 2e-7
                        + pixels as f64 * 5e-9,
                }
            })
            .collect();
        let f = fit(&samples).unwrap();
        assert!((f.per_splat_voxel - 3e-9).abs() < 1e-13, "{f:?}");
        assert!((f.per_splat - 8e-8).abs() < 1e-12, "{f:?}");
        assert!((f.per_splat_piece - 2e-7).abs() < 1e-11, "{f:?}");
        assert!((f.per_splat_pixel - 5e-9).abs() < 1e-13, "{f:?}");
        assert!(f.rel_rms < 1e-6 && f.rel_max < 1e-6, "{f:?}");
        assert!(fit(&samples[..2]).is_err());
    }
}
