//! Format tests for the mesh readers: the shared datasets load with the
//! documented sizes and fields, every encoding of the same mesh reads the same.

use std::path::{Path, PathBuf};

use pvrsim::data::io::read_mesh;
use pvrsim::data::TetMesh;

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(name)
}

/// Compares two meshes, reporting the first difference (not the whole mesh).
fn assert_same(a: &TetMesh, b: &TetMesh, what: &str) {
    assert_eq!(a.points.len(), b.points.len(), "{what}: point count");
    if let Some(i) = (0..a.points.len()).find(|&i| a.points[i] != b.points[i]) {
        panic!("{what}: point {i}: {:?} vs {:?}", a.points[i], b.points[i]);
    }
    assert_eq!(a.tets.len(), b.tets.len(), "{what}: tet count");
    if let Some(i) = (0..a.tets.len()).find(|&i| a.tets[i] != b.tets[i]) {
        panic!("{what}: tet {i}: {:?} vs {:?}", a.tets[i], b.tets[i]);
    }
    let names = |m: &TetMesh| {
        m.fields
            .iter()
            .map(|f| (f.name.clone(), f.components))
            .collect::<Vec<_>>()
    };
    assert_eq!(names(a), names(b), "{what}: fields");
    for (fa, fb) in a.fields.iter().zip(&b.fields) {
        if let Some(i) = (0..fa.values.len()).find(|&i| fa.values[i] != fb.values[i]) {
            panic!(
                "{what}: field {} value {i}: {} vs {}",
                fa.name, fa.values[i], fb.values[i]
            );
        }
    }
}

/// `aorta.vtk` in the shared data folder next to this checkout.
fn shared_aorta() -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/data/aorta.vtk")
}

#[test]
fn aorta_full_load_time() {
    let p = &shared_aorta();
    if !p.exists() {
        eprintln!(
            "skipping: {} not found (the shared data folder is not next to this checkout)",
            p.display()
        );
        return;
    }
    let t = std::time::Instant::now();
    let m = read_mesh(p).unwrap();
    eprintln!(
        "aorta.vtk: {} points, {} tets in {:?}",
        m.points.len(),
        m.tets.len(),
        t.elapsed()
    );
    assert_eq!(m.tets.len(), 305_703);
}

#[test]
fn aorta_full_load_time_repeat() {
    let p = &shared_aorta();
    if !p.exists() {
        eprintln!(
            "skipping: {} not found (the shared data folder is not next to this checkout)",
            p.display()
        );
        return;
    }
    for _ in 0..3 {
        let t = std::time::Instant::now();
        let b = std::fs::read(p).unwrap();
        let t1 = t.elapsed();
        let m = pvrsim::data::io::vtk_legacy::parse(&b, p).unwrap();
        let t2 = t.elapsed();
        m.validate(p).unwrap();
        eprintln!("read {t1:?} parse {t2:?} validate {:?}", t.elapsed());
    }
}

#[test]
fn spx_loads() {
    let m = read_mesh(&data("spx.inp")).unwrap();
    assert_eq!(m.points.len(), 2896);
    assert_eq!(m.tets.len(), 12_936);
    assert_eq!(m.fields.len(), 1);
    assert_eq!(m.fields[0].name, "density");
    let neg = (0..m.tets.len()).filter(|&t| m.tet_volume(t) < 0.0).count();
    let zero = (0..m.tets.len())
        .filter(|&t| m.tet_volume(t) == 0.0)
        .count();
    eprintln!(
        "spx: {neg} negative, {zero} zero-volume tets; bounds {:?}",
        m.bounds()
    );
}

#[test]
fn aorta_small_loads() {
    let m = read_mesh(&data("aorta-small.vtk")).unwrap();
    assert_eq!(m.tets.len(), 20_169);
    assert_eq!(m.points.len(), 5_326);
    let names: Vec<&str> = m.fields.iter().map(|f| f.name.as_str()).collect();
    for n in ["speed", "pressure", "potential", "velocity"] {
        assert!(names.contains(&n), "{names:?}");
    }
    assert_eq!(
        m.fields
            .iter()
            .find(|f| f.name == "velocity")
            .unwrap()
            .components,
        3
    );
    let speed = m.scalar("speed").unwrap();
    let max = speed.iter().cloned().fold(f64::MIN, f64::max);
    let min = speed.iter().cloned().fold(f64::MAX, f64::min);
    assert!((max - 1.617).abs() < 1e-3, "{max}");
    assert!(min.abs() < 1e-9);
}

