//! The scene contract (`shared/spec/scene.md`): which data to render, the
//! camera, the image and the transfer function. Every renderer reads a scene
//! through [`Scene::load`] and means the same thing by it.
//!
//! Parsing is two steps, as in ripgrep's flags: serde reads the TOML into
//! `Raw*` structs that reject unknown keys, then `Scene::from_raw` checks
//! every value and names the key of the first one that is impossible.

pub mod camera;
pub mod fit;
pub mod orbit;
pub mod series;
pub mod transfer;

use std::path::{Path, PathBuf};

use serde::Deserialize;

pub use camera::{Camera, Projection, View};
pub use orbit::orbit;
pub use transfer::{ControlPoint, TransferFunction};

use crate::error::{Error, Result};

/// Which data file and field to render.
#[derive(Debug, Clone, PartialEq)]
pub struct DataSpec {
    /// Path of the data file, resolved against the scene file's folder.
    pub path: PathBuf,
    /// Point-data array to render.
    pub field: String,
    /// Scalar range mapped to `[0, 1]`; `None`: the field's min and max.
    pub range: Option<[f64; 2]>,
}

/// Output image.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ImageSpec {
    /// Width in pixels (> 0).
    pub width: u32,
    /// Height in pixels (> 0).
    pub height: u32,
    /// Background RGB in `[0, 1]`.
    pub background: [f64; 3],
}

