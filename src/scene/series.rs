//! A series file (`pvrsim cluster --series FILE.toml`): a recorded
//! session replayed frame by frame. Each `[[frame]]` changes what it
//! names; everything else carries over from the frame before (the first
//! frame starts from the scene):
//!
//! ```toml
//! [[frame]]                      # frame 0: the scene as it is
//! [[frame]]
//! turn = 10                      # the eye turned 10 degrees about the target
//! [[frame]]
//! eye = [0, 0, 250]              # a camera (eye, target, up: any of them)
//! transfer = { unit_distance = 5, points = [[0, 0, 0, 1, 0.2], [1, 1, 0, 0, 0.8]] }
//! [[frame]]
//! field = "pressure"             # another point field of the mesh
//! [[frame]]
//! mesh = "step-0002.vtk"         # another time step: same topology
//! repeat = 3                     # this frame 3 times (default 1)
//! ```
//!
//! Keys and values are checked as the scene's are (an unknown key, a
//! camera whose eye is its target, a transfer function out of order): the
//! error names the file, the line or `frame[i].key`. Whether a field exists
//! and a time step's mesh matches is checked by the job layer when it loads
//! them, before any frame runs.

use std::path::{Path, PathBuf};

use serde::Deserialize;

use super::{transfer_from_rows, Camera, Scene, TransferFunction};
use crate::error::{Error, Result};

/// Most frames a series file may describe.
pub const MAX_FRAMES: u64 = 100_000;

