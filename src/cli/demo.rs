//! `pvrsim demo`: the quick start. Generates the built-in bifurcation dataset,
//! writes it with its scene (and the demo volume, a 64^3 hydrogen atom, with
//! its scene), renders it, then renders it again on the
//! simulated 8-node cluster (ERT + SHARE + DLB, virtual clock, `gbe`,
//! `pentium4`), and prints what happened.

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
    /// About how many tetrahedra to generate, 1,000 to 20,000,000.
    #[arg(long, default_value_t = 150_000)]
    pub cells: usize,
    /// Worker threads; 0 = all cores.
    #[arg(long, default_value_t = 0)]
    pub threads: usize,
    /// Nodes of the simulated cluster run; 0 skips it.
    #[arg(long, default_value_t = 8)]
    pub nodes: usize,
}

/// Fewest tetrahedra `--cells` accepts: below this the vessel's lattice is
/// too coarse to hold a lumen (100 gives no cell at all; 1,000 gives 926).
pub const MIN_CELLS: usize = 1_000;
/// Most tetrahedra `--cells` accepts (about 5 GB of mesh and lists).
pub const MAX_CELLS: usize = 20_000_000;

impl Validate for DemoArgs {
    fn validate(&self, _c: &mut Checks) -> anyhow::Result<()> {
        anyhow::ensure!(
            (MIN_CELLS..=MAX_CELLS).contains(&self.cells),
            "--cells {}: must be between {MIN_CELLS} and {MAX_CELLS}",
            self.cells
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
    let (mesh, scene_text) =
        super::with_threads(a.threads, || demo_mesh_and_scene(&params, "demo.vtk"))?;
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
    let vtk = a.out_dir.join("demo.vtk");
    super::scene::ensure_finite_toml(&scene_text, &a.out_dir.join("demo.toml"))?;
    crate::data::io::write_vtk_legacy(&mesh, &vtk, true)?;
    let scene_path = a.out_dir.join("demo.toml");
    std::fs::write(&scene_path, &scene_text)
        .with_context(|| format!("cannot write {}", scene_path.display()))?;
    println!("wrote {} and {}", vtk.display(), scene_path.display());
    write_demo_volume(&a)?;

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
        run_cluster(&a, &input)?;
    }
    println!(
        "next: pvrsim render {} -o out.png --compare",
        scene_path.display()
    );
    println!(
        "      pvrsim cluster {} --nodes 16 --ert 0.9 --share --dlb --timeline t.png",
        scene_path.display()
    );
    Ok(())
}

/// The cluster part: 8 nodes (by default) with ERT 0.9, weak sharing through
/// the manager and DLB, virtual clock, gbe, pentium4; writes the image, the
/// timeline and the report, and prints a short summary.
fn run_cluster(a: &DemoArgs, input: &RenderInput) -> anyhow::Result<()> {
    use crate::cluster::{self, timeline, ClockKind, ClusterConfig, Phase1Config};
    use crate::net::NetworkModel;
    use crate::node::renderer::NodeErt;
    use crate::node::{CostProfile, NodeOptions, NodePolicy, PlacementMethod};

    let cfg = ClusterConfig {
        phase1: Phase1Config {
            nodes: a.nodes,
            node: NodeOptions {
                ert: NodeErt::PAPER,
                ..Default::default()
            },
            share: true,
            overlap: false,
            dlb: true,
            data: crate::node::DataMode::Replicated,
            policy: NodePolicy::default(),
            clock: ClockKind::Virtual,
            record_trace: true,
        },
        placement: PlacementMethod::Rcb,
        compositor: "binary-swap".into(),
        codec: "rle".into(),
        network: NetworkModel::from_name("gbe")?,
        network_name: "gbe".into(),
        profile: CostProfile::named("pentium4")?,
        profile_name: "pentium4".into(),
        baselines: true,
    };
    let t = std::time::Instant::now();
    let out = super::with_threads(a.threads, || cluster::run(input, &cfg))??;
    let host_s = t.elapsed().as_secs_f64();
    let png = a.out_dir.join("cluster.png");
    out.image.save_png(&png)?;
    let tl = a.out_dir.join("timeline.png");
    timeline::draw(&out.trace, out.report.n_nodes, &tl)?;
    let rep = a.out_dir.join("cluster-report.json");
    std::fs::write(&rep, serde_json::to_string_pretty(&out.report)?)
        .with_context(|| format!("cannot write {}", rep.display()))?;
    let r = &out.report;
    println!(
        "simulated cluster: {} nodes + manager, ERT {} + SHARE + DLB, gbe, pentium4 (virtual clock, {:.2} s on this machine)",
        r.n_nodes, r.ert_threshold, host_s
    );
    println!(
        "  frame {:.3} s (phase 1 {:.3} s, compositing {:.3} s); slowest node's Tsc {:.3} s, imbalance {:.1} %",
        r.frame_s,
        r.phase1_s,
        r.composite_s,
        r.tsc_max_s,
        100.0 * r.imbalance
    );
    if let (Some(seq), Some(sp), Some(spf)) = (r.sequential_s, r.speedup, r.speedup_frame) {
        println!(
            "  one modelled node: {seq:.3} s; speed-up {spf:.2} by frame time (sequential / frame), {sp:.2} by Tsc (sequential / slowest node's scan time, the paper's measure)"
        );
    }
    println!(
        "  cells: {} skipped by ERT, {} moved by DLB; bytes on the wire: {} ({} in phase 2)",
        r.cells_skipped_ert, r.cells_moved, r.bytes_total, r.compositing.bytes_total
    );
    println!(
        "wrote {}, {} and {}",
        png.display(),
        tl.display(),
        rep.display()
    );
    Ok(())
}
