//! Every shared grid loads, with the dimensions, placement and values its
//! README states, and the copies of one grid in two formats hold identical
//! voxels. Needs `../shared/data`; each test prints a message and returns
//! when it is absent (the bundled excerpts in `tests/io_volume.rs` cover the
//! readers without it).

use std::path::{Path, PathBuf};

use pvrsim::data::io::read_volume;
use pvrsim::data::{Volume, VoxelType};

fn shared(name: &str) -> Option<PathBuf> {
    let p = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/data")
        .join(name);
    if p.exists() {
        Some(p)
    } else {
        eprintln!(
            "SKIPPED: {} is absent (needs the shared data folder)",
            p.display()
        );
        None
    }
}

fn load(name: &str) -> Option<Volume> {
    let p = shared(name)?;
    Some(read_volume(&p, "").unwrap_or_else(|e| panic!("{e}")))
}

fn zero_fraction(v: &Volume) -> f64 {
    let n = v.len();
    (0..n).filter(|&i| v.voxels.get_f32(i) == 0.0).count() as f64 / n as f64
}

#[test]
fn mni152_nhdr() {
    let Some(v) = load("mni152_t1.nhdr") else {
        return;
    };
    assert_eq!(v.dims, [197, 233, 189]);
    assert_eq!(v.voxels.voxel_type(), VoxelType::U8);
    assert_eq!(v.spacing, [1.0; 3]);
    assert_eq!(v.origin, [-98.0, -134.0, -72.0]);
    let [lo, hi] = v.value_range();
    assert!(lo == 0.0 && hi > 200.0, "{lo} {hi}");
}

#[test]
fn frog_nhdr_gzip() {
    let Some(v) = load("frog.nhdr") else { return };
    assert_eq!(v.dims, [500, 470, 136]);
    assert_eq!(v.spacing, [1.0, 1.0, 1.5]);
    assert_eq!(v.origin, [0.0; 3]);
    assert_eq!(v.value_range(), [0.0, 29.0]);
    assert!(zero_fraction(&v) > 0.5);
}
