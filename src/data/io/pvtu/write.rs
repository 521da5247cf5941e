//! Writer of partitioned meshes: one `.vtu` per piece (appended data, raw
//! or zlib-compressed blocks, little-endian, UInt64 headers) and the
//! `.pvtu` naming them, readable by VTK, ParaView and [`super::read`].
//!
//! A piece holds its cells (in mesh order) and every vertex they use (in
//! mesh order), so vertices on the boundary between pieces are written in
//! each piece that uses them, as solvers write them. Arrays are `Float32`
//! when every value is exactly a single-precision number (so the round trip
//! is exact), else `Float64`; connectivity and offsets `Int32` (`Int64`
//! past 2^31 - 1), cell types `UInt8` (10, tetrahedron).

use std::io::Write;
use std::path::{Path, PathBuf};

use rayon::prelude::*;

use crate::data::io::numeric::NumType;
use crate::data::TetMesh;
use crate::error::{Error, Result};

/// How the pieces' arrays are stored.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Encoding {
    /// The bytes as they are.
    Raw,
    /// zlib blocks of 64 KiB (`vtkZLibDataCompressor`), compressed in parallel.
    Zlib,
}

/// zlib block size.
const BLOCK: usize = 1 << 16;

fn xml_escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// `Float32` if every value is exactly a single-precision number.
fn float_type(values: &[f64]) -> NumType {
    if values
        .par_iter()
        .all(|&v| (v as f32) as f64 == v || v.is_nan())
    {
        NumType::F32
    } else {
        NumType::F64
    }
}

fn xml_type(t: NumType) -> &'static str {
    match t {
        NumType::F32 => "Float32",
        NumType::F64 => "Float64",
        NumType::I32 => "Int32",
        NumType::I64 => "Int64",
        NumType::U8 => "UInt8",
        NumType::I8 => "Int8",
        NumType::I16 => "Int16",
        NumType::U16 => "UInt16",
        NumType::U32 => "UInt32",
        NumType::U64 => "UInt64",
    }
}

fn floats_le(values: impl Iterator<Item = f64>, t: NumType) -> Vec<u8> {
    if t == NumType::F32 {
        values.flat_map(|v| (v as f32).to_le_bytes()).collect()
    } else {
        values.flat_map(|v| v.to_le_bytes()).collect()
    }
}

fn ints_le(values: impl Iterator<Item = i64>, t: NumType) -> Vec<u8> {
    if t == NumType::I32 {
        values.flat_map(|v| (v as i32).to_le_bytes()).collect()
    } else {
        values.flat_map(|v| v.to_le_bytes()).collect()
    }
}

/// One array's appended bytes: the UInt64 length header and the data, or
/// the zlib block header and the compressed blocks.
fn appended(data: &[u8], enc: Encoding) -> Vec<u8> {
    match enc {
        Encoding::Raw => {
            let mut out = Vec::with_capacity(8 + data.len());
            out.extend_from_slice(&(data.len() as u64).to_le_bytes());
            out.extend_from_slice(data);
            out
        }
        Encoding::Zlib => {
            let blocks: Vec<Vec<u8>> = data
                .par_chunks(BLOCK)
                .map(|b| {
                    let mut e = flate2::write::ZlibEncoder::new(
                        Vec::with_capacity(b.len() / 2),
                        flate2::Compression::fast(),
                    );
                    // Writing to a Vec cannot fail.
                    let _ = e.write_all(b);
                    e.finish().unwrap_or_default()
                })
                .collect();
            let last = data.len() % BLOCK;
            let mut out = Vec::new();
            for v in [blocks.len() as u64, BLOCK as u64, last as u64] {
                out.extend_from_slice(&v.to_le_bytes());
            }
            for b in &blocks {
                out.extend_from_slice(&(b.len() as u64).to_le_bytes());
            }
            for b in &blocks {
                out.extend_from_slice(b);
            }
            out
        }
    }
}

