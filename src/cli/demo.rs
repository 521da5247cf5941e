//! `pvrsim demo`: the quick start. Generates the built-in bifurcation dataset,
//! writes it with its scene, renders it, and prints what happened.

use std::path::PathBuf;

use anyhow::Context;
use clap::Args;

use crate::data::demo::{demo_mesh_and_scene, DemoParams};
use crate::render::cell::{self, CellOptions};
use crate::render::RenderInput;
use crate::scene::Scene;

/// Options of `pvrsim demo`.
#[derive(Debug, Args)]
pub struct DemoArgs {
    /// Folder for demo.vtk, demo.toml, demo.png and demo-stats.json.
    #[arg(long, default_value = "demo")]
    pub out_dir: PathBuf,
    /// About how many tetrahedra to generate.
    #[arg(long, default_value_t = 150_000)]
    pub cells: usize,
    /// Worker threads; 0 = all cores.
    #[arg(long, default_value_t = 0)]
    pub threads: usize,
}

/// Runs `pvrsim demo`.
pub fn run(a: DemoArgs) -> anyhow::Result<()> {
    std::fs::create_dir_all(&a.out_dir)
        .with_context(|| format!("cannot create {}", a.out_dir.display()))?;
    let t = std::time::Instant::now();
    let params = DemoParams {
        cells_target: a.cells,
        ..Default::default()
    };
    let (mesh, scene_text) =
        super::with_threads(a.threads, || demo_mesh_and_scene(&params, "demo.vtk"))?;
    let gen_s = t.elapsed().as_secs_f64();
    println!(
        "generated a bifurcating vessel: {} tetrahedra, {} vertices in {:.2} s",
        mesh.tets.len(),
        mesh.points.len(),
        gen_s
    );
    let vtk = a.out_dir.join("demo.vtk");
    crate::data::io::write_vtk_legacy(&mesh, &vtk, true)?;
    let scene_path = a.out_dir.join("demo.toml");
    std::fs::write(&scene_path, &scene_text)
        .with_context(|| format!("cannot write {}", scene_path.display()))?;
    println!("wrote {} and {}", vtk.display(), scene_path.display());

    let scene = Scene::parse(&scene_text, &scene_path)?;
    let input = RenderInput::new(scene, std::sync::Arc::new(mesh))?;
    let (image, stats) =
        super::with_threads(a.threads, || cell::render(&input, &CellOptions::default()))?;
    let png = a.out_dir.join("demo.png");
    image.save_png(&png)?;
    let stats_path = a.out_dir.join("demo-stats.json");
    std::fs::write(&stats_path, serde_json::to_string_pretty(&stats)?)?;
    println!(
        "rendered {}x{} by cell projection in {:.3} s ({} threads): {} segments, {} merged by partial composition",
        image.width, image.height, stats.time_total_s, stats.threads, stats.segments_generated, stats.segments_merged
    );
    println!("wrote {} and {}", png.display(), stats_path.display());
    println!(
        "next: pvrsim render {} -o out.png --compare",
        scene_path.display()
    );
    Ok(())
}
