//! `pvrsim partition`: a mesh split into spatially coherent pieces
//! (recursive coordinate bisection of the cell centroids) and written as a
//! `.pvtu` with one `.vtu` per piece, boundary vertices duplicated.

use std::path::PathBuf;

use anyhow::Context;
use clap::{Args, ValueEnum};

use crate::data::io::pvtu::write::{write_pvtu, Encoding};

/// How the pieces store their arrays.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum EncodingArg {
    /// Uncompressed appended data (fastest to read).
    Raw,
    /// zlib blocks (VTK's vtkZLibDataCompressor).
    Zlib,
}

impl From<EncodingArg> for Encoding {
    fn from(e: EncodingArg) -> Encoding {
        match e {
            EncodingArg::Raw => Encoding::Raw,
            EncodingArg::Zlib => Encoding::Zlib,
        }
    }
}

/// Options of `pvrsim partition`.
#[derive(Debug, Args)]
pub struct PartitionArgs {
    /// Mesh to split: .vtk, .vtu, .pvtu or .inp.
    pub mesh: PathBuf,
    /// Number of pieces, 1 to 65,536.
    #[arg(long)]
    pub pieces: usize,
    /// Output .pvtu; the pieces go beside it as STEM_0.vtu, STEM_1.vtu, ...
    #[arg(short, long)]
    pub output: PathBuf,
    /// How the pieces store their arrays.
    #[arg(long, value_enum, default_value_t = EncodingArg::Raw)]
    pub encoding: EncodingArg,
    /// Overwrite the output if it exists.
    #[arg(long)]
    pub force: bool,
}

/// Most pieces `--pieces` accepts.
pub const MAX_PIECES: usize = 65_536;

/// Runs `pvrsim partition`.
pub fn run(a: PartitionArgs) -> anyhow::Result<()> {
    anyhow::ensure!(
        (1..=MAX_PIECES).contains(&a.pieces),
        "--pieces {}: must be between 1 and {MAX_PIECES}",
        a.pieces
    );
    anyhow::ensure!(
        crate::data::io::mesh_format(&a.output) == Some(crate::data::io::MeshFormat::Pvtu),
        "-o {}: the output is a .pvtu (its pieces go beside it)",
        a.output.display()
    );
    anyhow::ensure!(
        a.force || !a.output.exists(),
        "-o {}: exists (--force overwrites it)",
        a.output.display()
    );
    // The folder (one missing level is created, and said) and writability,
    // before the mesh is read; the pieces go beside the .pvtu.
    crate::job::output::prepare_output("-o", &a.output, crate::job::output::OutputKind::Pvtu)?;
    let t = std::time::Instant::now();
    let mesh = crate::data::io::read_mesh(&a.mesh)
        .with_context(|| format!("cannot read {}", a.mesh.display()))?;
    let load_s = t.elapsed().as_secs_f64();
    anyhow::ensure!(
        mesh.tets.len() >= a.pieces,
        "--pieces {}: the mesh has only {} cells",
        a.pieces,
        mesh.tets.len()
    );
    let t = std::time::Instant::now();
    let pieces = crate::data::partition::partition(&mesh, a.pieces);
    let part_s = t.elapsed().as_secs_f64();
    let t = std::time::Instant::now();
    let paths = write_pvtu(&mesh, &pieces, a.encoding.into(), &a.output)
        .with_context(|| format!("cannot write {}", a.output.display()))?;
    let write_s = t.elapsed().as_secs_f64();
    let sizes: Vec<usize> = pieces.iter().map(Vec::len).collect();
    println!(
        "read {} ({} tetrahedra, {} vertices) in {load_s:.2} s; split into {} pieces of {} to {} cells in {part_s:.2} s; wrote {} and {} piece files in {write_s:.2} s",
        a.mesh.display(),
        mesh.tets.len(),
        mesh.points.len(),
        a.pieces,
        sizes.iter().min().unwrap_or(&0),
        sizes.iter().max().unwrap_or(&0),
        a.output.display(),
        paths.len()
    );
    Ok(())
}