/// The array types of a whole mesh, shared by all its pieces.
#[derive(Debug, Clone)]
pub struct ArrayTypes {
    points: NumType,
    fields: Vec<NumType>,
    index: NumType,
}

impl ArrayTypes {
    /// The types for `mesh` (see the module documentation).
    pub fn of(mesh: &TetMesh) -> ArrayTypes {
        ArrayTypes {
            points: float_type(mesh.points.as_flattened()),
            fields: mesh.fields.iter().map(|f| float_type(&f.values)).collect(),
            index: if mesh.points.len() < i32::MAX as usize
                && 4 * mesh.tets.len() < i32::MAX as usize
            {
                NumType::I32
            } else {
                NumType::I64
            },
        }
    }
}

/// Writes the cells `cells` (indices into `mesh.tets`) of `mesh` as one
/// `.vtu` at `path`.
pub fn write_piece(
    mesh: &TetMesh,
    cells: &[u32],
    types: &ArrayTypes,
    enc: Encoding,
    path: &Path,
) -> Result<()> {
    // The piece's vertices in mesh order, and the local index of each.
    let mut used = vec![false; mesh.points.len()];
    for &c in cells {
        for v in mesh.tets[c as usize] {
            used[v as usize] = true;
        }
    }
    let verts: Vec<u32> = (0..mesh.points.len() as u32)
        .filter(|&v| used[v as usize])
        .collect();
    drop(used);
    let mut local = vec![0u32; mesh.points.len()];
    for (i, &v) in verts.iter().enumerate() {
        local[v as usize] = i as u32;
    }
    let mut arrays: Vec<(String, Vec<u8>)> = Vec::new();
    let mut xml_point_data = String::new();
    let mut offset = 0usize;
    let mut push = |decl: String, bytes: Vec<u8>, arrays: &mut Vec<(String, Vec<u8>)>| {
        let a = appended(&bytes, enc);
        let line = decl.replace("OFFSET", &offset.to_string());
        offset += a.len();
        arrays.push((line, a));
    };
    for (f, &t) in mesh.fields.iter().zip(&types.fields) {
        let c = f.components;
        let bytes = floats_le(
            verts.iter().flat_map(|&v| {
                f.values[v as usize * c..(v as usize + 1) * c]
                    .iter()
                    .copied()
            }),
            t,
        );
        push(
            format!(
                "        <DataArray type=\"{}\" Name=\"{}\" NumberOfComponents=\"{c}\" format=\"appended\" offset=\"OFFSET\"/>\n",
                xml_type(t),
                xml_escape(&f.name)
            ),
            bytes,
            &mut arrays,
        );
    }
    let nfields = arrays.len();
    push(
        format!(
            "        <DataArray type=\"{}\" Name=\"Points\" NumberOfComponents=\"3\" format=\"appended\" offset=\"OFFSET\"/>\n",
            xml_type(types.points)
        ),
        floats_le(verts.iter().flat_map(|&v| mesh.points[v as usize]), types.points),
        &mut arrays,
    );
    let it = types.index;
    push(
        format!("        <DataArray type=\"{}\" Name=\"connectivity\" format=\"appended\" offset=\"OFFSET\"/>\n", xml_type(it)),
        ints_le(
            cells
                .iter()
                .flat_map(|&c| mesh.tets[c as usize].map(|v| local[v as usize] as i64)),
            it,
        ),
        &mut arrays,
    );
    push(
        format!("        <DataArray type=\"{}\" Name=\"offsets\" format=\"appended\" offset=\"OFFSET\"/>\n", xml_type(it)),
        ints_le((1..=cells.len() as i64).map(|i| 4 * i), it),
        &mut arrays,
    );
    push(
        "        <DataArray type=\"UInt8\" Name=\"types\" format=\"appended\" offset=\"OFFSET\"/>\n".to_string(),
        vec![10u8; cells.len()],
        &mut arrays,
    );
    let mut head = String::new();
    head.push_str("<?xml version=\"1.0\"?>\n");
    head.push_str(&format!(
        "<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"UInt64\"{}>\n",
        if enc == Encoding::Zlib { " compressor=\"vtkZLibDataCompressor\"" } else { "" }
    ));
    head.push_str("  <UnstructuredGrid>\n");
    head.push_str(&format!(
        "    <Piece NumberOfPoints=\"{}\" NumberOfCells=\"{}\">\n",
        verts.len(),
        cells.len()
    ));
    head.push_str("      <PointData>\n");
    for (l, _) in &arrays[..nfields] {
        xml_point_data.push_str(l);
    }
    head.push_str(&xml_point_data);
    head.push_str("      </PointData>\n      <Points>\n");
    head.push_str(&arrays[nfields].0);
    head.push_str("      </Points>\n      <Cells>\n");
    for (l, _) in &arrays[nfields + 1..] {
        head.push_str(l);
    }
    head.push_str("      </Cells>\n    </Piece>\n  </UnstructuredGrid>\n  <AppendedData encoding=\"raw\">\n   _");
    let file = std::fs::File::create(path).map_err(|e| Error::io(path, e))?;
    let mut w = std::io::BufWriter::with_capacity(1 << 20, file);
    let res = (|| -> std::io::Result<()> {
        w.write_all(head.as_bytes())?;
        for (_, a) in &arrays {
            w.write_all(a)?;
        }
        w.write_all(b"\n  </AppendedData>\n</VTKFile>\n")?;
        w.flush()
    })();
    res.map_err(|e| Error::io(path, e))
}

