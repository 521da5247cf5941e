//! Writer for VTK legacy unstructured grids (the classic cell layout, version
//! 3.0), readable by VTK, ParaView, meshio and [`vtk_legacy`](super::vtk_legacy).
//!
//! Points are written as `float`, cells as `CELLS n 5n` with type 10
//! (tetrahedron). Point fields: 1-component fields as `SCALARS name float 1`
//! with `LOOKUP_TABLE default`, 3-component fields as `VECTORS name float`,
//! any other component count as a `FIELD FieldData` array of `float`. Spaces
//! in names are written as `%20`, as VTK does. Binary files are big-endian.
//! Values are narrowed to `f32`, so a round trip is exact only for values
//! that are representable in single precision.

use std::io::Write;
use std::path::Path;

use crate::data::TetMesh;
use crate::error::{Error, Result};

/// Writes `mesh` to `path` as a VTK legacy file, `BINARY` if `binary`, else `ASCII`.
pub fn write_vtk_legacy(mesh: &TetMesh, path: &Path, binary: bool) -> Result<()> {
    let file = std::fs::File::create(path).map_err(|e| Error::io(path, e))?;
    let mut w = std::io::BufWriter::with_capacity(1 << 20, file);
    write_to(mesh, &mut w, binary)
        .and_then(|_| w.flush())
        .map_err(|e| Error::io(path, e))
}

/// Items encoded per parallel task of the binary writer.
const CHUNK: usize = 1 << 16;

/// Writes `items` encoded by `enc` (big-endian bytes of one item), the
/// chunks encoded on all cores, a bounded number at a time.
fn encoded<T: Sync>(
    w: &mut impl Write,
    items: &[T],
    enc: impl Fn(&T, &mut Vec<u8>) + Sync,
) -> std::io::Result<()> {
    use rayon::prelude::*;
    for group in items.chunks(CHUNK * 64) {
        let bufs: Vec<Vec<u8>> = group
            .par_chunks(CHUNK)
            .map(|c| {
                let mut b = Vec::with_capacity(c.len() * 20);
                for x in c {
                    enc(x, &mut b);
                }
                b
            })
            .collect();
        for b in bufs {
            w.write_all(&b)?;
        }
    }
    Ok(())
}

fn floats_slice(
    w: &mut impl Write,
    vals: &[f64],
    per_line: usize,
    binary: bool,
) -> std::io::Result<()> {
    if binary {
        encoded(w, vals, |v, b| {
            b.extend_from_slice(&(*v as f32).to_be_bytes())
        })?;
        writeln!(w)
    } else {
        floats(w, vals.iter().copied(), per_line, binary)
    }
}

fn floats(
    w: &mut impl Write,
    vals: impl Iterator<Item = f64>,
    per_line: usize,
    binary: bool,
) -> std::io::Result<()> {
    if binary {
        for v in vals {
            w.write_all(&(v as f32).to_be_bytes())?;
        }
    } else {
        for (i, v) in vals.enumerate() {
            let sep = if (i + 1) % per_line == 0 { "\n" } else { " " };
            write!(w, "{}{sep}", v as f32)?;
        }
    }
    writeln!(w)
}

fn ints(w: &mut impl Write, vals: &[i32], binary: bool) -> std::io::Result<()> {
    if binary {
        for v in vals {
            w.write_all(&v.to_be_bytes())?;
        }
        writeln!(w)
    } else {
        for c in vals.chunks(5) {
            let s: Vec<String> = c.iter().map(|v| v.to_string()).collect();
            writeln!(w, "{}", s.join(" "))?;
        }
        Ok(())
    }
}

/// Writes the file's bytes to `w`.
pub fn write_to(mesh: &TetMesh, w: &mut impl Write, binary: bool) -> std::io::Result<()> {
    writeln!(w, "# vtk DataFile Version 3.0")?;
    writeln!(w, "written by pvrsim")?;
    writeln!(w, "{}", if binary { "BINARY" } else { "ASCII" })?;
    writeln!(w, "DATASET UNSTRUCTURED_GRID")?;
    writeln!(w, "POINTS {} float", mesh.points.len())?;
    floats_slice(w, mesh.points.as_flattened(), 3, binary)?;
    let n = mesh.tets.len();
    writeln!(w, "CELLS {n} {}", 5 * n)?;
    if binary {
        encoded(w, &mesh.tets, |t, b| {
            b.extend_from_slice(&4i32.to_be_bytes());
            for v in t {
                b.extend_from_slice(&(*v as i32).to_be_bytes());
            }
        })?;
        writeln!(w)?;
        writeln!(w, "CELL_TYPES {n}")?;
        encoded(w, &mesh.tets, |_, b| {
            b.extend_from_slice(&10i32.to_be_bytes())
        })?;
        writeln!(w)?;
    } else {
        let conn: Vec<i32> = mesh
            .tets
            .iter()
            .flat_map(|t| [4, t[0] as i32, t[1] as i32, t[2] as i32, t[3] as i32])
            .collect();
        ints(w, &conn, binary)?;
        writeln!(w, "CELL_TYPES {n}")?;
        ints(w, &vec![10; n], binary)?;
    }
    if mesh.fields.is_empty() {
        return Ok(());
    }
    writeln!(w, "POINT_DATA {}", mesh.points.len())?;
    for f in &mesh.fields {
        let name = f.name.replace('%', "%25").replace(' ', "%20");
        match f.components {
            1 => writeln!(w, "SCALARS {name} float 1\nLOOKUP_TABLE default")?,
            3 => writeln!(w, "VECTORS {name} float")?,
            c => writeln!(
                w,
                "FIELD FieldData 1\n{name} {c} {} float",
                mesh.points.len()
            )?,
        }
        floats_slice(w, &f.values, f.components.max(1), binary)?;
    }
    Ok(())
}
