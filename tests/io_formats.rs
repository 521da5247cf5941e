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

#[test]
fn aorta_full_load_time() {
    let p = Path::new("/work/shared/data/aorta.vtk");
    if !p.exists() {
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
    let p = Path::new("/work/shared/data/aorta.vtk");
    if !p.exists() {
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
    let p = Path::new("/work/shared/data/aorta.vtk");
    if !p.exists() {
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
