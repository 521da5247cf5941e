//! How long a sweep will take (`pvrsim sweep --dry-run`), run by run:
//!
//! 1. a finished run of the same point in `results.csv` (another
//!    repetition): its `wall_s`;
//! 2. else the mean `wall_s` of the finished runs in `results.csv`;
//! 3. else a size model of the run, from the scene (its mesh's cell count
//!    `n_c`, read once per scene) and the image's pixel count `n_p`, with
//!    constants measured on the 2-core development machine, one thread
//!    (see docs/sweeps.md for the commands):
//!
//! ```text
//! render   t = 2e-6 s · n_c + 3.8e-6 s · n_p     (+ 6e-5 s · n_p with --compare)
//! cluster  t = 5 · (render t) + 4e-3 s · nodes    (run + sequential and Base references)
//! ```
//!
//! The model is rough (within about 2x on the bundled and shared scenes);
//! the printed estimate says which basis it used.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use super::grid::{ParamValue, Point};
use super::results::{Results, OK};

/// Seconds per cell of a render, one thread.
pub const PER_CELL_S: f64 = 2e-6;
/// Seconds per pixel of a render, one thread.
pub const PER_PIXEL_S: f64 = 3.8e-6;
/// Seconds per pixel of the reference renderer (`--compare`).
pub const PER_PIXEL_REFERENCE_S: f64 = 6e-5;
/// A cluster run (with its two references) ÷ a render of the same scene.
pub const CLUSTER_FACTOR: f64 = 5.0;
/// Seconds per simulated node.
pub const PER_NODE_S: f64 = 4e-3;

/// An estimated duration and how it was obtained.
#[derive(Debug, Clone, PartialEq)]
pub struct Estimate {
    /// Seconds for all runs still to do.
    pub seconds: f64,
    /// Runs estimated from their own point's earlier repetition.
    pub from_same_point: usize,
    /// Runs estimated from the mean of the finished runs.
    pub from_mean: usize,
    /// Runs estimated by the size model.
    pub from_model: usize,
    /// Runs with no estimate (the scene could not be read).
    pub unknown: usize,
}

impl std::fmt::Display for Estimate {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let s = self.seconds;
        let t = if s >= 3600.0 {
            format!("{:.1} h", s / 3600.0)
        } else if s >= 60.0 {
            format!("{:.1} min", s / 60.0)
        } else {
            format!("{s:.1} s")
        };
        let mut basis = Vec::new();
        if self.from_same_point > 0 {
            basis.push(format!(
                "{} from an earlier repetition",
                self.from_same_point
            ));
        }
        if self.from_mean > 0 {
            basis.push(format!("{} from the mean of finished runs", self.from_mean));
        }
        if self.from_model > 0 {
            basis.push(format!(
                "{} from a size model, rough (within about 2x)",
                self.from_model
            ));
        }
        if self.unknown > 0 {
            basis.push(format!("{} unknown (scene unreadable)", self.unknown));
        }
        write!(f, "estimated duration ~{t} ({})", basis.join("; "))
    }
}

fn wall_s(row: &super::results::Row) -> Option<f64> {
    if row.get("status").map(String::as_str) != Some(OK) {
        return None;
    }
    row.get("wall_s")?.parse().ok()
}

fn param<'a>(p: &'a Point, k: &str) -> Option<&'a ParamValue> {
    p.iter().find(|(n, _)| n == k).map(|(_, v)| v)
}

fn num(p: &Point, k: &str) -> Option<f64> {
    match param(p, k)? {
        ParamValue::Int(i) => Some(*i as f64),
        ParamValue::Float(x) => Some(*x),
        ParamValue::Str(s) => s.parse().ok(),
        ParamValue::Bool(_) => None,
    }
}

/// Cells and pixels of a scene, read once.
fn scene_size(path: &Path, cache: &mut HashMap<PathBuf, Option<(f64, f64)>>) -> Option<(f64, f64)> {
    *cache.entry(path.to_path_buf()).or_insert_with(|| {
        let scene = crate::scene::Scene::load(path).ok()?;
        let mesh = crate::data::io::read_mesh(&scene.data.path).ok()?;
        Some((
            mesh.tets.len() as f64,
            scene.image.width as f64 * scene.image.height as f64,
        ))
    })
}

/// Model seconds of one run of `command` (see the module doc).
pub fn model_seconds(command: &str, cells: f64, pixels: f64, compare: bool, nodes: f64) -> f64 {
    let mut t = PER_CELL_S * cells + PER_PIXEL_S * pixels;
    if compare {
        t += PER_PIXEL_REFERENCE_S * pixels;
    }
    if command == "cluster" {
        t = CLUSTER_FACTOR * t + PER_NODE_S * nodes;
    }
    t
}

/// Estimates the runs `todo` (points with their repetition) of a sweep of
/// `command` whose path parameters are relative to `base_dir`.
pub fn estimate(
    command: &str,
    base_dir: &Path,
    todo: &[(&Point, usize)],
    results: &Results,
) -> Estimate {
    let done: Vec<f64> = results.rows.iter().filter_map(wall_s).collect();
    let mean = (!done.is_empty()).then(|| done.iter().sum::<f64>() / done.len() as f64);
    let mut cache = HashMap::new();
    let mut e = Estimate {
        seconds: 0.0,
        from_same_point: 0,
        from_mean: 0,
        from_model: 0,
        unknown: 0,
    };
    for (p, _) in todo {
        if let Some(t) = results.rows_of(p).into_iter().find_map(wall_s) {
            e.seconds += t;
            e.from_same_point += 1;
        } else if let Some(m) = mean {
            e.seconds += m;
            e.from_mean += 1;
        } else if let Some(ParamValue::Str(s)) = param(p, "scene") {
            match scene_size(&base_dir.join(s), &mut cache) {
                Some((cells, scene_px)) => {
                    let px = match (num(p, "width"), num(p, "height")) {
                        (Some(w), Some(h)) => w * h,
                        _ => scene_px,
                    };
                    let compare = matches!(param(p, "compare"), Some(ParamValue::Bool(true)));
                    let nodes = num(p, "nodes").unwrap_or(8.0);
                    e.seconds += model_seconds(command, cells, px, compare, nodes);
                    e.from_model += 1;
                }
                None => e.unknown += 1,
            }
        } else {
            e.unknown += 1;
        }
    }
    e
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn model_matches_the_measurements_within_2x() {
        // aorta-small view B (20,169 cells) at 400x400, one thread: 0.65 s measured.
        let t = model_seconds("render", 20_169.0, 160_000.0, false, 0.0);
        assert!((0.65 / 2.0..0.65 * 2.0).contains(&t), "{t}");
        // The same scene at 100x100 on 8 cluster nodes: 0.29 s measured.
        let t = model_seconds("cluster", 20_169.0, 10_000.0, false, 8.0);
        assert!((0.29 / 2.0..0.29 * 2.0).contains(&t), "{t}");
    }

    #[test]
    fn display_names_the_basis() {
        let e = Estimate {
            seconds: 150.0,
            from_same_point: 0,
            from_mean: 2,
            from_model: 1,
            unknown: 0,
        };
        let s = e.to_string();
        assert!(s.starts_with("estimated duration ~2.5 min"), "{s}");
        assert!(
            s.contains("2 from the mean") && s.contains("1 from a size model"),
            "{s}"
        );
    }
}
