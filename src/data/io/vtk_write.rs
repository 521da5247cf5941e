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
    let mut w = std::io::BufWriter::new(file);
    write_to(mesh, &mut w, binary)
        .and_then(|_| w.flush())
        .map_err(|e| Error::io(path, e))
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
    floats(w, mesh.points.iter().flatten().copied(), 3, binary)?;
    let n = mesh.tets.len();
    writeln!(w, "CELLS {n} {}", 5 * n)?;
    let conn: Vec<i32> = mesh
        .tets
        .iter()
        .flat_map(|t| [4, t[0] as i32, t[1] as i32, t[2] as i32, t[3] as i32])
        .collect();
    ints(w, &conn, binary)?;
    writeln!(w, "CELL_TYPES {n}")?;
    ints(w, &vec![10; n], binary)?;
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
        floats(w, f.values.iter().copied(), f.components.max(1), binary)?;
    }
    Ok(())
}
