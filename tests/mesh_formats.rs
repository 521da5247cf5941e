//! One decision of a data file's format ([`mesh_format`], [`data_format`])
//! and every command reading every mesh format the readers know (`.vtk`,
//! `.vtu`, `.pvtu`, `.inp`): `pvrsim scene`, `info`, `render`, `partition`.

use std::path::Path;

mod cli_support;
use cli_support::{copy_vtk_pieces, data, pvrsim};

use pvrsim::data::io::volume::VolumeFormat;
use pvrsim::data::io::{mesh_format, MeshFormat};
use pvrsim::data::{data_format, DataFormat};

#[test]
fn formats_by_name() {
    let m = |p: &str| mesh_format(Path::new(p));
    assert_eq!(m("a/b.vtk"), Some(MeshFormat::VtkLegacy));
    assert_eq!(m("b.VTU"), Some(MeshFormat::Vtu));
    assert_eq!(m("dir.x/b.PvTu"), Some(MeshFormat::Pvtu));
    assert_eq!(m("b.inp"), Some(MeshFormat::AvsUcd));
    assert_eq!(m("b.vti"), None);
    assert_eq!(m("vtk"), None);
    let d = |p: &str| data_format(Path::new(p));
    assert_eq!(d("p.pvtu"), Some(DataFormat::Mesh(MeshFormat::Pvtu)));
    assert_eq!(
        d("head.nii.gz"),
        Some(DataFormat::Volume(VolumeFormat::Nifti))
    );
    assert_eq!(d("picture.png"), None);
    let e = pvrsim::data::read_dataset(Path::new("x.png"), "")
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("x.png") && e.contains(".pvtu") && e.contains(".nrrd"),
        "{e}"
    );
}

/// Runs `pvrsim ARGS`, which must succeed.
fn ok(args: &[&str]) {
    let (ok, err) = pvrsim(args);
    assert!(ok, "pvrsim {}: {err}", args.join(" "));
}

#[test]
fn every_command_reads_every_mesh_format() {
    let d = tempfile::tempdir().unwrap();
    let dir = d.path();
    let at = |name: &str| dir.join(name).display().to_string();
    copy_vtk_pieces("raw", dir);
    std::fs::copy(data("aorta-small.vtk"), dir.join("a.vtk")).unwrap();
    std::fs::copy(data("spx.inp"), dir.join("spx.inp")).unwrap();
    // A .vtu of the whole mesh: the one piece of a one-piece partition.
    ok(&[
        "partition",
        &at("a.vtk"),
        "--pieces",
        "1",
        "-o",
        &at("one.pvtu"),
    ]);
    for (file, field) in [
        ("a.vtk", "speed"),
        ("one_0.vtu", "speed"),
        ("a.pvtu", "speed"),
        ("spx.inp", "density"),
    ] {
        ok(&["info", &at(file), "--no-quality"]);
        let scene = at(&format!("{file}.toml"));
        ok(&[
            "scene",
            &at(file),
            "--field",
            field,
            "--size",
            "48x40",
            "-o",
            &scene,
        ]);
        let png = at(&format!("{file}.png"));
        ok(&["render", &scene, "--threads", "1", "-o", &png]);
        assert!(std::fs::metadata(&png).unwrap().len() > 0, "{file}");
        let parts = at(&format!("{file}-2.pvtu"));
        ok(&["partition", &at(file), "--pieces", "2", "-o", &parts]);
        ok(&["info", &parts, "--no-quality"]);
    }
}

#[test]
fn an_unknown_extension_is_named_by_every_command() {
    let d = tempfile::tempdir().unwrap();
    let p = d.path().join("mesh.obj");
    std::fs::write(&p, "v 0 0 0\n").unwrap();
    let p = p.display().to_string();
    let s = d.path().join("s.toml").display().to_string();
    let o = d.path().join("o.pvtu").display().to_string();
    for args in [
        vec!["info", p.as_str()],
        vec!["scene", p.as_str(), "-o", s.as_str()],
        vec!["partition", p.as_str(), "--pieces", "2", "-o", o.as_str()],
    ] {
        let (ok, err) = pvrsim(&args);
        assert!(!ok, "{args:?}");
        assert!(
            err.contains("mesh.obj") && err.contains(".pvtu"),
            "{args:?}: {err}"
        );
    }
}

/// `pvrsim info --json --no-quality FILE`, parsed.
fn info(file: &Path) -> serde_json::Value {
    let o = cli_support::run_in(
        file.parent().unwrap(),
        &["info", "--json", "--no-quality", file.to_str().unwrap()],
    );
    let (out, err) = cli_support::text(&o);
    assert!(o.status.success(), "{err}");
    serde_json::from_str(&out).unwrap()
}

/// The load path renumbers a scattered mesh (a randomly permuted copy of
/// the demo mesh) and keeps a local one's order; both render the same
/// canonical image.
#[test]
fn a_permuted_mesh_is_renumbered_at_load_and_renders_the_same_image() {
    let d = tempfile::tempdir().unwrap();
    let dir = d.path();
    let at = |name: &str| dir.join(name).display().to_string();
    ok(&[
        "demo",
        "--cells",
        "600000",
        "--nodes",
        "0",
        "--out-dir",
        &at("."),
    ]);
    ok(&[
        "generate",
        "permuted",
        "--input",
        &at("demo.vtk"),
        "-o",
        &at("perm.vtk"),
    ]);
    let ordered = info(&dir.join("demo.vtk"));
    let permuted = info(&dir.join("perm.vtk"));
    assert!(ordered["vertices"].as_u64().unwrap() > 1 << 16, "{ordered}");
    assert_eq!(ordered["renumbered"], false, "{ordered}");
    assert!(
        ordered["file_locality"].as_f64().unwrap() > 0.9,
        "{ordered}"
    );
    assert_eq!(permuted["renumbered"], true, "{permuted}");
    assert!(
        permuted["file_locality"].as_f64().unwrap() < 0.9,
        "{permuted}"
    );
    assert_eq!(permuted["tetrahedra"], ordered["tetrahedra"]);
    let scene = std::fs::read_to_string(dir.join("demo.toml")).unwrap();
    assert!(scene.contains("\"demo.vtk\""), "{scene}");
    std::fs::write(
        dir.join("perm.toml"),
        scene.replace("\"demo.vtk\"", "\"perm.vtk\""),
    )
    .unwrap();
    let render = |s: &str| {
        let png = at(&format!("{s}.png"));
        ok(&[
            "render",
            &at(&format!("{s}.toml")),
            "--canonical",
            "--ert",
            "1",
            "--width",
            "160",
            "--height",
            "120",
            "-o",
            &png,
        ]);
        std::fs::read(png).unwrap()
    };
    assert_eq!(render("demo"), render("perm"));
}
