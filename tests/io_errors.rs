//! Bad input: every case must be an `Err` whose message names the file and
//! the place (line, byte, element, cell), never a panic.

use std::path::{Path, PathBuf};

use pvrsim::data::io::{read_mesh, vtk_legacy, vtu};
use pvrsim::data::TetMesh;

mod support;

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(name)
}

/// Writes `bytes` to a temporary file named `name` and reads it.
fn read_bytes_as(name: &str, bytes: &[u8]) -> (String, Result<TetMesh, pvrsim::Error>) {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join(name);
    std::fs::write(&p, bytes).unwrap();
    let r = read_mesh(&p);
    (p.display().to_string(), r)
}

/// Asserts reading `bytes` as a mesh fails with a message naming the file
/// and containing every `needle`; returns the message.
fn expect_err(name: &str, bytes: &[u8], needles: &[&str]) -> String {
    support::expect_err(name, bytes, needles, read_mesh)
}

const TET_ASCII: &str = "# vtk DataFile Version 3.0
one tet
ASCII
DATASET UNSTRUCTURED_GRID
POINTS 4 float
0 0 0  1 0 0  0 1 0  0 0 1
CELLS 1 5
4 0 1 2 3
CELL_TYPES 1
10
POINT_DATA 4
SCALARS s float 1
LOOKUP_TABLE default
0 1 2 3
";

#[test]
fn the_ascii_template_is_valid() {
    let (_, r) = read_bytes_as("t.vtk", TET_ASCII.as_bytes());
    let m = r.unwrap();
    assert_eq!((m.points.len(), m.tets.len(), m.fields.len()), (4, 1, 1));
}

#[test]
fn truncated_binary_file_names_bytes_expected_and_offset() {
    let full = std::fs::read(data("aorta-small.vtk")).unwrap();
    for cut in [
        150,
        200,
        1_000,
        60_000,
        64_000,
        100_000,
        300_000,
        400_000,
        600_000,
        full.len() - 10,
        full.len() - 2,
    ] {
        let msg = expect_err("cut.vtk", &full[..cut], &[]);
        assert!(msg.contains("byte") || msg.contains("line"), "{cut}: {msg}");
    }
    let msg = expect_err("cut.vtk", &full[..1_000], &["truncated", "bytes"]);
    assert!(msg.contains("POINTS"), "{msg}");
}

#[test]
fn truncation_anywhere_never_panics() {
    let full = std::fs::read(data("aorta-small.vtk")).unwrap();
    for cut in (0..full.len()).step_by(997) {
        let r = vtk_legacy::parse(&full[..cut], Path::new("cut.vtk"))
            .and_then(|m| m.validate(Path::new("cut.vtk")));
        assert!(r.is_err(), "cut at {cut} parsed");
    }
}

#[test]
fn counts_that_disagree_with_the_data() {
    let full = std::fs::read(data("aorta-small.vtk")).unwrap();
    let text = String::from_utf8_lossy(&full[..300]).to_string();
    assert!(text.contains("POINTS 5326 float"));
    // Binary: claim more points than there are: the data after them is misread.
    let mut bad = full.clone();
    let at = bad
        .windows(17)
        .position(|w| w == b"CELLS 20169 10084")
        .unwrap();
    bad[at + 17] = b'6';
    expect_err("count.vtk", &bad, &["CELLS", "disagree"]);
    // ASCII: too few cell list entries, too many points, wrong POINT_DATA count.
    expect_err(
        "a.vtk",
        TET_ASCII.replace("CELLS 1 5", "CELLS 1 6").as_bytes(),
        &["line"],
    );
    expect_err(
        "a.vtk",
        TET_ASCII.replace("CELLS 1 5", "CELLS 2 5").as_bytes(),
        &["line 7", "disagree"],
    );
    expect_err(
        "a.vtk",
        TET_ASCII.replace("POINTS 4", "POINTS 5").as_bytes(),
        &["line"],
    );
    expect_err(
        "a.vtk",
        TET_ASCII.replace("POINT_DATA 4", "POINT_DATA 3").as_bytes(),
        &["line 11", "POINT_DATA 3", "4 points"],
    );
    expect_err(
        "a.vtk",
        TET_ASCII
            .replace("CELL_TYPES 1\n10", "CELL_TYPES 2\n10 10")
            .as_bytes(),
        &["line 9", "CELL_TYPES 2"],
    );
}

