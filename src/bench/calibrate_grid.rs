//! `pvrsim calibrate`, grid part: the software slicer's unit costs on this
//! host. The built-in hydrogen grid (48³ and 64³) cut into 1, 2 and 3
//! bricks per axis on one node, and into 2 per axis on 2 and 4 nodes, at
//! two image sizes, every node in its own worker process, which records its
//! process CPU seconds (the slicer's threads included;
//! [`crate::node::grid::GridNodeStats`]).
//! Each node's render is a sample `t = samples · per_sample + textures ·
//! per_texture_draw + texture bytes / upload_bytes_per_s + 4 · pixels /
//! readback_bytes_per_s`, fitted by
//! non-negative least squares on relative errors ([`crate::node::lsq`]):
//! the per-sample cost of slicing, the per-brick set-up and the texture
//! build (the software "upload") that `node::grid::device` charges.

use std::path::Path;

use anyhow::Context;

use super::timer::Timer;
use crate::data::builtin::BuiltIn;
use crate::job::api::ClusterJob;
use crate::job::args::by_name::ParamValue;
use crate::node::lsq::nnls;

/// One timed grid render.
#[derive(Debug, Clone, Copy)]
pub struct GridSample {
    /// Trilinear samples taken.
    pub samples: u64,
    /// Textures (bricks) drawn.
    pub textures: u64,
    /// Texture bytes built.
    pub texture_bytes: u64,
    /// Subimage pixels produced.
    pub pixels: u64,
    /// Seconds (process CPU, or wall with `--timer wall`).
    pub secs: f64,
}

/// The fitted grid costs and the fit's quality.
#[derive(Debug, Clone, Copy)]
pub struct GridFit {
    /// Seconds per sample.
    pub per_sample: f64,
    /// Seconds per brick drawn.
    pub per_texture_draw: f64,
    /// Texture bytes built per second (0: not resolved by the fit).
    pub upload_bytes_per_s: f64,
    /// Subimage bytes (4 a pixel) produced per second (0: not resolved).
    pub readback_bytes_per_s: f64,
    /// Samples.
    pub samples: usize,
    /// Weighted R².
    pub r2: f64,
    /// RMS of the relative residuals.
    pub rel_rms: f64,
    /// Sum of measured and of modelled seconds.
    pub total: (f64, f64),
}

fn opt(k: &str, v: impl ToString) -> (String, ParamValue) {
    (k.to_string(), ParamValue::Str(v.to_string()))
}

/// Renders the built-in grids on 1, 2 and 4 nodes, each node in its own
/// worker process (`--transport processes`: a node's process CPU is its
/// own, and nodes sharing the host's cores pay what they pay in a real
/// frame), with `--no-texture-cache` (every frame does the whole work).
/// Every configuration is run once per pass, `repeats` passes in turn (a
/// slow spell of a shared host then slows one pass of many configurations,
/// not every run of a few), each run two frames on the same workers: the
/// first, a fresh process's first touch of its memory (one page fault a
/// page, priced by the host, not the work), is dropped. Per node the
/// fastest of the passes is kept, as `pvrsim fidelity` keeps the fastest
/// warm frame (the host only ever adds to a CPU time: stolen cycles of a
/// virtual machine, caches other jobs evicted).
pub fn measure(data: &BuiltIn, repeats: usize, timer: Timer) -> anyhow::Result<Vec<GridSample>> {
    let probe = data.dir().join("grid-probe.toml");
    std::fs::write(
        &probe,
        "name = \"grid-probe\"\n[costs]\nper_sample = 1e-9\n",
    )
    .with_context(|| format!("writing {}", probe.display()))?;
    let mut configs = Vec::new();
    for n in [48u64, 64] {
        let scene = data.write_grid(n)?;
        for (d, nodes) in [(1u32, 1usize), (2, 1), (3, 1), (2, 2), (2, 4)] {
            for size in [96u32, 160, 256] {
                configs.push((scene.clone(), d, nodes, size));
            }
        }
    }
    // Per configuration, per node: the fastest sample so far.
    let mut best: Vec<Vec<GridSample>> = vec![Vec::new(); configs.len()];
    for _ in 0..repeats.max(1) {
        for (c, (scene, d, nodes, size)) in configs.iter().enumerate() {
            let warm = render_warm(scene, &probe, *d, *nodes, *size, timer)?;
            super::timer::keep_fastest(&mut best[c], warm, |s| &mut s.secs);
        }
    }
    Ok(best.into_iter().flatten().collect())
}