/// A validated scene.
#[derive(Debug, Clone, PartialEq)]
pub struct Scene {
    /// Data file and field.
    pub data: DataSpec,
    /// Camera.
    pub camera: Camera,
    /// Image size and background.
    pub image: ImageSpec,
    /// Transfer function.
    pub transfer: TransferFunction,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawScene {
    data: RawData,
    camera: RawCamera,
    image: RawImage,
    transfer: RawTransfer,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawData {
    path: String,
    field: String,
    range: Option<Vec<f64>>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawCamera {
    eye: Vec<f64>,
    target: Vec<f64>,
    up: Vec<f64>,
    projection: String,
    height: Option<f64>,
    fov_y_deg: Option<f64>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawImage {
    width: i64,
    height: i64,
    #[serde(default = "black")]
    background: Vec<f64>,
}

fn black() -> Vec<f64> {
    vec![0.0; 3]
}

/// A fixed-size array of the scene: exactly `N` numbers, more or fewer is
/// an error naming `key`.
fn fixed<const N: usize>(path: &Path, key: &str, v: &[f64]) -> Result<[f64; N]> {
    <[f64; N]>::try_from(v).map_err(|_| {
        Error::scene(
            path,
            key,
            format!("must have exactly {N} numbers, got {}: {v:?}", v.len()),
        )
    })
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawTransfer {
    unit_distance: f64,
    points: Vec<Vec<f64>>,
}

#[cfg(test)]
thread_local! {
    /// Scene files read on this thread (tests count them per command).
    static LOADS: std::cell::Cell<usize> = const { std::cell::Cell::new(0) };
}

/// How many scene files [`Scene::load`] read on this thread (tests: a
/// command reads its scene once).
#[cfg(test)]
pub(crate) fn loads_on_this_thread() -> usize {
    LOADS.with(|n| n.get())
}

impl Scene {
    /// Reads and validates a scene file.
    pub fn load(path: &Path) -> Result<Scene> {
        #[cfg(test)]
        LOADS.with(|n| n.set(n.get() + 1));
        let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
        Scene::parse(&text, path)
    }

    /// Parses scene TOML; `path` is used for error messages and to resolve
    /// the data path.
    pub fn parse(text: &str, path: &Path) -> Result<Scene> {
        let raw: RawScene = toml::from_str(text).map_err(|e| toml_error(text, path, &e))?;
        Scene::from_raw(raw, path)
    }

    fn from_raw(raw: RawScene, path: &Path) -> Result<Scene> {
        let err = |key: &str, msg: String| Error::scene(path, key, msg);

        // [data]
        let base = path.parent().unwrap_or(Path::new("."));
        let data_path = base.join(&raw.data.path);
        if raw.data.field.is_empty() {
            return Err(err("data.field", "must name a point-data array".into()));
        }
        let range = match &raw.data.range {
            Some(r) => Some(fixed::<2>(path, "data.range", r)?),
            None => None,
        };
        if let Some([a, b]) = range {
            if !(a.is_finite() && b.is_finite() && a < b) {
                return Err(err(
                    "data.range",
                    format!("must be two finite numbers with range[0] < range[1], got [{a}, {b}]"),
                ));
            }
        }

        // [camera]
        let projection = match raw.camera.projection.as_str() {
            "orthographic" => Projection::Orthographic {
                height: raw.camera.height.ok_or_else(|| {
                    err(
                        "camera.height",
                        "required for an orthographic camera".into(),
                    )
                })?,
            },
            "perspective" => Projection::Perspective {
                fov_y_deg: raw.camera.fov_y_deg.ok_or_else(|| {
                    err(
                        "camera.fov_y_deg",
                        "required for a perspective camera".into(),
                    )
                })?,
            },
            other => {
                return Err(err(
                    "camera.projection",
                    format!("must be \"orthographic\" or \"perspective\", got \"{other}\""),
                ))
            }
        };
        let camera = Camera {
            eye: fixed::<3>(path, "camera.eye", &raw.camera.eye)?,
            target: fixed::<3>(path, "camera.target", &raw.camera.target)?,
            up: fixed::<3>(path, "camera.up", &raw.camera.up)?,
            projection,
        };
        camera.check().map_err(|(k, m)| err(k, m))?;

        // [image]
        let dim = |key: &str, v: i64| -> Result<u32> {
            if (1..=65536).contains(&v) {
                Ok(v as u32)
            } else {
                Err(err(
                    key,
                    format!("must be between 1 and 65536 pixels, got {v}"),
                ))
            }
        };
        let width = dim("image.width", raw.image.width)?;
        let height = dim("image.height", raw.image.height)?;
        let background = fixed::<3>(path, "image.background", &raw.image.background)?;
        if background.iter().any(|c| !(0.0..=1.0).contains(c)) {
            return Err(err(
                "image.background",
                format!(
                    "RGB components must be in [0, 1], got {:?}",
                    raw.image.background
                ),
            ));
        }

        // [transfer]
        let transfer = transfer_from_rows(&raw.transfer.points, raw.transfer.unit_distance)
            .map_err(|(k, m)| err(&format!("transfer.{k}"), m))?;

        Ok(Scene {
            data: DataSpec {
                path: data_path,
                field: raw.data.field,
                range,
            },
            camera,
            image: ImageSpec {
                width,
                height,
                background,
            },
            transfer,
        })
    }

    /// The camera frame for this scene's image size.
    pub fn view(&self) -> View {
        self.camera.view(self.image.width, self.image.height)
    }

    /// Writes the scene back as TOML in the spec's format (data path as given,
    /// made relative by the caller if needed).
    pub fn to_toml(&self, data_path: &str) -> String {
        let c = &self.camera;
        let (proj, extra) = match c.projection {
            Projection::Orthographic { height } => {
                ("orthographic", format!("height     = {height}"))
            }
            Projection::Perspective { fov_y_deg } => {
                ("perspective", format!("fov_y_deg  = {fov_y_deg}"))
            }
        };
        let mut s = String::new();
        s += &format!(
            "[data]\npath  = {:?}\nfield = {:?}\n",
            data_path, self.data.field
        );
        if let Some([a, b]) = self.data.range {
            s += &format!("range = [{a}, {b}]\n");
        }
        s += &format!(
            "\n[camera]\neye        = {:?}\ntarget     = {:?}\nup         = {:?}\nprojection = \"{proj}\"\n{extra}\n",
            c.eye, c.target, c.up
        );
        s += &format!(
            "\n[image]\nwidth      = {}\nheight     = {}\nbackground = {:?}\n",
            self.image.width, self.image.height, self.image.background
        );
        s += &format!(
            "\n[transfer]\nunit_distance = {}\npoints = [\n",
            self.transfer.unit_distance
        );
        for p in &self.transfer.points {
            s += &format!(
                "  [{}, {}, {}, {}, {}],\n",
                p.s, p.rgb[0], p.rgb[1], p.rgb[2], p.opacity
            );
        }
        s += "]\n";
        s
    }
}

/// A TOML error of the file at `path` (text `text`) as a scene error: the
/// key it names, `line N` (an unknown key's own line: its span is the
/// table, so the first line from there that sets the key) and the message.
pub(crate) fn toml_error(text: &str, path: &Path, e: &toml::de::Error) -> Error {
    let key = e.message().split('`').nth(1).unwrap_or("").to_string();
    let line = e.span().map(|s| {
        let from = text[..s.start].lines().count().max(1);
        text.lines()
            .enumerate()
            .skip(from - 1)
            .find(|(_, l)| !key.is_empty() && l.trim_start().starts_with(key.as_str()))
            .map_or(from, |(i, _)| i + 1)
    });
    let msg = match line {
        Some(l) => format!("line {l}: {}", e.message().trim()),
        None => e.message().trim().to_string(),
    };
    Error::scene(
        path,
        if key.is_empty() { "(file)".into() } else { key },
        msg,
    )
}

/// A transfer function from rows `[s, r, g, b, opacity]` and its unit
/// distance, checked as the scene contract's `[transfer]` table is; an
/// error names the key under the table (`points[3]`, `unit_distance`).
pub fn transfer_from_rows(
    points_in: &[Vec<f64>],
    unit_distance: f64,
) -> std::result::Result<TransferFunction, (String, String)> {
    let ud = unit_distance;
    if !(ud > 0.0 && ud.is_finite()) {
        return Err((
            "unit_distance".into(),
            format!("must be a finite number > 0, got {ud}"),
        ));
    }
    if points_in.is_empty() {
        return Err(("points".into(), "needs at least one control point".into()));
    }
    let mut points = Vec::with_capacity(points_in.len());
    for (i, p) in points_in.iter().enumerate() {
        let key = format!("points[{i}]");
        if p.len() != 5 {
            return Err((
                key,
                format!("must be [s, r, g, b, opacity], got {} numbers", p.len()),
            ));
        }
        if p.iter().any(|v| !v.is_finite()) {
            return Err((key, "must hold finite numbers".into()));
        }
        if !(0.0..=1.0).contains(&p[0]) {
            return Err((key, format!("s = {} is outside [0, 1]", p[0])));
        }
        if p[1..4].iter().any(|c| !(0.0..=1.0).contains(c)) {
            return Err((
                key,
                format!("colour {:?} has a component outside [0, 1]", &p[1..4]),
            ));
        }
        if !(0.0..=1.0).contains(&p[4]) {
            return Err((key, format!("opacity {} is outside [0, 1]", p[4])));
        }
        if let Some(prev) = points.last() {
            let prev: &ControlPoint = prev;
            if p[0] < prev.s {
                return Err((key, format!("s = {} is less than the previous point's s = {}: control points must be in ascending order", p[0], prev.s)));
            }
        }
        points.push(ControlPoint {
            s: p[0],
            rgb: [p[1], p[2], p[3]],
            opacity: p[4],
        });
    }

    Ok(TransferFunction {
        points,
        unit_distance: ud,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const GOOD: &str = r#"
[data]
path = "x.vtk"
field = "speed"
[camera]
eye = [0.0, -200.0, 0.0]
target = [0.0, 0.0, 0.0]
up = [0.0, 0.0, 1.0]
projection = "orthographic"
height = 120.0
[image]
width = 30
height = 20
background = [0.0, 0.0, 0.0]
[transfer]
unit_distance = 1.0
points = [[0.0, 0.0, 0.0, 1.0, 0.0], [1.0, 1.0, 0.0, 0.0, 0.2]]
"#;

    fn key_of(text: &str) -> String {
        match Scene::parse(text, Path::new("s.toml")) {
            Err(Error::Scene { key, .. }) => key,
            other => panic!("expected a scene error, got {other:?}"),
        }
    }

    #[test]
    fn parses_the_spec_example() {
        let s = Scene::parse(GOOD, Path::new("dir/s.toml")).unwrap();
        assert_eq!(s.data.path, Path::new("dir/x.vtk"));
        assert_eq!(s.image.width, 30);
        let round = Scene::parse(&s.to_toml("x.vtk"), Path::new("dir/s.toml")).unwrap();
        assert_eq!(round, s);
    }

    #[test]
    fn errors_name_the_key() {
        assert_eq!(
            key_of(&GOOD.replace("width = 30", "width = 0")),
            "image.width"
        );
        assert_eq!(
            key_of(&GOOD.replace("target = [0.0, 0.0, 0.0]", "target = [0.0, -200.0, 0.0]")),
            "camera.target"
        );
        assert_eq!(
            key_of(&GOOD.replace("up = [0.0, 0.0, 1.0]", "up = [0.0, 1.0, 0.0]")),
            "camera.up"
        );
        assert_eq!(
            key_of(&GOOD.replace("[1.0, 1.0, 0.0, 0.0, 0.2]", "[1.0, 1.0, 0.0, 0.0, 1.2]")),
            "transfer.points[1]"
        );
        assert_eq!(
            key_of(&GOOD.replace(
                "[[0.0, 0.0, 0.0, 1.0, 0.0], [1.0,",
                "[[0.5, 0.0, 0.0, 1.0, 0.0], [0.2,"
            )),
            "transfer.points[1]"
        );
        assert_eq!(
            key_of(&GOOD.replace("height = 120.0", "height = 120.0\nzoom = 2")),
            "zoom"
        );
        assert_eq!(
            key_of(&GOOD.replace("unit_distance = 1.0", "unit_distance = 0.0")),
            "transfer.unit_distance"
        );
    }
}