#[test]
fn non_finite_coordinates_and_scalars() {
    expect_err(
        "n.vtk",
        TET_ASCII
            .replace("0 1 0  0 0 1", "0 nan 0  0 0 1")
            .as_bytes(),
        &["point 2", "not finite"],
    );
    expect_err(
        "n.vtk",
        TET_ASCII
            .replace("0 1 0  0 0 1", "0 1 0  0 0 inf")
            .as_bytes(),
        &["point 3", "not finite"],
    );
    expect_err(
        "n.vtk",
        TET_ASCII
            .replace("default\n0 1 2 3", "default\n0 1 NaN 3")
            .as_bytes(),
        &["field \"s\"", "point 2", "not finite"],
    );
    // Binary NaN: overwrite the first coordinate of aorta-small.vtk.
    let mut b = std::fs::read(data("aorta-small.vtk")).unwrap();
    let at = b
        .windows(18)
        .position(|w| w == b"POINTS 5326 float\n")
        .unwrap()
        + 18;
    b[at..at + 4].copy_from_slice(&f32::NAN.to_be_bytes());
    expect_err("n.vtk", &b, &["point 0", "not finite"]);
}

#[test]
fn indices_out_of_range_and_unknown_cell_types() {
    expect_err(
        "i.vtk",
        TET_ASCII.replace("4 0 1 2 3", "4 0 1 2 9").as_bytes(),
        &["cell 0", "vertex index 9", "out of range"],
    );
    expect_err(
        "i.vtk",
        TET_ASCII.replace("4 0 1 2 3", "4 0 1 -2 3").as_bytes(),
        &["cell 0", "out of range"],
    );
    expect_err(
        "t.vtk",
        TET_ASCII
            .replace("CELL_TYPES 1\n10", "CELL_TYPES 1\n24")
            .as_bytes(),
        &["cell 0", "type 24", "quadratic tetrahedron"],
    );
    expect_err(
        "t.vtk",
        TET_ASCII
            .replace("CELL_TYPES 1\n10", "CELL_TYPES 1\n12")
            .as_bytes(),
        &["cell 0", "hexahedron has 8 vertices"],
    );
}

#[test]
fn garbage_headers_keywords_and_dataset_types() {
    expect_err(
        "g.vtk",
        b"hello world\n\x00\x01\x02",
        &["line 1", "not a VTK legacy file"],
    );
    expect_err("g.vtk", b"", &["line 1"]);
    expect_err(
        "g.vtk",
        TET_ASCII.replace("ASCII", "EBCDIC").as_bytes(),
        &["line 3", "EBCDIC"],
    );
    expect_err(
        "g.vtk",
        TET_ASCII
            .replace("UNSTRUCTURED_GRID", "POLYDATA")
            .as_bytes(),
        &["line 4", "POLYDATA", "not supported"],
    );
    expect_err(
        "g.vtk",
        TET_ASCII.replace("UNSTRUCTURED_GRID", "BANANA").as_bytes(),
        &["line 4", "unknown dataset type", "BANANA"],
    );
    expect_err(
        "g.vtk",
        TET_ASCII.replace("CELL_TYPES 1", "CELL_KINDS 1").as_bytes(),
        &["line 9", "unknown keyword", "CELL_KINDS"],
    );
    expect_err(
        "g.vtk",
        TET_ASCII
            .replace("POINTS 4 float", "POINTS 4 quaternion")
            .as_bytes(),
        &["line 5", "quaternion"],
    );
    expect_err(
        "g.vtk",
        TET_ASCII
            .replace("0 0 0  1 0 0", "0 0 0  1 zero 0")
            .as_bytes(),
        &["line 6", "\"zero\""],
    );
    expect_err(
        "g.stl",
        b"solid",
        &["unsupported mesh format", ".vtk", ".vtu", ".inp"],
    );
}

#[test]
fn missing_field_names_the_ones_there() {
    let m = read_mesh(&data("aorta-small.vtk")).unwrap();
    let msg = m.scalar("temperature").unwrap_err().to_string();
    assert!(
        msg.contains("\"temperature\"") && msg.contains("\"speed\""),
        "{msg}"
    );
}

#[test]
fn missing_file_is_an_io_error_naming_it() {
    let msg = read_mesh(Path::new("/nonexistent/mesh.vtk"))
        .unwrap_err()
        .to_string();
    assert!(msg.starts_with("/nonexistent/mesh.vtk"), "{msg}");
}

#[test]
fn vtu_errors_name_the_element() {
    let good = std::fs::read_to_string(data("vtu/binary-uint32.vtu")).unwrap();
    expect_err(
        "v.vtu",
        good.replace("NumberOfPoints=\"9\"", "NumberOfPoints=\"10\"")
            .as_bytes(),
        &["<DataArray Name=\"Points\"> in <Points>", "expected 30"],
    );
    expect_err(
        "v.vtu",
        good.replace("UnstructuredGrid\"", "PolyData\"").as_bytes(),
        &["<VTKFile>", "PolyData"],
    );
    let mut bad64 = good.clone().into_bytes();
    let at = good.find("format=\"binary\">\n").unwrap() + 22;
    bad64[at] = b'*';
    expect_err("v.vtu", &bad64, &["<DataArray", "base64"]);
    expect_err(
        "v.vtu",
        good.replace("</Points>", "</Pointz>").as_bytes(),
        &["byte", "XML"],
    );
    expect_err("v.vtu", b"<foo/>", &["no <VTKFile>"]);
    let ascii = std::fs::read_to_string(data("vtu/ascii.vtu")).unwrap();
    expect_err(
        "v.vtu",
        ascii
            .replacen(
                "<DataArray type=\"Int64\" Name=\"types\" format=\"ascii\">\n10",
                "<DataArray type=\"Int64\" Name=\"types\" format=\"ascii\">\n25",
                1,
            )
            .as_bytes(),
        &["cell 0", "quadratic hexahedron"],
    );
    let raw = std::fs::read(data("vtu/appended-raw-zlib.vtu")).unwrap();
    for cut in [raw.len() - 40, raw.len() - 200, raw.len() - 600] {
        expect_err("v.vtu", &raw[..cut], &["<DataArray Name="]);
    }
}

