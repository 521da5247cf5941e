//! Scene fitting: a commented scene that frames a dataset, so nobody
//! computes an eye position by hand (`pvrsim scene`, the Python module).
//!
//! The camera looks at the centre of the data's bounding box from `--view`
//! (a side, `+x` .. `-z`, or `AZ,EL` in degrees), up = +z (+y for views
//! along z). Orthographic: the eight box corners are projected on the
//! image axes `right`, `up'`; with extents `e_x`, `e_y` and aspect
//! `a = W/H`, `height = 1.1 · max(e_y, e_x / a)` (5 % margin on each side)
//! and the eye is two diagonals away. Perspective (`--perspective FOV`):
//! the bounding sphere (radius `r` = half the diagonal) must fit the
//! narrower field of view `φ = min(fov_y, fov_x)`, with
//! `fov_x = 2 atan(a tan(fov_y / 2))`: `distance = 1.1 r / sin(φ / 2)`.
//! The transfer function spans the field's range (written as `range`):
//! ParaView's "Cool to Warm" colours, opacity rising from 0.01 to 0.3, per
//! `unit_distance` = diagonal / 50.
//!
//! Data sources plug in through [`SceneSource`] (bounds, field names and
//! range; the job layer implements it for tetrahedral meshes and regular
//! grids: `crate::job::scene_fit`). A grid's transfer function
//! is clear at the range minimum (a scan's air, a skull-stripped template's
//! zeros), so the box does not render as fog.

use std::path::{Component, Path, PathBuf};

use glam::DVec3;

/// What a fitted scene needs to know about a dataset.
pub trait SceneSource {
    /// Axis-aligned bounds `(min, max)` in world units.
    fn bounds(&self) -> ([f64; 3], [f64; 3]);
    /// Range `[min, max]` of the scalar rendered for `field` (a vector
    /// field's magnitude), or an error listing the fields there are.
    fn field_range(&self, field: &str) -> anyhow::Result<[f64; 2]>;
    /// Number of components of `field` (1: scalar).
    fn components(&self, field: &str) -> usize;
    /// What the data is, for the scene's comment ("12936 tetrahedra").
    fn describe(&self) -> String;
    /// The fields a scene may name.
    fn field_names(&self) -> Vec<String>;
    /// Transfer-function rows `[s_norm, r, g, b, opacity]` and the comment
    /// line saying what they do. Default: ParaView's Cool to Warm colours,
    /// opacity 0.01 -> 0.05 -> 0.3.
    fn transfer(&self) -> (Vec<[f64; 5]>, &'static str) {
        (
            vec![
                [0.0, 0.2300, 0.2990, 0.7540, 0.01],
                [0.5, 0.8650, 0.8650, 0.8650, 0.05],
                [1.0, 0.7060, 0.0160, 0.1500, 0.30],
            ],
            "opacity 0.01 -> 0.05 -> 0.3",
        )
    }
}

/// Unit vector from the target towards the eye, and the up vector, for `--view`.
pub fn parse_view(s: &str) -> anyhow::Result<(DVec3, DVec3)> {
    let z_up = DVec3::Z;
    let side = |d: DVec3| {
        if d.z.abs() > 0.5 {
            (d, DVec3::Y)
        } else {
            (d, z_up)
        }
    };
    Ok(match s.trim() {
        "+x" | "x" => side(DVec3::X),
        "-x" => side(-DVec3::X),
        "+y" | "y" => side(DVec3::Y),
        "-y" => side(-DVec3::Y),
        "+z" | "z" => side(DVec3::Z),
        "-z" => side(-DVec3::Z),
        other => {
            let (a, e) = other.split_once(',').ok_or_else(|| {
                anyhow::anyhow!("--view {other}: expected +x, -x, +y, -y, +z, -z or AZ,EL in degrees (e.g. 30,20)")
            })?;
            let az: f64 = a
                .trim()
                .parse()
                .map_err(|_| anyhow::anyhow!("--view {other}: azimuth `{a}` is not a number"))?;
            let el: f64 = e
                .trim()
                .parse()
                .map_err(|_| anyhow::anyhow!("--view {other}: elevation `{e}` is not a number"))?;
            anyhow::ensure!(
                az.is_finite() && el.is_finite() && (-90.0..=90.0).contains(&el),
                "--view {other}: the elevation must be in [-90, 90] degrees"
            );
            let (az, el) = (az.to_radians(), el.to_radians());
            // az = 0, el = 0: the -y side (the front view); az = 90: +x.
            let d = DVec3::new(el.cos() * az.sin(), -el.cos() * az.cos(), el.sin());
            side(d.normalize())
        }
    })
}