/// One run of two frames on the same workers: per node, the counts and
/// time of the second.
fn render_warm(
    scene: &Path,
    profile: &Path,
    d: u32,
    nodes: usize,
    size: u32,
    timer: Timer,
) -> anyhow::Result<Vec<GridSample>> {
    let job = ClusterJob::from_options(&[
        opt("scene", scene.display()),
        opt("nodes", nodes),
        opt("subvolumes", d),
        opt("transport", "processes"),
        opt("profile", profile.display()),
        opt("width", size),
        opt("height", size),
        opt("frames", 2),
        ("no_texture_cache".to_string(), ParamValue::Bool(true)),
        ("no_baselines".to_string(), ParamValue::Bool(true)),
    ])
    .map_err(|e| anyhow::anyhow!("grid calibration job: {e}"))?;
    let r = job
        .run()
        .map_err(|e| anyhow::anyhow!("grid calibration run: {e}"))?;
    let frames = r.frame_reports_json();
    anyhow::ensure!(
        frames.len() == 2,
        "grid calibration: {} frames came back, 2 asked for",
        frames.len()
    );
    let nodes = frames[1]["nodes"]
        .as_array()
        .ok_or_else(|| anyhow::anyhow!("grid calibration: a report without nodes"))?;
    Ok(nodes
        .iter()
        .map(|node| {
            let num = |k: &str| node[k].as_f64().unwrap_or(0.0);
            GridSample {
                samples: num("samples_taken") as u64,
                textures: node["bricks"].as_array().map_or(0, |b| b.len() as u64),
                texture_bytes: num("texture_bytes") as u64,
                pixels: num("pixels") as u64,
                secs: match timer {
                    Timer::Cpu => num("process_cpu_s"),
                    Timer::Wall => num("host_s"),
                },
            }
        })
        .collect())
}

/// Fits the three costs to `samples`.
pub fn fit(samples: &[GridSample]) -> anyhow::Result<GridFit> {
    let s: Vec<&GridSample> = samples.iter().filter(|s| s.secs > 0.0).collect();
    anyhow::ensure!(s.len() >= 3, "grid calibration: fewer than 3 timed renders");
    let x: Vec<Vec<f64>> = s
        .iter()
        .map(|s| {
            vec![
                s.samples as f64,
                s.textures as f64,
                s.texture_bytes as f64,
                4.0 * s.pixels as f64,
            ]
        })
        .collect();
    let y: Vec<f64> = s.iter().map(|s| s.secs).collect();
    let w: Vec<f64> = y.iter().map(|v| 1.0 / (v * v)).collect();
    let f = nnls(&x, &y, &w);
    let rel = (f
        .residuals
        .iter()
        .zip(&y)
        .map(|(r, v)| (r / v).powi(2))
        .sum::<f64>()
        / y.len() as f64)
        .sqrt();
    let measured: f64 = y.iter().sum();
    Ok(GridFit {
        per_sample: f.coef[0],
        per_texture_draw: f.coef[1],
        upload_bytes_per_s: if f.coef[2] > 0.0 {
            1.0 / f.coef[2]
        } else {
            0.0
        },
        readback_bytes_per_s: if f.coef[3] > 0.0 {
            1.0 / f.coef[3]
        } else {
            0.0
        },
        samples: s.len(),
        r2: f.r2,
        rel_rms: rel,
        total: (measured, measured - f.residuals.iter().sum::<f64>()),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fit_recovers_synthetic_grid_costs() {
        let samples: Vec<GridSample> = (1..10u64)
            .map(|i| {
                let (samples, textures, bytes) = (100_000 * i, i * i % 7 + 1, 50_000 * (i % 4 + 1));
                let pixels = 1000 * (i * 3 % 5 + 1);
                GridSample {
                    samples,
                    textures,
                    texture_bytes: bytes,
                    pixels,
                    secs: samples as f64 * 4e-9
                        + textures as f64 * 2e-4
                        + bytes as f64 / 1e9
                        + 4.0 * pixels as f64 / 2e8,
                }
            })
            .collect();
        let f = fit(&samples).unwrap();
        assert!((f.per_sample - 4e-9).abs() < 1e-13, "{f:?}");
        assert!((f.per_texture_draw - 2e-4).abs() < 1e-9, "{f:?}");
        assert!((f.upload_bytes_per_s - 1e9).abs() / 1e9 < 1e-4, "{f:?}");
        assert!((f.readback_bytes_per_s - 2e8).abs() / 2e8 < 1e-4, "{f:?}");
        assert!(f.rel_rms < 1e-6);
        assert!(fit(&samples[..2]).is_err());
    }
}
