//! Volume readers on the bundled excerpts, and bad input: every case is an
//! `Err` naming the file and the field, line or element, never a panic
//! (plus fuzzing with random and mutated files).

use std::path::{Path, PathBuf};

use proptest::prelude::*;
use pvrsim::data::io::read_volume;
use pvrsim::data::{read_dataset, Dataset, Volume, Voxels};

mod support;

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(name)
}

fn read_as(name: &str, bytes: &[u8]) -> (String, Result<Volume, pvrsim::Error>) {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join(name);
    std::fs::write(&p, bytes).unwrap();
    let r = read_volume(&p, "");
    (p.display().to_string(), r)
}

/// Asserts reading `bytes` as a volume fails with a message naming the
/// file and every needle.
fn expect_err(name: &str, bytes: &[u8], needles: &[&str]) {
    support::expect_err(name, bytes, needles, |p| read_volume(p, ""));
}

const CROP_SUM: f64 = 5_611_467.0; // printed by tests/data/volume/make_excerpts.py

#[test]
fn bundled_crop_is_identical_in_three_formats() {
    let a = read_volume(&data("volume/mni-crop.nhdr"), "").unwrap();
    let b = read_volume(&data("volume/mni-crop.nii.gz"), "").unwrap();
    let c = read_volume(&data("volume/mni-crop.vti"), "t1").unwrap();
    for v in [&a, &b, &c] {
        assert_eq!(v.dims, [32; 3]);
        assert_eq!(v.spacing, [1.0; 3]);
        assert_eq!(v.origin, [-18.0, -34.0, 8.0]);
        let sum: f64 = (0..v.len()).map(|i| v.voxels.get_f32(i) as f64).sum();
        assert_eq!(sum, CROP_SUM);
    }
    assert_eq!(a.voxels, b.voxels);
    assert_eq!(a.voxels, c.voxels);
    // Against the full template when the shared folder is there.
    let full = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/data/mni152_t1.nhdr");
    if !full.exists() {
        eprintln!("SKIPPED: comparison with {} (absent)", full.display());
        return;
    }
    let f = read_volume(&full, "").unwrap();
    for (i, j, k) in [(0, 0, 0), (31, 0, 5), (7, 19, 31), (31, 31, 31)] {
        assert_eq!(a.get(i, j, k), f.get(80 + i, 100 + j, 80 + k));
    }
}

#[test]
fn bundled_lobster_and_dataset_dispatch() {
    let v = read_volume(&data("lobster.fld"), "").unwrap();
    assert_eq!(v.dims, [120, 120, 34]);
    assert!(matches!(
        read_dataset(&data("lobster.fld"), "").unwrap(),
        Dataset::Volume(_)
    ));
    assert!(matches!(
        read_dataset(&data("spx.inp"), "density").unwrap(),
        Dataset::Mesh(_)
    ));
    let e = read_dataset(Path::new("x.png"), "")
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("x.png") && e.contains(".nii.gz") && e.contains(".vtk"),
        "{e}"
    );
}

#[test]
fn generated_volumes_and_scenes_load() {
    let dir = tempfile::tempdir().unwrap();
    for (kind, size) in [("hydrogen", "24"), ("marschner-lobb", "17")] {
        let out = dir.path().join(format!("{kind}.nrrd"));
        let st = std::process::Command::new(env!("CARGO_BIN_EXE_pvrsim"))
            .args(["generate", kind, "--size", size, "-o"])
            .arg(&out)
            .status()
            .unwrap();
        assert!(st.success());
        let scene = pvrsim::scene::Scene::load(&out.with_extension("toml")).unwrap();
        let v = read_volume(&scene.data.path, &scene.data.field).unwrap();
        assert_eq!(v.dims[0], size.parse::<u64>().unwrap());
    }
    let st = std::process::Command::new(env!("CARGO_BIN_EXE_pvrsim"))
        .args(["generate", "hydrogen", "--size", "8", "-o"])
        .arg(dir.path().join("h.vtk"))
        .output()
        .unwrap();
    assert!(!st.status.success());
    assert!(String::from_utf8_lossy(&st.stderr).contains(".nrrd"));
}

