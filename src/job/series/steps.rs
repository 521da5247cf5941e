//! The frames of a mesh series as steps ([`crate::cluster::series::Step`]):
//! an orbit (`--frames N --turn DEG`) of the scene, or a series file
//! (`--series FILE.toml`) whose time steps' meshes and fields are loaded
//! and checked here, all before the first frame runs.

use std::path::PathBuf;
use std::sync::Arc;

use anyhow::Context;

use crate::cluster::series::Step;
use crate::job::series::args::SeriesArgs;
use crate::render::RenderInput;

/// The series' data states (the scene's first) and one step per frame.
pub fn mesh_steps(
    s: &SeriesArgs,
    mut input: RenderInput,
) -> anyhow::Result<(Vec<RenderInput>, Vec<Step>)> {
    // Time steps are numbered as the scene's mesh, then the mapping goes.
    let like = input.renumbering.take();
    let Some(path) = &s.series else {
        let image = &input.scene.image;
        let steps = s
            .orbit_cameras(
                &input.scene.camera,
                image.width,
                image.height,
                &input.mesh.points,
            )?
            .into_iter()
            .map(|camera| Step {
                data: 0,
                camera,
                transfer: input.scene.transfer.clone(),
            })
            .collect();
        return Ok((vec![input], steps));
    };
    let specs = crate::scene::series::load(path, &input.scene)?;
    data_states(specs, input, like.as_deref(), path)
}

/// The data states of `specs` (frames naming a mesh and a field): the
/// scene's `input` first, then each other (mesh, field) pair once (its
/// mesh read numbered as the scene's, `like`, and checked for the scene
/// mesh's topology), with one step per spec naming its state. `origin`
/// names the specs' file in errors. The series' and the live viewer's
/// time steps and fields (`pvrsim view --series`).
pub fn data_states(
    specs: Vec<crate::scene::series::FrameSpec>,
    input: RenderInput,
    like: Option<&crate::data::locality::Renumbering>,
    origin: &std::path::Path,
) -> anyhow::Result<(Vec<RenderInput>, Vec<Step>)> {
    let path = origin;
    let base = input.mesh.clone();
    let mut keys: Vec<(PathBuf, String)> = vec![(
        input.scene.data.path.clone(),
        input.scene.data.field.clone(),
    )];
    let mut meshes: Vec<(PathBuf, Arc<crate::data::TetMesh>)> =
        vec![(input.scene.data.path.clone(), base.clone())];
    let mut inputs = vec![input];
    let mut steps = Vec::with_capacity(specs.len());
    for (i, f) in specs.into_iter().enumerate() {
        let key = (f.mesh.clone(), f.field.clone());
        let data = match keys.iter().position(|k| *k == key) {
            Some(d) => d,
            None => {
                let at = || format!("{}: frame {i}", path.display());
                let mesh = match meshes.iter().find(|(p, _)| *p == f.mesh) {
                    Some((_, m)) => m.clone(),
                    None => {
                        let m = crate::data::io::read_mesh_like(&f.mesh, like)
                            .with_context(|| format!("{}: the time step's mesh", at()))?;
                        anyhow::ensure!(
                            m.points.len() == base.points.len() && m.tets == base.tets,
                            "{}: the time step {} has {} vertices and {} cells{}, the scene's mesh {} and {}: a time step must have the scene mesh's topology",
                            at(),
                            f.mesh.display(),
                            m.points.len(),
                            m.tets.len(),
                            if m.tets.len() == base.tets.len() { " (other connectivity)" } else { "" },
                            base.points.len(),
                            base.tets.len()
                        );
                        let m = Arc::new(m);
                        meshes.push((f.mesh.clone(), m.clone()));
                        m
                    }
                };
                let mut scene = inputs[0].scene.clone();
                scene.data.path = f.mesh.clone();
                scene.data.field = f.field.clone();
                let mut input = RenderInput::new(scene, mesh)
                    .with_context(|| format!("{}: field {:?}", at(), f.field))?;
                // Same topology: the scene's pieces (if any) place it too.
                input.pieces = inputs[0].pieces.clone();
                keys.push(key);
                inputs.push(input);
                inputs.len() - 1
            }
        };
        steps.push(Step {
            data,
            camera: f.camera,
            transfer: f.transfer,
        });
    }
    Ok((inputs, steps))
}
