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
}

/// Runs `pvrsim info`.
pub fn run(a: InfoArgs) -> anyhow::Result<()> {
    let t = std::time::Instant::now();
    if crate::data::io::volume::volume_format(&a.file).is_some() {
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
    let mesh = crate::data::io::read_mesh(&a.file)
        .with_context(|| format!("cannot read {}", a.file.display()))?;
    let load_s = t.elapsed().as_secs_f64();
    let report = MeshReport::compute(&mesh, &mesh.adjacency());
    if a.json {
        println!("{}", serde_json::to_string_pretty(&report)?);
    } else {
        println!("{}  (read in {:.3} s)", a.file.display(), load_s);
        // Always end with a newline (the report's last line may lack one).
        println!("{}", report.to_string().trim_end());
    }
    Ok(())
}