/// Writes `mesh` split into `pieces` (cell indices per piece) as `out`
/// (`.pvtu`) and `STEM_k.vtu` beside it; returns the pieces' paths.
pub fn write_pvtu(
    mesh: &TetMesh,
    pieces: &[Vec<u32>],
    enc: Encoding,
    out: &Path,
) -> Result<Vec<PathBuf>> {
    let types = ArrayTypes::of(mesh);
    let stem = out
        .file_stem()
        .and_then(|s| s.to_str())
        .ok_or_else(|| Error::data(out, "file name", "not a file name"))?;
    let dir = out.parent().unwrap_or(Path::new(""));
    let names: Vec<String> = (0..pieces.len())
        .map(|k| format!("{stem}_{k}.vtu"))
        .collect();
    let paths: Vec<PathBuf> = names.iter().map(|n| dir.join(n)).collect();
    let results: Vec<Result<()>> = pieces
        .par_iter()
        .zip(&paths)
        .map(|(cells, p)| write_piece(mesh, cells, &types, enc, p))
        .collect();
    for r in results {
        r?;
    }
    let mut x = String::new();
    x.push_str("<?xml version=\"1.0\"?>\n");
    x.push_str("<VTKFile type=\"PUnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"UInt64\">\n");
    x.push_str("  <PUnstructuredGrid GhostLevel=\"0\">\n    <PPointData>\n");
    for (f, &t) in mesh.fields.iter().zip(&types.fields) {
        x.push_str(&format!(
            "      <PDataArray type=\"{}\" Name=\"{}\" NumberOfComponents=\"{}\"/>\n",
            xml_type(t),
            xml_escape(&f.name),
            f.components
        ));
    }
    x.push_str("    </PPointData>\n    <PPoints>\n");
    x.push_str(&format!(
        "      <PDataArray type=\"{}\" Name=\"Points\" NumberOfComponents=\"3\"/>\n",
        xml_type(types.points)
    ));
    x.push_str("    </PPoints>\n");
    for n in &names {
        x.push_str(&format!("    <Piece Source=\"{}\"/>\n", xml_escape(n)));
    }
    x.push_str("  </PUnstructuredGrid>\n</VTKFile>\n");
    std::fs::write(out, x).map_err(|e| Error::io(out, e))?;
    Ok(paths)
}