/// A fitted camera: eye, target, up and the projection's line.
#[derive(Debug, Clone, PartialEq)]
pub struct Fitted {
    /// Eye.
    pub eye: DVec3,
    /// Target (the box centre).
    pub target: DVec3,
    /// Up.
    pub up: DVec3,
    /// `height = ...` or `fov_y_deg = ...`.
    pub projection: (&'static str, &'static str, f64),
}

/// Fits the camera to the box `(lo, hi)` (see the module doc).
pub fn fit(
    lo: [f64; 3],
    hi: [f64; 3],
    dir: DVec3,
    up: DVec3,
    aspect: f64,
    fov: Option<f64>,
) -> Fitted {
    let (lo, hi) = (DVec3::from(lo), DVec3::from(hi));
    let centre = 0.5 * (lo + hi);
    let diag = (hi - lo).length().max(1e-12);
    let forward = -dir;
    let right = forward.cross(up).normalize();
    let up2 = right.cross(forward);
    match fov {
        None => {
            let (mut ex, mut ey) = (0.0f64, 0.0f64);
            for k in 0..8 {
                let c = DVec3::new(
                    if k & 1 == 0 { lo.x } else { hi.x },
                    if k & 2 == 0 { lo.y } else { hi.y },
                    if k & 4 == 0 { lo.z } else { hi.z },
                ) - centre;
                ex = ex.max(2.0 * c.dot(right).abs());
                ey = ey.max(2.0 * c.dot(up2).abs());
            }
            let height = (1.1 * ey.max(ex / aspect)).max(1e-9 * diag);
            Fitted {
                eye: centre + 2.0 * diag * dir,
                target: centre,
                up,
                projection: ("orthographic", "height", height),
            }
        }
        Some(fov_y) => {
            let half_y = (fov_y.to_radians() / 2.0).tan();
            let half_x = aspect * half_y;
            let phi = 2.0 * half_y.min(half_x).atan();
            let dist = 1.1 * (diag / 2.0) / (phi / 2.0).sin();
            Fitted {
                eye: centre + dist * dir,
                target: centre,
                up,
                projection: ("perspective", "fov_y_deg", fov_y),
            }
        }
    }
}

/// `to` relative to the directory `from` (both made absolute), for the
/// scene's `data.path`; `to` as given when no relative path exists.
fn relative_to(to: &Path, from_dir: &Path) -> PathBuf {
    let (Ok(to_abs), Ok(from_abs)) = (std::path::absolute(to), std::path::absolute(from_dir))
    else {
        return to.to_path_buf();
    };
    let a: Vec<Component> = to_abs.components().collect();
    let b: Vec<Component> = from_abs.components().collect();
    let common = a.iter().zip(&b).take_while(|(x, y)| x == y).count();
    if common == 0 {
        return to_abs;
    }
    let mut p = PathBuf::new();
    for _ in common..b.len() {
        p.push("..");
    }
    for c in &a[common..] {
        p.push(c);
    }
    p
}

fn v3(v: DVec3) -> String {
    format!("[{:.6}, {:.6}, {:.6}]", v.x, v.y, v.z)
}