#[test]
fn ascii_and_binary_legacy_round_trip() {
    let m = read_mesh(&data("aorta-small.vtk")).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let (a, b) = (dir.path().join("a.vtk"), dir.path().join("b.vtk"));
    pvrsim::data::io::write_vtk_legacy(&m, &a, false).unwrap();
    pvrsim::data::io::write_vtk_legacy(&m, &b, true).unwrap();
    let ma = read_mesh(&a).unwrap();
    let mb = read_mesh(&b).unwrap();
    // The source is float32, so the f32 writer loses nothing.
    assert_same(&ma, &m, "ascii");
    assert_same(&mb, &m, "binary");
}

/// meshio's view of the fixtures (see tests/data/vtu/make_fixtures.py).
fn vtu_expected() -> (serde_json::Value, TetMesh) {
    let text = std::fs::read_to_string(data("vtu/expected.json")).unwrap();
    let v: serde_json::Value = serde_json::from_str(&text).unwrap();
    let f = |x: &serde_json::Value| x.as_str().unwrap().parse::<f64>().unwrap();
    let points = v["points"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| [f(&p[0]), f(&p[1]), f(&p[2])])
        .collect();
    let tets = v["tets"]
        .as_array()
        .unwrap()
        .iter()
        .map(|t| [0, 1, 2, 3].map(|k| t[k].as_u64().unwrap() as u32))
        .collect();
    let mut fields: Vec<pvrsim::data::Field> = v["fields"]
        .as_object()
        .unwrap()
        .iter()
        .map(|(name, rows)| {
            let rows = rows.as_array().unwrap();
            let components = rows[0].as_array().unwrap().len();
            let values = rows
                .iter()
                .flat_map(|r| r.as_array().unwrap().iter().map(f))
                .collect();
            pvrsim::data::Field {
                name: name.clone(),
                components,
                values,
            }
        })
        .collect();
    fields.sort_by(|a, b| a.name.cmp(&b.name));
    (
        v,
        TetMesh {
            points,
            tets,
            fields,
        },
    )
}

#[test]
fn every_vtu_fixture_equals_meshio_view() {
    let (v, expected) = vtu_expected();
    let files = v["files"].as_array().unwrap();
    assert_eq!(files.len(), 9);
    for name in files {
        let name = name.as_str().unwrap();
        let mut m = read_mesh(&data(&format!("vtu/{name}"))).unwrap_or_else(|e| panic!("{e}"));
        m.fields.sort_by(|a, b| a.name.cmp(&b.name));
        if name == "ascii.vtu" {
            // meshio prints 12 significant digits.
            assert_eq!(m.tets, expected.tets);
            for (a, b) in m
                .points
                .iter()
                .flatten()
                .zip(expected.points.iter().flatten())
            {
                assert!(
                    (a - b).abs() <= 1e-12 * b.abs().max(1e-300),
                    "{name}: {a} vs {b}"
                );
            }
            for (fa, fb) in m.fields.iter().zip(&expected.fields) {
                assert_eq!((&fa.name, fa.components), (&fb.name, fb.components));
                for (a, b) in fa.values.iter().zip(&fb.values) {
                    assert!(
                        (a - b).abs() <= 1e-11 * b.abs(),
                        "{name} {}: {a} vs {b}",
                        fa.name
                    );
                }
            }
        } else {
            assert_same(&m, &expected, name);
        }
    }
}

