//! Scene fitting as a job: the data file read once as a
//! [`SceneSource`] (tetrahedral meshes and regular grids), the scene text
//! fitted to it by [`crate::scene::fit`]. `pvrsim scene` and the Python
//! module call it.

use std::path::Path;

use anyhow::Context;

use crate::scene::fit::{FitSpec, SceneSource};

impl SceneSource for crate::data::Volume {
    fn bounds(&self) -> ([f64; 3], [f64; 3]) {
        crate::data::Volume::bounds(self)
    }
    fn field_range(&self, field: &str) -> anyhow::Result<[f64; 2]> {
        anyhow::ensure!(
            field == self.field,
            "the grid's scalar is \"{}\", not \"{field}\"",
            self.field
        );
        Ok(self.value_range())
    }
    fn components(&self, _field: &str) -> usize {
        1
    }
    fn describe(&self) -> String {
        format!(
            "regular grid, {} x {} x {} voxels of {}, spacing ({}, {}, {})",
            self.dims[0],
            self.dims[1],
            self.dims[2],
            self.voxels.voxel_type().name(),
            self.spacing[0],
            self.spacing[1],
            self.spacing[2]
        )
    }
    fn field_names(&self) -> Vec<String> {
        vec![self.field.clone()]
    }
    fn transfer(&self) -> (Vec<[f64; 5]>, &'static str) {
        (
            vec![
                [0.0, 0.2300, 0.2990, 0.7540, 0.0],
                [0.1, 0.2300, 0.2990, 0.7540, 0.0],
                [0.5, 0.8650, 0.8650, 0.8650, 0.05],
                [1.0, 0.7060, 0.0160, 0.1500, 0.30],
            ],
            "opacity 0 up to 10 % of the range (the grid's background), then 0 -> 0.05 -> 0.3",
        )
    }
}

impl SceneSource for crate::data::TetMesh {
    fn bounds(&self) -> ([f64; 3], [f64; 3]) {
        crate::data::TetMesh::bounds(self)
    }
    fn field_range(&self, field: &str) -> anyhow::Result<[f64; 2]> {
        let s = self.scalar(field)?;
        let lo = s.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = s.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        anyhow::ensure!(
            lo.is_finite() && hi.is_finite(),
            "field \"{field}\" has no values"
        );
        Ok([lo, hi])
    }
    fn components(&self, field: &str) -> usize {
        self.fields
            .iter()
            .find(|f| f.name == field)
            .map_or(1, |f| f.components)
    }
    fn describe(&self) -> String {
        format!(
            "{} tetrahedra, {} vertices",
            self.tets.len(),
            self.points.len()
        )
    }
    fn field_names(&self) -> Vec<String> {
        self.fields.iter().map(|f| f.name.clone()).collect()
    }
}

/// Reads the data file named by `path` as every command does
/// ([`crate::data::read_dataset`]: every mesh and grid format the readers
/// know, `.pvtu` included); `field` selects the array of a grid format that
/// holds several (VTI).
pub fn load_source(path: &Path, field: Option<&str>) -> anyhow::Result<Box<dyn SceneSource>> {
    let data = crate::data::read_dataset(path, field.unwrap_or(""))
        .with_context(|| format!("cannot read {}", path.display()))?;
    Ok(match data {
        crate::data::Dataset::Mesh(m) => Box::new(m),
        crate::data::Dataset::Volume(v) => Box::new(v),
    })
}

/// Reads the data of `spec` and fits a scene to it: the scene text, which
/// parses as the renderers will read it.
pub fn fit_scene(spec: &FitSpec) -> anyhow::Result<String> {
    let src = load_source(&spec.data, spec.field.as_deref())?;
    let text = crate::scene::fit::scene_text(spec, src.as_ref())?;
    crate::scene::Scene::parse(&text, &spec.output).with_context(|| {
        format!(
            "internal error: the fitted scene for {} does not parse",
            spec.data.display()
        )
    })?;
    Ok(text)
}
