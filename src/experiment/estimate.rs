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
//! and for a grid scene (`n_v` voxels, `n_s` slices: the `slices`
//! parameter, else the sum of the dimensions `n_d`):
//!
//! ```text
//! render   t = 2.1e-8 s · n_v + 1.1e-6 s · n_p + 8e-10 s · n_p · n_s   (+ 1.7e-7 s · n_p · n_d with --compare)
//! cluster  t = (render t) + 4e-3 s · nodes
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
/// Seconds per voxel of a grid render (the process, reading and
/// classifying the volume), one thread.
pub const PER_VOXEL_S: f64 = 2.1e-8;
/// Seconds per pixel of a grid render, one thread.
pub const PER_GRID_PIXEL_S: f64 = 1.1e-6;
/// Seconds per slice sample (pixel x slice) of a grid render, one thread.
pub const PER_GRID_SAMPLE_S: f64 = 8e-10;
/// Seconds per sample (pixel x the sum of the dimensions) of the grid
/// reference (`--compare`), one thread.
pub const PER_GRID_REFERENCE_SAMPLE_S: f64 = 1.7e-7;

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
            basis.push(format!(
                "{} not estimated: the scene or its data cannot be read yet",
                self.unknown
            ));
        }
        if self.from_same_point + self.from_mean + self.from_model == 0 {
            // Nothing to go on: no figure, rather than ~0 s.
            return write!(f, "estimated duration unknown ({})", basis.join("; "));
        }
        let more = if self.unknown > 0 { " or more" } else { "" };
        write!(f, "estimated duration ~{t}{more} ({})", basis.join("; "))
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

/// What the size model reads of a scene: its data's size and its pixels.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum SceneSize {
    /// A mesh.
    Mesh {
        /// Its cells.
        cells: f64,
        /// The scene's image pixels.
        pixels: f64,
    },
    /// A grid.
    Grid {
        /// Its voxels.
        voxels: f64,
        /// Samples along a ray by default: the sum of the dimensions (the
        /// voxel layers a view-aligned slicer crosses, roughly).
        depth: f64,
        /// The scene's image pixels.
        pixels: f64,
    },
}

/// A scene's size, read once (`None`: the scene or its data is unreadable).
fn scene_size(path: &Path, cache: &mut HashMap<PathBuf, Option<SceneSize>>) -> Option<SceneSize> {
    *cache.entry(path.to_path_buf()).or_insert_with(|| {
        let scene = crate::scene::Scene::load(path).ok()?;
        let pixels = scene.image.width as f64 * scene.image.height as f64;
        if crate::data::io::volume::volume_format(&scene.data.path).is_some() {
            let v = crate::data::io::read_volume(&scene.data.path, &scene.data.field).ok()?;
            let d = v.dims.map(|n| n as f64);
            return Some(SceneSize::Grid {
                voxels: d[0] * d[1] * d[2],
                depth: d[0] + d[1] + d[2],
                pixels,
            });
        }
        let mesh = crate::data::io::read_mesh(&scene.data.path).ok()?;
        Some(SceneSize::Mesh {
            cells: mesh.tets.len() as f64,
            pixels,
        })
    })
}

/// Model seconds of one run of `command` on a grid (see the module doc):
/// `voxels` read and classified, `pixels`, `pixels x slices` slice
/// samples; the grid reference (`compare`) samples `pixels x depth`.
pub fn grid_model_seconds(
    command: &str,
    voxels: f64,
    pixels: f64,
    slices: f64,
    depth: f64,
    compare: bool,
    nodes: f64,
) -> f64 {
    let mut t =
        PER_VOXEL_S * voxels + PER_GRID_PIXEL_S * pixels + PER_GRID_SAMPLE_S * pixels * slices;
    if compare {
        t += PER_GRID_REFERENCE_SAMPLE_S * pixels * depth;
    }
    if command == "cluster" {
        t += PER_NODE_S * nodes;
    }
    t
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
            let compare = matches!(param(p, "compare"), Some(ParamValue::Bool(true)));
            let nodes = num(p, "nodes").unwrap_or(8.0);
            let px = |scene_px: f64| match (num(p, "width"), num(p, "height")) {
                (Some(w), Some(h)) => w * h,
                _ => scene_px,
            };
            match scene_size(&base_dir.join(s), &mut cache) {
                Some(SceneSize::Mesh { cells, pixels }) => {
                    e.seconds += model_seconds(command, cells, px(pixels), compare, nodes);
                    e.from_model += 1;
                }
                Some(SceneSize::Grid {
                    voxels,
                    depth,
                    pixels,
                }) => {
                    let slices = num(p, "slices").unwrap_or(depth);
                    e.seconds += grid_model_seconds(
                        command,
                        voxels,
                        px(pixels),
                        slices,
                        depth,
                        compare,
                        nodes,
                    );
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
    fn grid_model_matches_the_measurements_within_2x() {
        // mni152 (197x233x189), slice3d, one thread (docs/sweeps.md).
        let (v, d) = (8_675_289.0, 619.0);
        for (px, slices, compare, measured) in [
            (65_536.0, 551.0, false, 0.23),
            (262_144.0, 58.0, false, 0.48),
            (262_144.0, 932.0, false, 0.67),
            (65_536.0, 551.0, true, 7.29),
        ] {
            let t = grid_model_seconds("render", v, px, slices, d, compare, 0.0);
            assert!(
                (measured / 2.0..measured * 2.0).contains(&t),
                "{px} {slices}: {t}"
            );
        }
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