#[test]
fn aorta_quality_report_matches_the_data_readme() {
    let p = &shared_aorta();
    if !p.exists() {
        eprintln!(
            "skipping: {} not found (the shared data folder is not next to this checkout)",
            p.display()
        );
        return;
    }
    let m = read_mesh(p).unwrap();
    let t = std::time::Instant::now();
    let adj = m.adjacency();
    let t_adj = t.elapsed();
    let r = pvrsim::data::quality::MeshReport::compute(&m, &adj);
    eprintln!("adjacency {t_adj:?}, report {:?}\n{r}", t.elapsed() - t_adj);
    let v = r.volume.unwrap();
    assert!(
        (v.min - 0.089).abs() < 0.001
            && (v.median - 0.588).abs() < 0.001
            && (v.max - 1.66).abs() < 0.01
    );
    assert!((r.volume_total - 186_067.0).abs() < 1.0);
    let a = r.min_dihedral_deg.unwrap();
    assert!((a.min - 11.5).abs() < 0.05 && (a.median - 48.4).abs() < 0.05);
    assert!((r.min_dihedral_p1_deg.unwrap() - 18.2).abs() < 0.05);
    assert_eq!(r.dihedral_below_15, 368);
    assert_eq!((r.inverted, r.degenerate, r.nonmanifold_faces), (0, 0, 0));
}

/// A 2x1x1 block: one hexahedron, then the next unit cube as two wedges,
/// a pyramid on top, and a skipped triangle and line. Classic ASCII layout.
const MIXED_ASCII: &str = "# vtk DataFile Version 2.0
mixed cells
ASCII

DATASET UNSTRUCTURED_GRID
POINTS 13 double
0 0 0  1 0 0  1 1 0  0 1 0
0 0 1  1 0 1  1 1 1  0 1 1
2 0 0  2 1 0  2 0 1  2 1 1
1.5 0.5 2
CELLS 6 36
8 0 1 2 3 4 5 6 7
6 1 8 9 5 10 11
6 1 9 2 5 11 6
5 5 10 11 6 12
3 0 1 5
2 0 1
CELL_TYPES 6
12 13 13 14 5 3
CELL_DATA 6
SCALARS material int 1
LOOKUP_TABLE default
1 2 2 3 4 5
POINT_DATA 13
FIELD FieldData 2
temp 1 13 float
0 1 2 3 4 5 6 7 8 9 10 11 12
vel%20xyz 3 13 double
0 0 0 1 0 0 2 0 0 3 0 0 4 0 0 5 0 0 6 0 0 7 0 0 8 0 0 9 0 0 10 0 0 11 0 0 12 0 0
";

#[test]
fn mixed_cells_are_decomposed_and_lower_dimensional_skipped() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("mixed.vtk");
    std::fs::write(&p, MIXED_ASCII).unwrap();
    let m = read_mesh(&p).unwrap();
    // 6 (hex) + 3 + 3 (wedges) + 2 (pyramid); triangle and line skipped.
    assert_eq!(m.tets.len(), 14);
    let vols: Vec<f64> = (0..m.tets.len()).map(|t| m.tet_volume(t)).collect();
    assert!(vols.iter().all(|&v| v > 0.0));
    let total: f64 = vols.iter().sum();
    assert!((total - (2.0 + 1.0 / 3.0)).abs() < 1e-12, "{total}");
    let adj = m.adjacency();
    assert_eq!(adj.nonmanifold_faces, 0);
    // Closed surface of the block plus pyramid: 2x1x1 box has 10 unit squares
    // (20 triangles); the pyramid covers one (-2) and adds 4 triangles.
    let boundary = adj
        .neighbors
        .iter()
        .flatten()
        .filter(|&&n| n == pvrsim::data::NO_NEIGHBOR)
        .count();
    assert_eq!(boundary, 22);
    assert_eq!(
        m.fields
            .iter()
            .map(|f| (f.name.as_str(), f.components))
            .collect::<Vec<_>>(),
        [("temp", 1), ("vel xyz", 3)]
    );
}

