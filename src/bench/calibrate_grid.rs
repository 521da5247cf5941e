//! `pvrsim calibrate`, grid part: the software slicer's unit costs on this
//! host. One node renders the built-in hydrogen grid (48³ and 64³) cut into
//! 1, 2 and 3 bricks per axis, at two image sizes, on the virtual clock
//! (which renders for real and records the node's process CPU seconds,
//! the slicer's worker threads included; [`crate::node::GridNodeStats`]).
//! Each render is a sample `t = samples · per_sample + textures ·
//! per_texture_draw + texture bytes / upload_bytes_per_s`, fitted by
//! non-negative least squares on relative errors ([`crate::node::lsq`]):
//! the per-sample cost of slicing, the per-brick set-up and the texture
//! build (the software "upload") that `node::grid::device` charges.

use std::path::Path;

use anyhow::Context;

use super::calibrate::Timer;
use crate::data::builtin::BuiltIn;
use crate::job::api::ClusterJob;
use crate::job::options::ParamValue;
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

/// Renders the built-in grids (`repeats` times each, fastest kept).
pub fn measure(data: &BuiltIn, repeats: usize, timer: Timer) -> anyhow::Result<Vec<GridSample>> {
    let probe = data.dir().join("grid-probe.toml");
    std::fs::write(
        &probe,
        "name = \"grid-probe\"\n[costs]\nper_sample = 1e-9\n",
    )
    .with_context(|| format!("writing {}", probe.display()))?;
    let mut out = Vec::new();
    for n in [48u64, 64] {
        let scene = data.write_grid(n)?;
        for d in 1..=3u32 {
            for size in [96u32, 160] {
                let mut best: Option<GridSample> = None;
                for _ in 0..repeats.max(1) {
                    let s = render_once(&scene, &probe, d, size, timer)?;
                    if best.is_none_or(|b| s.secs < b.secs) {
                        best = Some(s);
                    }
                }
                out.extend(best);
            }
        }
    }
    Ok(out)
}

fn render_once(
    scene: &Path,
    profile: &Path,
    d: u32,
    size: u32,
    timer: Timer,
) -> anyhow::Result<GridSample> {
    let job = ClusterJob::from_options(&[
        opt("scene", scene.display()),
        opt("nodes", 1),
        opt("subvolumes", d),
        opt("clock", "virtual"),
        opt("profile", profile.display()),
        opt("width", size),
        opt("height", size),
        ("no_baselines".to_string(), ParamValue::Bool(true)),
    ])
    .map_err(|e| anyhow::anyhow!("grid calibration job: {e}"))?;
    let r = job
        .run()
        .map_err(|e| anyhow::anyhow!("grid calibration run: {e}"))?;
    let rep = r.report_json();
    let node = &rep["nodes"][0];
    let num = |k: &str| node[k].as_f64().unwrap_or(0.0);
    Ok(GridSample {
        samples: num("samples_taken") as u64,
        textures: node["device"]["textures"].as_u64().unwrap_or(0).max(d as u64 * d as u64 * d as u64),
        texture_bytes: num("texture_bytes") as u64,
        secs: match timer {
            Timer::Cpu => num("process_cpu_s"),
            Timer::Wall => num("host_s"),
        },
    })
}

/// Fits the three costs to `samples`.
pub fn fit(samples: &[GridSample]) -> anyhow::Result<GridFit> {
    let s: Vec<&GridSample> = samples.iter().filter(|s| s.secs > 0.0).collect();
    anyhow::ensure!(s.len() >= 3, "grid calibration: fewer than 3 timed renders");
    let x: Vec<Vec<f64>> = s
        .iter()
        .map(|s| vec![s.samples as f64, s.textures as f64, s.texture_bytes as f64])
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
        upload_bytes_per_s: if f.coef[2] > 0.0 { 1.0 / f.coef[2] } else { 0.0 },
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
                GridSample {
                    samples,
                    textures,
                    texture_bytes: bytes,
                    secs: samples as f64 * 4e-9 + textures as f64 * 2e-4 + bytes as f64 / 1e9,
                }
            })
            .collect();
        let f = fit(&samples).unwrap();
        assert!((f.per_sample - 4e-9).abs() < 1e-13, "{f:?}");
        assert!((f.per_texture_draw - 2e-4).abs() < 1e-9, "{f:?}");
        assert!((f.upload_bytes_per_s - 1e9).abs() / 1e9 < 1e-4, "{f:?}");
        assert!(f.rel_rms < 1e-6);
        assert!(fit(&samples[..2]).is_err());
    }
}
