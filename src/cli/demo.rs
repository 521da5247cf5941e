//! `pvrsim demo`: the quick start. Generates the built-in bifurcation dataset,
//! writes it with its scene (and the demo volume, a 64^3 hydrogen atom, with
//! its scene), renders it, then renders its ERT variant (`demo-ert.toml`:
//! opaque vessel walls) on the simulated 8-node cluster (ERT + SHARE + DLB,
//! virtual clock, `gbe`, `pentium4`; `demo_cluster.rs`), and prints Base
//! beside ERT+DLB+SHARE.

use std::path::PathBuf;

use anyhow::Context;
use clap::Args;

use super::validate::{self, Checks, Validate};
use crate::data::demo::{demo_mesh_and_scene, DemoParams};
use crate::render::cell::{self, CellOptions};
use crate::render::RenderInput;
use crate::scene::Scene;

/// Options of `pvrsim demo`.
#[derive(Debug, Args)]
pub struct DemoArgs {
    /// Folder for demo.vtk, demo.toml, demo.png, demo-stats.json, and the
    /// cluster's cluster.png, timeline.png and cluster-report.json.
    #[arg(long, default_value = "demo")]
    pub out_dir: PathBuf,
    /// About how many tetrahedra to generate, 1,000 to 20,000,000 (to
    /// 100,000,000 with `--pieces` and `--nodes 0`: the pieces are written,
    /// not rendered, above 20,000,000; render them with `pvrsim cluster
    /// --transport processes`, each worker reading its own).
    #[arg(long, default_value_t = 150_000)]
    pub cells: usize,
    /// Worker threads; 0 = all cores.
    #[arg(long, default_value_t = 0)]
    pub threads: usize,
    /// Nodes of the simulated cluster run; 0 skips it.
    #[arg(long, default_value_t = 8)]
    pub nodes: usize,
    /// Write the mesh as demo.pvtu with this many spatially coherent
    /// pieces (demo_0.vtu, ...; raw appended data, as `pvrsim partition`)
    /// instead of demo.vtk; 0 writes demo.vtk.
    #[arg(long, default_value_t = 0)]
    pub pieces: usize,
}

/// Fewest tetrahedra `--cells` accepts: below this the vessel's lattice is
/// too coarse to hold a lumen (100 gives no cell at all; 1,000 gives 926).
pub const MIN_CELLS: usize = 1_000;
/// Most tetrahedra `--cells` accepts (the whole `demo` command peaks at about
/// 1.6 GB there: docs/experiments/scaling.md).
pub const MAX_CELLS: usize = 20_000_000;
/// Most tetrahedra `--cells` accepts with `--pieces` and `--nodes 0` (the
/// generator's peak, about 77 B a tetrahedron: 7.7 GB at 100 M, measured in
/// docs/experiments/scaling.md); the pieces are not rendered.
pub const MAX_CELLS_PIECES: usize = 100_000_000;

impl Validate for DemoArgs {
    type Parsed = ();

    fn validate(&self, _c: &mut Checks) -> anyhow::Result<()> {
        let max = if self.pieces > 0 && self.nodes == 0 {
            MAX_CELLS_PIECES
        } else {
            MAX_CELLS
        };
        anyhow::ensure!(
            (MIN_CELLS..=max).contains(&self.cells),
            "--cells {}: must be between {MIN_CELLS} and {max}{}",
            self.cells,
            if max == MAX_CELLS {
                format!(" ({MAX_CELLS_PIECES} with --pieces and --nodes 0)")
            } else {
                String::new()
            }
        );
        anyhow::ensure!(
            self.pieces <= super::partition::MAX_PIECES,
            "--pieces {}: at most {}",
            self.pieces,
            super::partition::MAX_PIECES
        );
        Ok(())
    }
}

/// Writes the demo's regular grid (hydrogen atom, 64^3 u8) as
/// `hydrogen.nrrd` and its scene `hydrogen.toml`, and checks both load.
fn write_demo_volume(a: &DemoArgs) -> anyhow::Result<()> {
    let (vol, text) = crate::data::demo_volume::demo_volume_and_scene("hydrogen.nrrd");
    let nrrd = a.out_dir.join("hydrogen.nrrd");
    crate::data::io::volume::write_nrrd(
        &vol,
        &nrrd,
        false,
        "pvrsim demo: hydrogen atom (KVS formula), 64^3",
    )?;
    let scene_path = a.out_dir.join("hydrogen.toml");
    std::fs::write(&scene_path, &text)
        .with_context(|| format!("cannot write {}", scene_path.display()))?;
    let scene = Scene::load(&scene_path)?;
    crate::data::io::read_volume(&scene.data.path, &scene.data.field)?;
    println!(
        "wrote {} ({}^3 u8 grid) and {}",
        nrrd.display(),
        vol.dims[0],
        scene_path.display()
    );
    Ok(())
}