/// One frame of a series, with everything carried over resolved.
#[derive(Debug, Clone, PartialEq)]
pub struct FrameSpec {
    /// The camera.
    pub camera: Camera,
    /// The transfer function.
    pub transfer: TransferFunction,
    /// The point field rendered.
    pub field: String,
    /// The mesh file (the scene's, or a time step's), resolved against
    /// the series file's folder.
    pub mesh: PathBuf,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawSeries {
    #[serde(default)]
    frame: Vec<RawFrame>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawFrame {
    eye: Option<Vec<f64>>,
    target: Option<Vec<f64>>,
    up: Option<Vec<f64>>,
    turn: Option<f64>,
    transfer: Option<RawTransfer>,
    field: Option<String>,
    mesh: Option<String>,
    repeat: Option<u64>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawTransfer {
    unit_distance: f64,
    points: Vec<Vec<f64>>,
}

/// Reads the series file at `path` over `scene` (the first frame's
/// starting point): every frame resolved, every value checked.
pub fn load(path: &Path, scene: &Scene) -> Result<Vec<FrameSpec>> {
    let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
    parse(&text, path, scene)
}

/// [`load`] of text already read (`path` names it in errors and resolves
/// mesh paths).
pub fn parse(text: &str, path: &Path, scene: &Scene) -> Result<Vec<FrameSpec>> {
    let raw: RawSeries = toml::from_str(text).map_err(|e| super::toml_error(text, path, &e))?;
    if raw.frame.is_empty() {
        return Err(Error::scene(
            path,
            "frame",
            "a series file needs at least one [[frame]]",
        ));
    }
    let base = path.parent().unwrap_or(Path::new("."));
    let mut cur = FrameSpec {
        camera: scene.camera,
        transfer: scene.transfer.clone(),
        field: scene.data.field.clone(),
        mesh: scene.data.path.clone(),
    };
    let mut out = Vec::new();
    for (i, f) in raw.frame.iter().enumerate() {
        let err = |key: &str, msg: String| Error::scene(path, format!("frame[{i}].{key}"), msg);
        let xyz = |key: &str, v: &Option<Vec<f64>>, old: [f64; 3]| -> Result<[f64; 3]> {
            match v {
                None => Ok(old),
                Some(v) if v.len() == 3 => Ok([v[0], v[1], v[2]]),
                Some(v) => Err(err(key, format!("must be 3 numbers, got {}", v.len()))),
            }
        };
        cur.camera.eye = xyz("eye", &f.eye, cur.camera.eye)?;
        cur.camera.target = xyz("target", &f.target, cur.camera.target)?;
        cur.camera.up = xyz("up", &f.up, cur.camera.up)?;
        if let Some(t) = f.turn {
            if !t.is_finite() {
                return Err(err(
                    "turn",
                    format!("must be a finite angle in degrees, got {t}"),
                ));
            }
            cur.camera = super::orbit(&cur.camera, 2, t)[1];
        }
        cur.camera.check().map_err(|(_, m)| err("eye", m))?;
        if let Some(t) = &f.transfer {
            cur.transfer = transfer_from_rows(&t.points, t.unit_distance)
                .map_err(|(k, m)| err(&format!("transfer.{k}"), m))?;
        }
        if let Some(field) = &f.field {
            if field.is_empty() {
                return Err(err("field", "must name a point-data array".into()));
            }
            cur.field = field.clone();
        }
        if let Some(m) = &f.mesh {
            if m.is_empty() {
                return Err(err("mesh", "must name a mesh file".into()));
            }
            cur.mesh = base.join(m);
        }
        let repeat = f.repeat.unwrap_or(1);
        if repeat == 0 {
            return Err(err("repeat", "must be at least 1".into()));
        }
        if out.len() as u64 + repeat > MAX_FRAMES {
            return Err(err(
                "repeat",
                format!("the series would pass {MAX_FRAMES} frames"),
            ));
        }
        for _ in 0..repeat {
            out.push(cur.clone());
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scene() -> Scene {
        Scene::parse(
            r#"
[data]
path = "m.vtk"
field = "speed"
[camera]
eye = [0, 0, 10]
target = [0, 0, 0]
up = [0, 1, 0]
projection = "orthographic"
height = 4
[image]
width = 8
height = 8
[transfer]
unit_distance = 1
points = [[0, 0, 0, 0, 0], [1, 1, 1, 1, 1]]
"#,
            Path::new("/d/s.toml"),
        )
        .unwrap()
    }

    #[test]
    fn frames_carry_over_what_they_do_not_change() {
        let f = parse(
            "[[frame]]\n[[frame]]\nturn = 90\nrepeat = 2\n[[frame]]\nfield = \"p\"\nmesh = \"t1.vtk\"\n",
            Path::new("/s/series.toml"),
            &scene(),
        )
        .unwrap();
        assert_eq!(f.len(), 4);
        assert_eq!(f[0].camera, scene().camera);
        assert!((f[1].camera.eye[0] - 10.0).abs() < 1e-9);
        assert_eq!(f[1], f[2]);
        assert_eq!(f[3].camera, f[2].camera);
        assert_eq!(f[3].field, "p");
        assert_eq!(f[3].mesh, PathBuf::from("/s/t1.vtk"));
        assert_eq!(f[2].mesh, PathBuf::from("/d/m.vtk"));
    }

    fn bad(text: &str, needles: &[&str]) {
        let e = parse(text, Path::new("/s/series.toml"), &scene())
            .unwrap_err()
            .to_string();
        assert!(e.contains("/s/series.toml"), "{e}");
        for n in needles {
            assert!(e.contains(n), "{e} lacks {n}");
        }
    }

    #[test]
    fn bad_series_files_name_the_line_or_the_frame() {
        bad("[[frame]]\nzoom = 2\n", &["line 2", "zoom"]);
        bad(
            "[[frame]]\n[[frame]]\neye = [0, 0, 0]\n",
            &["frame[1].eye", "same point"],
        );
        bad("[[frame]]\neye = [1, 2]\n", &["frame[0].eye", "3 numbers"]);
        bad(
            "[[frame]]\ntransfer = { unit_distance = 1, points = [[0.5, 0, 0, 0, 0], [0.1, 0, 0, 0, 0]] }\n",
            &["frame[0].transfer.points[1]", "ascending"],
        );
        bad("[[frame]]\nrepeat = 0\n", &["frame[0].repeat"]);
        bad("", &["at least one [[frame]]"]);
        bad("[[frame]]\nturn = inf\n", &["frame[0].turn"]);
    }
}