#[test]
fn mesh_field_grid_renders_like_the_mesh_and_scene_fits_grids() {
    let dir = tempfile::tempdir().unwrap();
    let data = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data");
    let pv = |args: &[&std::ffi::OsStr]| {
        std::process::Command::new(env!("CARGO_BIN_EXE_pvrsim"))
            .args(args)
            .output()
            .unwrap()
    };
    // The aorta-small scene's field on a grid: the new scene keeps the
    // camera, the transfer function and the value range.
    let out = dir.path().join("ab.nrrd");
    let o = pv(&[
        "generate".as_ref(),
        "mesh-field".as_ref(),
        "--input".as_ref(),
        data.join("aorta-small-view-b.toml").as_os_str(),
        "--size".as_ref(),
        "96".as_ref(),
        "-o".as_ref(),
        out.as_os_str(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let mesh_scene = pvrsim::scene::Scene::load(&data.join("aorta-small-view-b.toml")).unwrap();
    let grid_scene = pvrsim::scene::Scene::load(&out.with_extension("toml")).unwrap();
    assert_eq!(grid_scene.camera, mesh_scene.camera);
    assert_eq!(grid_scene.transfer, mesh_scene.transfer);
    let v = read_volume(&grid_scene.data.path, &grid_scene.data.field).unwrap();
    assert_eq!(v.dims.iter().max(), Some(&96));
    let mesh = pvrsim::data::io::read_mesh(&mesh_scene.data.path).unwrap();
    let s = mesh.scalar("speed").unwrap();
    let hi = s.iter().cloned().fold(f64::MIN, f64::max);
    assert_eq!(grid_scene.data.range, Some([0.0, hi]));
    // Every sample lies within the mesh field's range (barycentric
    // interpolation is a convex combination), and most of the box is inside.
    let r = v.value_range();
    assert!(r[0] >= 0.0 && r[1] <= hi + 1e-6, "{r:?}");
    let o = pv(&[
        "render".as_ref(),
        out.with_extension("toml").as_os_str(),
        "-o".as_ref(),
        dir.path().join("ab.png").as_os_str(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    // Bad input: a grid scene is not a mesh; --field on another generator.
    let o = pv(&[
        "generate".as_ref(),
        "mesh-field".as_ref(),
        "--input".as_ref(),
        data.join("lobster.fld").as_os_str(),
        "-o".as_ref(),
        out.as_os_str(),
        "--force".as_ref(), // `out` exists: the input must be what fails
    ]);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("lobster.fld"));
    let o = pv(&[
        "generate".as_ref(),
        "hydrogen".as_ref(),
        "--field".as_ref(),
        "x".as_ref(),
        "-o".as_ref(),
        out.as_os_str(),
        "--force".as_ref(),
    ]);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("--field"));

    // `pvrsim scene` on a grid: no --field needed, a TF clear at the minimum.
    let toml = dir.path().join("lobster.toml");
    let o = pv(&[
        "scene".as_ref(),
        data.join("lobster.fld").as_os_str(),
        "-o".as_ref(),
        toml.as_os_str(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let sc = pvrsim::scene::Scene::load(&toml).unwrap();
    assert_eq!(sc.data.field, "intensity");
    assert_eq!(sc.transfer.points[0].opacity, 0.0);
    assert_eq!(sc.data.range, Some([0.0, 255.0]));
    let o = pv(&[
        "render".as_ref(),
        toml.as_os_str(),
        "-o".as_ref(),
        dir.path().join("l.png").as_os_str(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

fn nrrd(body: &str, data: &[u8]) -> Vec<u8> {
    let mut v = format!("NRRD0004\n{body}\n\n").into_bytes();
    v.extend_from_slice(data);
    v
}

const H: &str = "type: uint8\ndimension: 3\nsizes: 2 2 2\nencoding: raw";

#[test]
fn nrrd_errors() {
    assert!(read_as("ok.nrrd", &nrrd(H, &[0; 8])).1.is_ok());
    expect_err(
        "t.nrrd",
        &nrrd(H, &[0; 7]),
        &["truncated", "7 bytes", "need 8"],
    );
    expect_err(
        "o.nrrd",
        &nrrd(&H.replace("2 2 2", "4294967296 4294967296 2"), &[0; 8]),
        &["line 4 (`sizes`)", "64 bits"],
    );
    expect_err(
        "l.nrrd",
        &nrrd(&H.replace("2 2 2", "100000 100000 100000"), &[0; 8]),
        &["line 4 (`sizes`)", "exceed the 64 GiB limit"],
    );
    expect_err(
        "b.nrrd",
        &nrrd(&H.replace("2 2 2", "1000 1000 1000"), &[0; 8]),
        &["truncated", "need 1000000000"],
    );
    expect_err(
        "g.nrrd",
        &nrrd(
            &H.replace("raw", "gzip").replace("2 2 2", "1000 1000 100"),
            &[0x1f, 0x8b, 0, 0],
        ),
        &["at most", "truncated"],
    );
    expect_err(
        "g.nrrd",
        &nrrd(&H.replace("raw", "gzip"), b"not gzip at all"),
        &["gzip data is corrupt"],
    );
    expect_err(
        "u.nrrd",
        &nrrd(&H.replace("uint8", "block"), &[0; 8]),
        &["line 2 (`type`)", "block"],
    );
    expect_err(
        "z.nrrd",
        &nrrd(&H.replace("raw", "bzip2"), &[0; 8]),
        &["`encoding`", "bzip2"],
    );
    expect_err(
        "e.nrrd",
        &nrrd(&H.replace("uint8", "short"), &[0; 16]),
        &["`endian`", "required"],
    );
    expect_err("m.nrrd", b"P5 2 2\n", &["line 1", "not a NRRD file"]);
    expect_err(
        "l.nrrd",
        &nrrd(&format!("{H}\nsizes 2 2 2"), &[0; 8]),
        &["line 6", "field: value"],
    );
    expect_err(
        "k.nrrd",
        &nrrd(&format!("{H}\nbanana: 3"), &[0; 8]),
        &["line 6", "unknown field \"banana\""],
    );
    expect_err(
        "p.nrrd",
        &nrrd(
            &format!("{H}\nspace directions: (0,1,0) (1,0,0) (0,0,1)"),
            &[0; 8],
        ),
        &["`space directions`", "permuted"],
    );
    expect_err(
        "r.nrrd",
        &nrrd(
            &format!("{H}\nspace directions: (1,0.5,0) (0,1,0) (0,0,1)"),
            &[0; 8],
        ),
        &["not axis-aligned"],
    );
    expect_err(
        "d.nrrd",
        &nrrd(
            "type: uint8\ndimension: 4\nsizes: 2 2 2 2\nencoding: raw",
            &[0; 16],
        ),
        &["dimension 4"],
    );
    expect_err(
        "s.nrrd",
        &nrrd(&H.replace("sizes: 2 2 2", "sizes: 2 2"), &[0; 8]),
        &["2 sizes for dimension 3"],
    );
    expect_err(
        "n.nrrd",
        &nrrd(
            &H.replace("uint8", "float").replace("raw", "ascii"),
            b"1 2 3 nan 5 6 7 8",
        ),
        &["voxel 3", "not finite"],
    );
    expect_err(
        "a.nrrd",
        &nrrd(&H.replace("raw", "ascii"), b"1 2 3 4 5 6 7 300"),
        &["sample 7", "300"],
    );
    expect_err(
        "x.nhdr",
        format!("NRRD0004\n{H}\n").as_bytes(),
        &["data file"],
    );
    expect_err(
        "f.nhdr",
        format!("NRRD0004\n{H}\ndata file: missing.raw\n").as_bytes(),
        &["missing.raw"],
    );
    expect_err(
        "q.nhdr",
        format!("NRRD0004\n{H}\ndata file: LIST\n").as_bytes(),
        &["LIST", "not supported"],
    );
}

fn nifti(dims: [i16; 4], datatype: i16, data: &[u8]) -> Vec<u8> {
    let mut h = vec![0u8; 352];
    h[0..4].copy_from_slice(&348i32.to_le_bytes());
    let d = [dims[0], dims[1], dims[2], dims[3], 1, 1, 1, 1];
    for (i, v) in d.iter().enumerate() {
        h[40 + 2 * i..42 + 2 * i].copy_from_slice(&v.to_le_bytes());
    }
    h[70..72].copy_from_slice(&datatype.to_le_bytes());
    for i in 0..8 {
        h[76 + 4 * i..80 + 4 * i].copy_from_slice(&1f32.to_le_bytes());
    }
    h[108..112].copy_from_slice(&352f32.to_le_bytes());
    h[344..348].copy_from_slice(b"n+1\0");
    h.extend_from_slice(data);
    h
}

#[test]
fn nifti_errors() {
    let ok = read_as("ok.nii", &nifti([3, 2, 2, 2], 2, &[7; 8]))
        .1
        .unwrap();
    assert_eq!(ok.voxels, Voxels::U8(vec![7; 8]));
    expect_err(
        "t.nii",
        &nifti([3, 2, 2, 2], 2, &[0; 7]),
        &["truncated", "need 360"],
    );
    expect_err(
        "h.nii",
        &nifti([3, 2, 2, 2], 2, &[])[..100],
        &["header", "truncated"],
    );
    expect_err("s.nii", &[0u8; 400], &["sizeof_hdr", "not a NIfTI-1"]);
    expect_err(
        "4.nii",
        &nifti([4, 2, 2, 2], 2, &[0; 8])
            .iter()
            .enumerate()
            .map(|(i, &b)| if i == 48 { 5 } else { b })
            .collect::<Vec<_>>(),
        &["dim[4]", "not supported"],
    );
    expect_err(
        "c.nii",
        &nifti([3, 2, 2, 2], 32, &[0; 64]),
        &["datatype", "complex"],
    );
    expect_err(
        "n.nii",
        &nifti([3, -2, 2, 2], 2, &[0; 8]),
        &["dim[1]", "-2"],
    );
    let mut two = nifti([3, 2, 2, 2], 2, &[0; 8]);
    two[344..348].copy_from_slice(b"ni1\0");
    expect_err("p.nii", &two, &["magic", ".hdr/.img"]);
    // A gzip file claiming far more than it could hold.
    let big = nifti([3, 3000, 3000, 300], 16, &[]);
    let gz = {
        use std::io::Write;
        let mut e = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
        e.write_all(&big).unwrap();
        e.finish().unwrap()
    };
    expect_err("b.nii.gz", &gz, &["at most"]);
}

#[test]
fn vti_errors() {
    let good = std::fs::read(data("volume/mni-crop.vti")).unwrap();
    let text = String::from_utf8(good.clone()).unwrap();
    let (_, r) = read_as("f.vti", &good);
    assert!(r.is_ok());
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("n.vti");
    std::fs::write(&p, &good).unwrap();
    let e = read_volume(&p, "density").unwrap_err().to_string();
    assert!(
        e.contains("no array named \"density\"") && e.contains("\"t1\""),
        "{e}"
    );
    let cut = text.find("</DataArray>").unwrap() - 200;
    let trunc = format!(
        "{}{}",
        &text[..cut],
        &text[text.find("</DataArray>").unwrap()..]
    );
    expect_err(
        "t.vti",
        trunc.as_bytes(),
        &["<DataArray Name=\"t1\">", "truncated"],
    );
    expect_err(
        "x.vti",
        text.replace("Piece Extent=\"80 111", "Piece Extent=\"80 100")
            .as_bytes(),
        &["<Piece> 0", "partial"],
    );
    expect_err(
        "u.vti",
        text.replace("ImageData\" version", "UnstructuredGrid\" version")
            .as_bytes(),
        &["<VTKFile>", "ImageData"],
    );
    expect_err(
        "c.vti",
        text.replace(
            "format=\"binary\"",
            "format=\"binary\" NumberOfComponents=\"3\"",
        )
        .as_bytes(),
        &["3 components"],
    );
    expect_err(
        "d.vti",
        text.replace(
            "Spacing=\"1 1 1\"",
            "Spacing=\"1 1 1\" Direction=\"0 1 0 1 0 0 0 0 1\"",
        )
        .as_bytes(),
        &["permuted"],
    );
}

#[test]
fn fld_errors() {
    let good = std::fs::read(data("lobster.fld")).unwrap();
    expect_err(
        "t.fld",
        &good[..good.len() - 1],
        &["truncated", "489599 bytes", "need 489600"],
    );
    let ff = good.windows(2).position(|w| w == b"\x0c\x0c").unwrap();
    expect_err("n.fld", &good[..ff], &["two form feeds"]);
    let text = String::from_utf8(good[..ff].to_vec()).unwrap();
    let with = |h: String| {
        let mut v = h.into_bytes();
        v.extend_from_slice(&good[ff..]);
        v
    };
    expect_err(
        "v.fld",
        &with(text.replace("veclen = 1", "veclen = 3")),
        &["veclen"],
    );
    expect_err(
        "k.fld",
        &with(text.replace("nspace", "nspaceship")),
        &["line 6", "nspaceship"],
    );
    expect_err(
        "d.fld",
        &with(text.replace("byte", "complex")),
        &["`data`", "complex"],
    );
    expect_err(
        "r.fld",
        &with(text.replace("uniform", "rectilinear")),
        &["`field`", "rectilinear"],
    );
    expect_err(
        "o.fld",
        &with(text.replace("dim1   = 120", "dim1   = 99999")),
        &["truncated"],
    );
    expect_err(
        "m.fld",
        &with(text.replace("dim2   = 120\n", "")),
        &["dim2", "missing"],
    );
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    /// Random bytes under every volume extension: an error, never a panic.
    #[test]
    fn random_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..600), ext in 0usize..6) {
        let name = ["r.nrrd", "r.nhdr", "r.nii", "r.nii.gz", "r.vti", "r.fld"][ext];
        let _ = read_as(name, &bytes).1;
    }

    /// Mutated and truncated real files: an error or a volume, never a panic.
    #[test]
    fn mutated_files_never_panic(which in 0usize..4, cut in 0.0f64..1.0, edits in proptest::collection::vec((0.0f64..1.0, any::<u8>()), 0..6)) {
        let (src, name) = [
            ("volume/mni-crop.nhdr", "m.nhdr"),
            ("volume/mni-crop.vti", "m.vti"),
            ("lobster.fld", "m.fld"),
            ("volume/mni-crop.nii.gz", "m.nii.gz"),
        ][which];
        let mut b = std::fs::read(data(src)).unwrap();
        // Headers are where the structure lives: mutate the first 400 bytes.
        let head = b.len().min(400);
        for (at, v) in edits {
            b[(at * head as f64) as usize % head] = v;
        }
        b.truncate(((cut * 1.2).min(1.0) * b.len() as f64) as usize);
        let dir = tempfile::tempdir().unwrap();
        // Keep the detached data file reachable for the .nhdr.
        std::fs::copy(data("volume/mni-crop.raw.gz"), dir.path().join("mni-crop.raw.gz")).unwrap();
        let p = dir.path().join(name);
        std::fs::write(&p, &b).unwrap();
        let _ = read_volume(&p, "");
    }
}