/// Runs `pvrsim demo`.
pub fn run(a: DemoArgs) -> anyhow::Result<()> {
    validate::apply(&a)?;
    super::output::prepare_dir("--out-dir", &a.out_dir)?;
    let t = std::time::Instant::now();
    let params = DemoParams {
        cells_target: a.cells,
        ..Default::default()
    };
    let data_name = if a.pieces > 0 {
        "demo.pvtu"
    } else {
        "demo.vtk"
    };
    let (mesh, scene_text) =
        super::with_threads(a.threads, || demo_mesh_and_scene(&params, data_name))?;
    let gen_s = t.elapsed().as_secs_f64();
    anyhow::ensure!(
        !mesh.tets.is_empty(),
        "--cells {}: the generator made no tetrahedra; give more cells",
        a.cells
    );
    println!(
        "generated a bifurcating vessel: {} tetrahedra, {} vertices in {:.2} s",
        mesh.tets.len(),
        mesh.points.len(),
        gen_s
    );
    let vtk = a.out_dir.join(data_name);
    super::scene::ensure_finite_toml(&scene_text, &a.out_dir.join("demo.toml"))?;
    if a.pieces > 0 {
        anyhow::ensure!(
            mesh.tets.len() >= a.pieces,
            "--pieces {}: the mesh has only {} cells",
            a.pieces,
            mesh.tets.len()
        );
        let parts = super::with_threads(a.threads, || {
            crate::data::partition::partition(&mesh, a.pieces)
        })?;
        super::with_threads(a.threads, || {
            crate::data::io::pvtu::write::write_pvtu(
                &mesh,
                &parts,
                crate::data::io::pvtu::write::Encoding::Raw,
                &vtk,
            )
        })??;
    } else {
        crate::data::io::write_vtk_legacy(&mesh, &vtk, true)?;
    }
    let scene_path = a.out_dir.join("demo.toml");
    std::fs::write(&scene_path, &scene_text)
        .with_context(|| format!("cannot write {}", scene_path.display()))?;
    println!("wrote {} and {}", vtk.display(), scene_path.display());
    write_demo_volume(&a)?;
    if mesh.tets.len() > MAX_CELLS {
        println!(
            "not rendered here (more than {MAX_CELLS} tetrahedra): pvrsim cluster {} --nodes {} \
             --transport processes renders the pieces, each worker reading its own",
            scene_path.display(),
            a.pieces
        );
        return Ok(());
    }

    let scene = Scene::parse(&scene_text, &scene_path)?;
    let input = RenderInput::new(scene, std::sync::Arc::new(mesh))?;
    let (image, stats) =
        super::with_threads(a.threads, || cell::render(&input, &CellOptions::default()))?;
    let png = a.out_dir.join("demo.png");
    image.save_png(&png)?;
    let stats_path = a.out_dir.join("demo-stats.json");
    std::fs::write(&stats_path, serde_json::to_string_pretty(&stats)?)?;
    println!(
        "rendered {}x{} by cell projection in {:.3} s ({}): {} segments, {} merged by partial composition",
        image.width, image.height, stats.time_total_s, super::plural(stats.threads, "thread"), stats.segments_generated, stats.segments_merged
    );
    println!("wrote {} and {}", png.display(), stats_path.display());
    if a.nodes > 0 {
        let ert_path = a.out_dir.join("demo-ert.toml");
        let ert_text = crate::data::demo_ert::ert_scene_toml(&scene_text, &scene_path)?;
        std::fs::write(&ert_path, &ert_text)
            .with_context(|| format!("cannot write {}", ert_path.display()))?;
        println!(
            "wrote {} (opaque vessel walls: ERT pays)",
            ert_path.display()
        );
        let ert_scene = Scene::parse(&ert_text, &ert_path)?;
        let ert_input = RenderInput::new(ert_scene, input.mesh.clone())?;
        super::demo_cluster::run_cluster(&a.out_dir, &ert_path, &ert_input, a.nodes, a.threads)?;
    }
    println!(
        "next: pvrsim render {} -o out.png --compare",
        scene_path.display()
    );
    // Name only files this run wrote: demo-ert.toml comes with --nodes.
    let cluster_scene = if a.nodes > 0 {
        a.out_dir.join("demo-ert.toml")
    } else {
        scene_path.clone()
    };
    println!(
        "      pvrsim cluster {} --nodes 16 --ert 0.9 --share --dlb --timeline t.png",
        cluster_scene.display()
    );
    if a.pieces > 0 {
        println!(
            "      pvrsim cluster {} --nodes {} --transport processes   (each worker reads its own piece)",
            scene_path.display(),
            a.pieces
        );
    }
    Ok(())
}