#[test]
fn ucd_errors_name_the_line() {
    let good = std::fs::read_to_string(data("spx.inp")).unwrap();
    expect_err(
        "u.inp",
        good.replacen("1 1 tet 1 1 2 21", "1 1 tet 1 1 2 99999", 1)
            .as_bytes(),
        &["line 2898", "node id 99999"],
    );
    expect_err(
        "u.inp",
        good.replacen("1 1 tet 1 1 2 21", "1 1 tet2 1 1 2 21", 1)
            .as_bytes(),
        &["line 2898", "tet2"],
    );
    expect_err(
        "u.inp",
        good.replacen("2896 12936 1 0 0", "2896 12937 1 0 0", 1)
            .as_bytes(),
        &["line"],
    );
    expect_err(
        "u.inp",
        good.replacen("2 5.858410", "2 5.85x410", 1).as_bytes(),
        &["line 3", "5.85x410"],
    );
    expect_err("u.inp", &good.as_bytes()[..good.len() / 2], &["line"]);
    let lines: Vec<&str> = good.lines().collect();
    expect_err(
        "u.inp",
        lines[..lines.len() - 3].join("\n").as_bytes(),
        &["line 18729", "file ends before node data values"],
    );
}

/// Flips and truncates bytes of small binary files: never a panic.
#[test]
fn fuzz_small_binary_files_never_panic() {
    let mesh = read_mesh(&data("vtu/appended-raw.vtu")).unwrap();
    let mut vtk = Vec::new();
    pvrsim::data::io::vtk_write::write_to(&mesh, &mut vtk, true).unwrap();
    let ucd = "# tiny\n5 2 1 0 0\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n5 1 1 1\n1 1 tet 1 2 3 4\n2 1 tet 2 3 4 5\n1 1\ns, none\n1 0.1\n2 0.2\n3 0.3\n4 0.4\n5 0.5\n";
    let dir = tempfile::tempdir().unwrap();
    let inputs: [(&str, Vec<u8>); 4] = [
        ("f.inp", ucd.as_bytes().to_vec()),
        ("f.vtk", vtk),
        (
            "f.vtu",
            std::fs::read(data("vtu/appended-raw-zlib.vtu")).unwrap(),
        ),
        ("f.vtu", std::fs::read(data("vtu/binary-zlib.vtu")).unwrap()),
    ];
    let mut state = 0x2545_f491_4f6c_dd1du64;
    let mut rand = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        state
    };
    let mut errors = 0;
    for (name, bytes) in &inputs {
        for i in 0..300 {
            let mut b = bytes.clone();
            match i % 3 {
                0 => b.truncate(rand() as usize % b.len()),
                1 => {
                    for _ in 0..1 + rand() % 4 {
                        let k = rand() as usize % b.len();
                        b[k] ^= 1 << (rand() % 8);
                    }
                }
                _ => {
                    let k = rand() as usize % b.len();
                    b[k] = rand() as u8;
                    b.truncate(b.len() - rand() as usize % 16);
                }
            }
            let p = Path::new(name);
            let r = if name.ends_with(".vtk") {
                vtk_legacy::parse(&b, p)
            } else if name.ends_with(".vtu") {
                vtu::parse(&b, p)
            } else {
                let f = dir.path().join(name);
                std::fs::write(&f, &b).unwrap();
                read_mesh(&f).map_err(|e| pvrsim::Error::data(p, "", e.to_string()))
            };
            if let Err(e) = r.and_then(|m| m.validate(p).map(|_| m)) {
                assert!(e.to_string().starts_with(name), "{e}");
                errors += 1;
            }
        }
    }
    assert!(errors > 400, "only {errors} of 1200 variants were rejected");
}

#[test]
fn misspelt_keyword_in_binary_file_is_named_with_its_line() {
    let mut b = std::fs::read(data("aorta-small.vtk")).unwrap();
    let at = b.windows(15).position(|w| w == b"POINT_DATA 5326").unwrap();
    b.splice(at..at + 10, b"POINT_DATTA".iter().copied());
    expect_err(
        "k.vtk",
        &b,
        &["line 23114", "unknown keyword \"POINT_DATTA\""],
    );
}
