//! Running a render job: validate, load the scene, and hand it to the mesh
//! path ([`super::render_mesh`]) or the grid path ([`super::render_grid`])
//! by what its data is.

use anyhow::Context;

use super::render::{RenderArgs, RenderOutcome};
use super::validate;

/// Renders as `pvrsim render` would: the image, the statistics and the
/// lines the command prints; with `quiet` no `--compare` strip is written
/// and no warning printed. Used by `render`, by [`super::RenderJob::run`] and by
/// sweeps, so that a sweep can vary any option `render` has, under the
/// same name.
pub fn render(a: &RenderArgs, quiet: bool) -> anyhow::Result<RenderOutcome> {
    validate::check(a)?;
    let scene = crate::scene::Scene::load(&a.scene)
        .with_context(|| format!("cannot load scene {}", a.scene.display()))?;
    if super::render_grid::is_grid_scene(&scene) {
        super::render_grid::execute(a, scene, quiet)
    } else {
        super::render_mesh::execute(a, quiet)
    }
}
