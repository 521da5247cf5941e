//! `pvrsim render`: one scene, one image. The options and the work are the
//! job layer's ([`crate::job::render`], re-exported here); this file checks
//! the outputs, runs the job and writes its files.

use anyhow::Context;

use crate::job::output::{self, prepare_output, OutputKind};
pub use crate::job::render::*;
pub use crate::job::run::render as execute;
use crate::job::Valid;

/// Runs `pvrsim render`: validates the options once and checks every output
/// path, renders, warns when the image is empty, writes.
pub fn run(a: RenderArgs) -> anyhow::Result<()> {
    let job = Valid::new(&a)?;
    job.print_warnings();
    prepare_output("-o", &a.output, OutputKind::Png)?;
    if let Some(p) = &a.stats {
        prepare_output("--stats", p, OutputKind::Json)?;
    }
    if a.compare && a.renderer.unwrap_or(RendererKind::Cell) == RendererKind::Cell {
        prepare_output("--compare", &compare_path(&a.output), OutputKind::Png)?;
    }
    let out = job.run(false)?;
    for line in &out.summary {
        println!("{line}");
    }
    let projected = out.stats["cells_projected"].as_u64();
    output::warn_if_empty(
        &out.image,
        &match projected {
            Some(n) => format!("{n} cells projected on screen"),
            None => "no ray met a visible cell".into(),
        },
    );
    out.image.save_png(&a.output)?;
    println!("wrote {}", a.output.display());
    if let Some(path) = &a.stats {
        std::fs::write(path, serde_json::to_string_pretty(&out.stats)?)
            .with_context(|| format!("cannot write {}", path.display()))?;
        println!("wrote {}", path.display());
    }
    Ok(())
}
