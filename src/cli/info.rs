//! `pvrsim info`: what is in a mesh or volume file.

use std::path::PathBuf;

use anyhow::Context;
use clap::Args;

use crate::data::quality::MeshReport;

/// Options of `pvrsim info`.
#[derive(Debug, Args)]
pub struct InfoArgs {
    /// Mesh file: .vtk (legacy, ASCII or binary), .vtu (XML) or .inp (AVS UCD);
    /// or volume: .nrrd/.nhdr, .nii/.nii.gz, .vti, .fld.
    pub file: PathBuf,
    /// Print the report as JSON instead of text.
    #[arg(long)]
    pub json: bool,
    /// Meshes: only read the file and report counts, bounds, fields and
    /// memory (no quality report, which builds the face adjacency: 16 bytes
    /// for each of the 4 faces of every tetrahedron).
    #[arg(long)]
    pub no_quality: bool,
}

/// The bytes a mesh holds, as `info` reports them.
fn memory_line(mesh: &crate::data::TetMesh) -> (usize, f64, String) {
    let bytes = mesh.heap_bytes();
    let per = bytes as f64 / mesh.tets.len().max(1) as f64;
    (
        bytes,
        per,
        format!(
            "memory: the mesh holds {bytes} bytes ({:.1} MB; {per:.1} B per tetrahedron: points 24 B and field values 8 B a vertex, 16 B a tetrahedron)",
            bytes as f64 / 1e6
        ),
    )
}

/// Runs `pvrsim info`.
pub fn run(a: InfoArgs) -> anyhow::Result<()> {
    let t = std::time::Instant::now();
    if let Some(crate::data::DataFormat::Volume(_)) = crate::data::data_format(&a.file) {
        let v = crate::data::io::read_volume(&a.file, "")
            .with_context(|| format!("cannot read {}", a.file.display()))?;
        let load_s = t.elapsed().as_secs_f64();
        let report = crate::data::volume::report::VolumeReport::compute(&v);
        if a.json {
            println!("{}", serde_json::to_string_pretty(&report)?);
        } else {
            println!("{}  (read in {:.3} s)", a.file.display(), load_s);
            print!("{report}");
        }
        return Ok(());
    }
    let loaded = crate::data::io::load_mesh(&a.file)
        .with_context(|| format!("cannot read {}", a.file.display()))?;
    let load_s = t.elapsed().as_secs_f64();
    let (mesh, pieces) = (loaded.mesh, loaded.pieces);
    let renumbered = loaded.renumbering.is_some();
    let (bytes, per, mut line) = memory_line(&mesh);
    line = format!(
        "{line}\nnumbering: {:.1} % of sampled cells local in the file (within {} vertices); {}",
        100.0 * loaded.file_locality,
        crate::data::locality::WINDOW,
        if renumbered {
            "renumbered along a Morton curve at load"
        } else {
            "the file's kept"
        }
    );
    if let Some(p) = &pieces {
        // The tetrahedra of each piece (the cluster's `--placement pieces`).
        let list: Vec<String> = p.iter().map(u64::to_string).collect();
        line = format!(
            "pieces: {} (tetrahedra each: {})\n{line}",
            p.len(),
            list.join(", ")
        );
    }
    if a.no_quality {
        let (lo, hi) = mesh.bounds();
        let fields: Vec<String> = mesh
            .fields
            .iter()
            .map(|f| format!("{} ({} components)", f.name, f.components))
            .collect();
        if a.json {
            let v = serde_json::json!({
                "tetrahedra": mesh.tets.len(),
                "vertices": mesh.points.len(),
                "bounds": [lo, hi],
                "fields": mesh.fields.iter().map(|f| &f.name).collect::<Vec<_>>(),
                "load_s": load_s,
                "mesh_bytes": bytes,
                "bytes_per_tet": per,
                "piece_tetrahedra": pieces,
                "file_locality": loaded.file_locality,
                "renumbered": renumbered,
            });
            println!("{}", serde_json::to_string_pretty(&v)?);
        } else {
            println!("{}  (read in {:.3} s)", a.file.display(), load_s);
            println!(
                "{} tetrahedra, {} vertices; bounds {lo:?} to {hi:?}",
                mesh.tets.len(),
                mesh.points.len()
            );
            println!("fields: {}", fields.join(", "));
            println!("{line}");
        }
        return Ok(());
    }
    let report = MeshReport::compute(&mesh, &mesh.adjacency());
    if a.json {
        let mut v = serde_json::to_value(&report)?;
        if let Some(o) = v.as_object_mut() {
            o.insert("mesh_bytes".into(), bytes.into());
            o.insert("bytes_per_tet".into(), per.into());
            o.insert("piece_tetrahedra".into(), serde_json::to_value(&pieces)?);
            o.insert("file_locality".into(), loaded.file_locality.into());
            o.insert("renumbered".into(), renumbered.into());
        }
        println!("{}", serde_json::to_string_pretty(&v)?);
    } else {
        println!("{}  (read in {:.3} s)", a.file.display(), load_s);
        // Always end with a newline (the report's last line may lack one).
        println!("{}", report.to_string().trim_end());
        println!("{line}");
    }
    Ok(())
}