/// Fails if any number in the TOML `text` is not finite: a scene must never
/// hold NaN or infinity (the parser of scenes rejects them, so such a file
/// would fail on its own output).
pub fn ensure_finite_toml(text: &str, what: &Path) -> anyhow::Result<()> {
    fn walk(v: &toml::Value, key: &str) -> Result<(), String> {
        match v {
            toml::Value::Float(f) if !f.is_finite() => Err(format!("`{key}` is {f}")),
            toml::Value::Array(a) => a.iter().try_for_each(|x| walk(x, key)),
            toml::Value::Table(t) => t.iter().try_for_each(|(k, x)| {
                walk(
                    x,
                    &if key.is_empty() {
                        k.clone()
                    } else {
                        format!("{key}.{k}")
                    },
                )
            }),
            _ => Ok(()),
        }
    }
    let v: toml::Value = text.parse().map_err(|e| {
        anyhow::anyhow!(
            "internal error: the scene for {} is not valid TOML: {e}",
            what.display()
        )
    })?;
    walk(&v, "").map_err(|e| {
        anyhow::anyhow!(
            "internal error: the scene for {} would hold a non-finite number: {e}; nothing written",
            what.display()
        )
    })
}

/// What to fit a scene to, besides the data: where the data file is (as
/// the scene will name it), where the scene will be written, the field,
/// the view (`--view`'s text: a side or `AZ,EL`), the image size and the
/// projection.
#[derive(Debug, Clone, PartialEq)]
pub struct FitSpec {
    /// The data file (written into the scene relative to `output`'s
    /// folder unless absolute).
    pub data: PathBuf,
    /// Where the scene will be written.
    pub output: PathBuf,
    /// The field to render (may be left out when the data has one).
    pub field: Option<String>,
    /// Where the camera is: `+x` .. `-z`, or `AZ,EL` in degrees
    /// ([`parse_view`]).
    pub view: String,
    /// Image width and height, pixels.
    pub size: (u32, u32),
    /// Perspective with this vertical field of view (degrees);
    /// orthographic when `None`.
    pub perspective: Option<f64>,
}

