//! Every shared grid loads, with the dimensions, placement and values its
//! README states, and the copies of one grid in two formats hold identical
//! voxels. Needs `../shared/data`; each test prints a message and returns
//! when it is absent (the bundled excerpts in `tests/io_volume.rs` cover the
//! readers without it).

use pvrsim::data::io::read_volume;
use pvrsim::data::{Volume, VoxelType};

mod support;
use support::shared;

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

#[test]
fn mni152_nifti_equals_nrrd() {
    let (Some(a), Some(b)) = (load("mni152_t1.nhdr"), load("mni152_t1.nii.gz")) else {
        return;
    };
    assert_eq!(a.dims, b.dims);
    assert_eq!(a.spacing, b.spacing);
    assert_eq!(a.origin, b.origin);
    assert_eq!(a.voxels, b.voxels, "voxels differ");
}

#[test]
fn frog_vti_equals_nrrd() {
    let (Some(a), Some(b)) = (load("frog.nhdr"), load("frog_tissues.vti")) else {
        return;
    };
    assert_eq!(b.field, "MetaImage");
    assert_eq!((a.dims, a.spacing, a.origin), (b.dims, b.spacing, b.origin));
    assert_eq!(a.voxels, b.voxels, "voxels differ");
    // The scene's field selects the same array; a wrong name lists the real one.
    let p = shared("frog_tissues.vti").unwrap();
    assert_eq!(read_volume(&p, "MetaImage").unwrap().voxels, b.voxels);
    let e = read_volume(&p, "speed").unwrap_err().to_string();
    assert!(e.contains("\"MetaImage\""), "{e}");
}

#[test]
fn lobster_fld() {
    let Some(v) = load("lobster.fld") else { return };
    assert_eq!(v.dims, [120, 120, 34]);
    assert_eq!(v.voxels.voxel_type(), VoxelType::U8);
    assert_eq!((v.spacing, v.origin), ([1.0; 3], [0.0; 3]));
    // The first non-zero bytes after the header's two form feeds (checked
    // with python: bytes 16 and 17 of the data are 44 and 38).
    assert_eq!((v.get(16, 0, 0), v.get(17, 0, 0)), (44.0, 38.0));
    assert_eq!(v.get(15, 0, 0), 0.0);
}

#[test]
fn colin27_nifti() {
    let Some(v) = load("colin27-brain.nii.gz") else {
        return;
    };
    assert_eq!(v.dims, [301, 370, 316]);
    assert_eq!(v.voxels.voxel_type(), VoxelType::U8);
    assert_eq!(v.spacing, [0.5; 3]);
    assert_eq!(v.origin, [-75.0, -107.0, -69.5]);
    let z = zero_fraction(&v);
    assert!((z - 0.63).abs() < 0.01, "zero fraction {z}");
    let [lo, hi] = v.value_range();
    assert!(lo == 0.0 && (125.0..=140.0).contains(&hi), "{lo} {hi}");
}
