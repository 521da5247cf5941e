//! Format tests for the mesh readers: the shared datasets load with the
//! documented sizes and fields, every encoding of the same mesh reads the same.

use std::path::{Path, PathBuf};

use pvrsim::data::io::read_mesh;

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data").join(name)
}

#[test]
fn aorta_full_load_time() {
    let p = Path::new("/work/shared/data/aorta.vtk");
    if !p.exists() {
        return;
    }
    let t = std::time::Instant::now();
    let m = read_mesh(p).unwrap();
    eprintln!("aorta.vtk: {} points, {} tets in {:?}", m.points.len(), m.tets.len(), t.elapsed());
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
