//! Running a render job: options validated once
//! ([`Valid<RenderArgs>`](super::validate::Valid)), the scene read once and
//! handed to the mesh path ([`super::render::mesh`]) or the grid path
//! ([`super::render::grid`]) by what its data is.

use super::render::{RenderArgs, RenderOutcome};
use super::validate::Valid;

/// Renders as `pvrsim render` would: the image, the statistics and the
/// lines the command prints; with `quiet` no `--compare` strip is written
/// and no warning printed. Validates `a` and runs it (see
/// [`Valid::run`](Valid#method.run)).
pub fn render(a: &RenderArgs, quiet: bool) -> anyhow::Result<RenderOutcome> {
    Valid::new(a)?.run(quiet)
}

impl Valid<'_, RenderArgs> {
    /// Renders validated options: used by `render`, by
    /// [`super::RenderJob::run`] and by sweeps, so that a sweep can vary
    /// any option `render` has, under the same name.
    pub fn run(&self, quiet: bool) -> anyhow::Result<RenderOutcome> {
        let a = self.args();
        let scene = super::load_scene(&a.scene)?;
        if super::render::grid::is_grid_scene(&scene) {
            super::render::grid::execute(a, scene, quiet)
        } else {
            super::render::mesh::execute(self, scene, quiet)
        }
    }
}
