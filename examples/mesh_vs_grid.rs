//! The cell renderer and the grid renderers on one physical field: a mesh
//! scene's field sampled on grids of growing size (`pvrsim generate
//! mesh-field`, `data::volume::from_mesh`), each grid rendered by `slice3d`
//! and by the grid reference, every image compared (f32, max-abs and RMSE
//! in 1/255) with the mesh's reference image (the f64 oracle through the
//! tetrahedra) beside the cell renderer's own error.
//!
//! ```text
//! cargo run --release --example mesh_vs_grid -- SCENE N1,N2,...
//! ```
//!
//! `N` = samples along the mesh's longest axis (the others in proportion).
//! The gap between the grid reference and the mesh reference is the
//! resampling error alone (trilinear of samples vs the barycentric field);
//! the gap between slice3d and the grid reference is the slicer's.

use std::path::Path;
use std::sync::Arc;

use pvrsim::data::volume::from_mesh::{dims_along_longest, sample_mesh_field};
use pvrsim::render::cell::{self, CellOptions};
use pvrsim::render::slice3d::{self, Slice3dOptions};
use pvrsim::render::{grid_reference, reference, RenderInput, VolumeInput};
use pvrsim::scene::Scene;

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    anyhow::ensure!(args.len() == 2, "usage: mesh_vs_grid SCENE N1,N2,...");
    let scene = Scene::load(Path::new(&args[0]))?;
    let sizes: Vec<u64> = args[1]
        .split(',')
        .map(|s| s.trim().parse())
        .collect::<Result<_, _>>()?;
    let mesh = Arc::new(pvrsim::data::io::read_mesh(&scene.data.path)?);
    let input = RenderInput::new(scene.clone(), mesh.clone())?;
    let t = std::time::Instant::now();
    let (mref, _) = reference::render(&input, &mesh.adjacency(), &Default::default());
    let ref_s = t.elapsed().as_secs_f64();
    let (cimg, _) = cell::render(&input, &CellOptions::default());
    let ce = cimg.error_against(&mref);
    println!(
        "{}: mesh reference {ref_s:.1} s; cell renderer vs mesh reference: max {:.2} / RMSE {:.3} (1/255)",
        args[0], ce.max_abs, ce.rmse
    );
    println!("| N | grid | voxels | grid reference vs mesh reference | slice3d vs mesh reference | slice3d vs grid reference |");
    println!("|---|---|---|---|---|---|");
    let values = mesh.scalar(&scene.data.field)?;
    let range = input.range;
    let (lo, hi) = mesh.bounds();
    for n in sizes {
        let dims = dims_along_longest(lo, hi, n)
            .ok_or_else(|| anyhow::anyhow!("N = {n}: need N >= 2 and a non-empty mesh box"))?;
        let vol = sample_mesh_field(
            &mesh,
            &scene.data.field,
            &values,
            dims,
            range[0],
            &scene.data.path,
        )?;
        let mut gs = scene.clone();
        gs.data.range = Some(range);
        let vin = VolumeInput::new(gs, Arc::new(vol))?;
        let (gref, _) = grid_reference::render(&vin, &Default::default());
        let (simg, _) = slice3d::render(&vin, &Slice3dOptions::default())?;
        let (a, b, c) = (
            gref.error_against(&mref),
            simg.error_against(&mref),
            simg.error_against(&gref),
        );
        println!(
            "| {n} | {}x{}x{} | {} | {:.2} / {:.3} | {:.2} / {:.3} | {:.2} / {:.3} |",
            dims[0],
            dims[1],
            dims[2],
            dims.iter().product::<u64>(),
            a.max_abs,
            a.rmse,
            b.max_abs,
            b.rmse,
            c.max_abs,
            c.rmse
        );
    }
    Ok(())
}