/// The scene text for `src` (see the module doc): a commented TOML scene
/// with the camera framing the data's bounds and the default transfer
/// function over the field's range.
pub fn scene_text(a: &FitSpec, src: &dyn SceneSource) -> anyhow::Result<String> {
    let (w, h) = a.size;
    let (dir, up) = parse_view(&a.view)?;
    let (lo, hi) = src.bounds();
    anyhow::ensure!(
        lo.iter().chain(&hi).all(|x| x.is_finite()),
        "{}: the data has no finite bounds (no points?)",
        a.data.display()
    );
    let names = src.field_names();
    let field = match (&a.field, names.as_slice()) {
        (Some(f), _) => f.to_string(),
        (None, [only]) => only.clone(),
        (None, _) => anyhow::bail!(
            "--field: {} has {} fields; name one of: {}",
            a.data.display(),
            names.len(),
            names.join(", ")
        ),
    };
    let range = src.field_range(&field)?;
    let diag = (DVec3::from(hi) - DVec3::from(lo)).length();
    anyhow::ensure!(
        diag > 0.0,
        "{}: all points coincide; nothing to frame",
        a.data.display()
    );
    let f = fit(lo, hi, dir, up, w as f64 / h as f64, a.perspective);
    let out_dir = match a.output.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    // An absolute data path stays absolute; a relative one is made relative
    // to the scene's folder (scene paths are relative to the scene file).
    let data_path = if a.data.is_absolute() {
        a.data.clone()
    } else {
        relative_to(&a.data, &out_dir)
    };
    let comps = src.components(&field);
    let mut t = String::new();
    t.push_str(&format!(
        "# Written by `pvrsim scene {} --field {} --view {} --size {}x{}{}`.\n",
        a.data.display(),
        field,
        a.view,
        w,
        h,
        a.perspective
            .map_or(String::new(), |f| format!(" --perspective {f}"))
    ));
    t.push_str(&format!("# Data: {}.\n", src.describe()));
    t.push_str(&format!(
        "# Bounding box: x [{:.6}, {:.6}], y [{:.6}, {:.6}], z [{:.6}, {:.6}]; diagonal {:.6}.\n",
        lo[0], hi[0], lo[1], hi[1], lo[2], hi[2], diag
    ));
    t.push_str(&format!(
        "# Camera: looks at the box centre from direction {} (view `{}`); {}.\n",
        v3(f.eye - f.target),
        a.view,
        if a.perspective.is_some() {
            "the bounding sphere fits the narrower field of view with a 10 % margin"
        } else {
            "orthographic height = 1.1 x the projected box extent (5 % margin on each side); eye two diagonals away"
        }
    ));
    let (rows, tf_about) = src.transfer();
    t.push_str("# Transfer function: ParaView's Cool to Warm colours over the field's range;\n");
    t.push_str(&format!(
        "# {tf_about} per unit_distance = diagonal / 50. Edit to taste.\n\n"
    ));
    t.push_str("[data]\n");
    t.push_str(&format!("path  = {:?}\n", data_path.to_string_lossy()));
    t.push_str(&format!("field = {field:?}"));
    if comps > 1 {
        t.push_str(&format!(
            "   # {comps} components: rendered as the magnitude |v|"
        ));
    }
    t.push('\n');
    t.push_str(&format!(
        "range = [{:?}, {:?}]   # the field's min and max\n\n",
        range[0], range[1]
    ));
    t.push_str("[camera]\n");
    t.push_str(&format!("eye        = {}\n", v3(f.eye)));
    t.push_str(&format!("target     = {}\n", v3(f.target)));
    t.push_str(&format!("up         = {}\n", v3(f.up)));
    t.push_str(&format!("projection = \"{}\"\n", f.projection.0));
    t.push_str(&format!(
        "{:<10} = {:.6}\n\n",
        f.projection.1, f.projection.2
    ));
    t.push_str("[image]\n");
    t.push_str(&format!(
        "width      = {w}\nheight     = {h}\nbackground = [0.0, 0.0, 0.0]\n\n"
    ));
    t.push_str("[transfer]\n");
    t.push_str(&format!("unit_distance = {:.6}\n", diag / 50.0));
    t.push_str("points = [\n");
    for r in rows {
        t.push_str(&format!(
            "  [{:.4}, {:.4}, {:.4}, {:.4}, {:.4}],\n",
            r[0], r[1], r[2], r[3], r[4]
        ));
    }
    t.push_str("]\n");
    ensure_finite_toml(&t, &a.output)?;
    Ok(t)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn views_parse() {
        assert_eq!(parse_view("-y").unwrap().0, -DVec3::Y);
        assert_eq!(parse_view("+z").unwrap().1, DVec3::Y);
        let (d, _) = parse_view("90,0").unwrap();
        assert!((d - DVec3::X).length() < 1e-12);
        assert!(parse_view("up").is_err());
        assert!(parse_view("0,95").is_err());
    }

    #[test]
    fn orthographic_fit_holds_the_box_with_margin() {
        // A 10 x 2 x 4 box seen from -y on a square image: x is the wider extent.
        let f = fit([0.0; 3], [10.0, 2.0, 4.0], -DVec3::Y, DVec3::Z, 1.0, None);
        assert_eq!(f.projection.2, 11.0);
        assert_eq!(f.target, DVec3::new(5.0, 1.0, 2.0));
        // Every corner projects inside the view.
        let f = fit([0.0; 3], [1.0, 1.0, 8.0], -DVec3::Y, DVec3::Z, 2.0, None);
        assert!((f.projection.2 - 8.8).abs() < 1e-12);
    }

    #[test]
    fn non_finite_numbers_are_refused() {
        let p = Path::new("x.toml");
        assert!(ensure_finite_toml("[camera]\neye = [1.0, 2.0, 3.0]\n", p).is_ok());
        let e = ensure_finite_toml("[camera]\neye = [nan, inf, 1.0]\n", p).unwrap_err();
        assert!(e.to_string().contains("camera.eye"), "{e}");
    }
}