/// The same tetrahedral mesh in the VTK 5.1 layout (OFFSETS/CONNECTIVITY),
/// ASCII and binary, with CELL_DATA and METADATA to parse past.
fn legacy_51(binary: bool) -> Vec<u8> {
    let mut out = Vec::new();
    let head = |out: &mut Vec<u8>, s: &str| out.extend_from_slice(s.as_bytes());
    head(
        &mut out,
        &format!(
            "# vtk DataFile Version 5.1\nvtk output\n{}\nDATASET UNSTRUCTURED_GRID\n",
            if binary { "BINARY" } else { "ASCII" }
        ),
    );
    let pts: [f32; 15] = [0., 0., 0., 1., 0., 0., 0., 1., 0., 0., 0., 1., 1., 1., 1.];
    let offs: [i64; 3] = [0, 4, 8];
    let conn: [i64; 8] = [0, 1, 2, 3, 1, 2, 3, 4];
    let f = |out: &mut Vec<u8>, v: &[f32]| {
        if binary {
            v.iter()
                .for_each(|x| out.extend_from_slice(&x.to_be_bytes()));
            out.push(b'\n');
        } else {
            out.extend_from_slice(
                format!(
                    "{}\n",
                    v.iter()
                        .map(|x| x.to_string())
                        .collect::<Vec<_>>()
                        .join(" ")
                )
                .as_bytes(),
            );
        }
    };
    let i = |out: &mut Vec<u8>, v: &[i64]| {
        if binary {
            v.iter()
                .for_each(|x| out.extend_from_slice(&x.to_be_bytes()));
            out.push(b'\n');
        } else {
            out.extend_from_slice(
                format!(
                    "{}\n",
                    v.iter()
                        .map(|x| x.to_string())
                        .collect::<Vec<_>>()
                        .join(" ")
                )
                .as_bytes(),
            );
        }
    };
    head(&mut out, "POINTS 5 float\n");
    f(&mut out, &pts);
    head(&mut out, "METADATA\nINFORMATION 2\n\nNAME L2_NORM_RANGE LOCATION vtkDataArray\nDATA 2 0 1.73205\nNAME L2_NORM_FINITE_RANGE LOCATION vtkDataArray\nDATA 2 0 1.73205\n\n");
    head(&mut out, "CELLS 3 8\nOFFSETS vtktypeint64\n");
    i(&mut out, &offs);
    head(&mut out, "CONNECTIVITY vtktypeint64\n");
    i(&mut out, &conn);
    head(&mut out, "CELL_TYPES 2\n");
    if binary {
        [10i32, 10]
            .iter()
            .for_each(|x| out.extend_from_slice(&x.to_be_bytes()));
        out.push(b'\n');
    } else {
        head(&mut out, "10\n10\n");
    }
    head(
        &mut out,
        "CELL_DATA 2\nFIELD FieldData 2\nid 1 2 vtktypeint64\n",
    );
    i(&mut out, &[7, 8]);
    head(
        &mut out,
        "METADATA\nCOMPONENT_NAMES\nthe%20id\n\nINFORMATION 0\n\nid2 1 2 vtktypeint64\n",
    );
    i(&mut out, &[9, 10]);
    head(&mut out, "VECTORS cellvec double\n");
    if binary {
        [0.5f64; 6]
            .iter()
            .for_each(|x| out.extend_from_slice(&x.to_be_bytes()));
        out.push(b'\n');
    } else {
        head(&mut out, "0.5 0.5 0.5 0.5 0.5 0.5\n");
    }
    head(
        &mut out,
        "POINT_DATA 5\nSCALARS s float\nLOOKUP_TABLE default\n",
    );
    f(&mut out, &[0.0, 0.25, 0.5, 0.75, 1.0]);
    head(&mut out, "VECTORS v float\n");
    f(
        &mut out,
        &[
            1., 2., 3., 4., 5., 6., 7., 8., 9., 10., 11., 12., 13., 14., 15.,
        ],
    );
    out
}

#[test]
fn version_51_layout_ascii_equals_binary() {
    let dir = tempfile::tempdir().unwrap();
    let (a, b) = (dir.path().join("a.vtk"), dir.path().join("b.vtk"));
    std::fs::write(&a, legacy_51(false)).unwrap();
    std::fs::write(&b, legacy_51(true)).unwrap();
    let ma = read_mesh(&a).unwrap();
    let mb = read_mesh(&b).unwrap();
    assert_same(&ma, &mb, "5.1");
    assert_eq!(ma.tets, vec![[0, 1, 2, 3], [1, 2, 3, 4]]);
    assert_eq!(ma.fields.len(), 2);
    assert_eq!(ma.fields[1].values[14], 15.0);
}

#[test]
fn spx_scene_loads_and_its_data_and_field_exist() {
    let scene = pvrsim::scene::Scene::load(&data("spx.toml")).unwrap();
    let path = if scene.data.path.is_absolute() {
        scene.data.path.clone()
    } else {
        data("").join(&scene.data.path)
    };
    let m = read_mesh(&path).unwrap();
    m.scalar(&scene.data.field).unwrap();
    assert_eq!((scene.image.width, scene.image.height), (256, 256));
}
