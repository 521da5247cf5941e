//! The demo's ERT scene (`demo-ert.toml`): the demo mesh and camera of
//! `demo.toml` with every opacity made stronger, so that early ray
//! termination visibly pays — the scene `pvrsim demo` runs on the simulated
//! cluster.
//!
//! `demo.toml` is translucent on purpose (a ray across the parent vessel
//! just reaches alpha 0.9 at its back wall), so a perfect ERT test could skip
//! only about 1 % of its cells. Dividing `unit_distance` by
//! [`WALL_FACTOR`] = 3 multiplies every segment's optical depth by 3: the
//! slow, opaque near-wall shell (TF opacity 0.65 for s in 0.10–0.24) on the
//! camera's side then reaches alpha 0.9 by itself, rays terminate there, and
//! the back half of every vessel can be skipped. Measured on the default
//! mesh (150,365 cells, `pvrsim render demo/demo-ert.toml --threads 1 --ert
//! 0.9 --oracle`): the oracle skips 53 % of the cells (1.3 % on `demo.toml`).
//! `pvrsim demo` prints the oracle share of the mesh it generated.

use std::path::Path;

use crate::scene::Scene;

/// `unit_distance` of `demo.toml` divided by this gives `demo-ert.toml`'s.
pub const WALL_FACTOR: f64 = 3.0;

/// The ERT scene text from the demo scene text `base` (read from `path`,
/// for errors): the same file with `unit_distance` divided by
/// [`WALL_FACTOR`] (two significant digits, written as used) and a comment
/// block on top saying why.
pub fn ert_scene_toml(base: &str, path: &Path) -> anyhow::Result<String> {
    let scene = Scene::parse(base, path).map_err(|e| anyhow::anyhow!("{e}"))?;
    let ud0 = scene.transfer.unit_distance;
    let exact = ud0 / WALL_FACTOR;
    let decimals = (1.0 - exact.log10().floor()).max(0.0) as usize;
    let ud: f64 = format!("{exact:.decimals$}").parse().unwrap_or(exact);
    let mut out = String::new();
    out += "# demo-ert.toml: demo.toml with every opacity stronger, so that early ray termination pays.\n";
    out += &format!(
        "# unit_distance = {ud} mm instead of {ud0} mm (divided by {WALL_FACTOR}): each segment's optical depth is\n"
    );
    out += &format!("# {WALL_FACTOR}x demo.toml's, so the slow, opaque near-wall shell (opacity 0.65 for s 0.10-0.24) on the\n");
    out += "# camera's side reaches alpha 0.9 by itself: rays terminate in the vessel's front wall and the cells of its\n";
    out += "# back half can be skipped (pvrsim demo prints the oracle's share of skippable cells; about half).\n";
    out += "# The comments below are demo.toml's: their alpha figures are for demo.toml's unit_distance.\n#\n";
    let mut replaced = false;
    for line in base.lines() {
        if !replaced && line.trim_start().starts_with("unit_distance") {
            out += &format!("unit_distance = {ud}\n");
            replaced = true;
        } else {
            out += line;
            out.push('\n');
        }
    }
    anyhow::ensure!(
        replaced,
        "{}: no unit_distance line in the demo scene",
        path.display()
    );
    let check = Scene::parse(&out, path).map_err(|e| anyhow::anyhow!("{e}"))?;
    anyhow::ensure!(
        (check.transfer.unit_distance - ud).abs() <= 1e-12 * ud.abs(),
        "{}: demo-ert.toml's unit_distance did not take",
        path.display()
    );
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn divides_unit_distance_and_keeps_the_rest() {
        let params = crate::data::demo::DemoParams {
            cells_target: 2_000,
            ..Default::default()
        };
        let (_, base) = crate::data::demo::demo_mesh_and_scene(&params, "demo.vtk");
        let p = Path::new("demo.toml");
        let t = ert_scene_toml(&base, p).unwrap();
        let s = Scene::parse(&t, p).unwrap();
        let s0 = Scene::parse(&base, p).unwrap();
        let want = s0.transfer.unit_distance / WALL_FACTOR;
        assert!((s.transfer.unit_distance - want).abs() <= 0.05 * want);
        assert!(s.transfer.unit_distance < s0.transfer.unit_distance);
        assert_eq!(s.transfer.points.len(), s0.transfer.points.len());
        assert_eq!(s.image.width, s0.image.width);
        assert!(t.starts_with("# demo-ert.toml"));
        assert!(ert_scene_toml("[data]\n", p).is_err());
    }
}
