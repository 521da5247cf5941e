//! The command line as a careful user meets it (issue 8), part 2: what is
//! written and printed (items 4, 7, 8, 9, 10). Every test runs the binary
//! on the bundled `tests/data` scenes in a temporary directory.

mod cli_support;

use std::path::Path;

use cli_support::*;

// ---------------------------------------------------------------- item 4

#[test]
fn item4_output_paths_are_checked_before_work() {
    let d = tempfile::tempdir().unwrap();
    let s = small_b();
    // A typo does not create a tree.
    let o = run_in(d.path(), &["render", &s, "-o", "no/such/dir/x.png"]);
    fails_with(&o, &["at most one missing level"]);
    assert!(!d.path().join("no").exists());
    let o = run_in(d.path(), &["render", &s, "--stats", "a/b/s.json"]);
    fails_with(&o, &["--stats a/b/s.json"]);
    // The format is checked before the render.
    let o = run_in(d.path(), &["render", &s, "-o", "out.jpg"]);
    fails_with(&o, &[".jpg is not supported"]);
    assert!(!text(&o).0.contains("cell projection"), "rendered first");
    let o = run_in(d.path(), &["cluster", &s, "--report", "r.txt"]);
    fails_with(&o, &["--report r.txt", "JSON"]);
    // One missing level is created, and said.
    let o = run_in(d.path(), &["render", &s, "-o", "new/x.png"]);
    assert!(o.status.success());
    assert!(text(&o).1.contains("note: created directory new"));
    assert!(d.path().join("new/x.png").exists());
    // A camera that sees nothing: a warning.
    let scene = std::fs::read_to_string(data("spx.toml")).unwrap();
    let away = scene
        .replace(
            "path  = \"spx.inp\"",
            &format!("path = {:?}", data("spx.inp").display().to_string()),
        )
        .replace("eye        = [7.0303,", "eye        = [107.0303,")
        .replace("target     = [7.0303,", "target     = [107.0303,");
    std::fs::write(d.path().join("away.toml"), away).unwrap();
    let o = run_in(d.path(), &["render", "away.toml", "-o", "away.png"]);
    assert!(o.status.success());
    let err = text(&o).1;
    assert!(
        err.contains("warning: the image is empty") && err.contains("0 cells projected"),
        "{err}"
    );
}

// ---------------------------------------------------------------- item 7

#[test]
fn item7_compare_gives_a_verdict_and_a_labelled_strip() {
    let d = tempfile::tempdir().unwrap();
    let o = run_in(
        d.path(),
        &[
            "render",
            &small_b(),
            "--threads",
            "1",
            "--compare",
            "-o",
            "b.png",
            "--stats",
            "s.json",
        ],
    );
    let (out, _) = text(&o);
    assert!(o.status.success(), "{out}");
    assert!(
        out.contains("verdict: WITHIN the bound")
            && out.contains("exact integrator 2/255 + ERT 2.54/255"),
        "{out}"
    );
    assert_eq!(
        json(&d.path().join("s.json"))["compare_verdict"]["within"],
        true
    );
    let strip = image::open(d.path().join("b-compare.png"))
        .unwrap()
        .to_rgb8();
    // Three 120-pixel columns (100-pixel images, widened for the labels), a 30-pixel label band.
    assert_eq!(strip.dimensions(), (3 * 120 + 12, 130));
    for x0 in [0u32, 126, 252] {
        let ink = (x0..x0 + 100)
            .flat_map(|x| (0..14).map(move |y| (x, y)))
            .filter(|&(x, y)| strip.get_pixel(x, y).0[0] < 128)
            .count();
        assert!(ink > 40, "no label over column at {x0}: {ink} dark pixels");
    }
    // Midpoint has no bound, and says so.
    let o = run_in(
        d.path(),
        &[
            "render",
            &small_b(),
            "--integrator",
            "midpoint",
            "--compare",
            "-o",
            "m.png",
        ],
    );
    assert!(text(&o)
        .0
        .contains("no bound applies to the midpoint integrator"));
}

// ---------------------------------------------------------------- item 8

#[test]
fn item8_piped_sweeps_print_a_line_per_run_and_dry_runs_estimate() {
    let d = tempfile::tempdir().unwrap();
    let cfg = d.path().join("tiny.toml");
    std::fs::write(
        &cfg,
        format!(
            "name = \"tiny\"\ncommand = \"render\"\nscene = {:?}\n[fixed]\nthreads = 1\n[vary]\ntile = [16, 32]\n",
            small_b()
        ),
    )
    .unwrap();
    let o = run_in(d.path(), &["sweep", "tiny.toml", "--dry-run"]);
    let (out, _) = text(&o);
    assert!(o.status.success(), "{out}");
    assert!(
        out.contains("estimated duration ~") && out.contains("size model"),
        "{out}"
    );
    let o = run_in(d.path(), &["sweep", "tiny.toml"]);
    let (out, _) = text(&o);
    assert!(o.status.success(), "{out}");
    assert!(out.contains("[1/2] tile=16 rep 0: ok in "), "{out}");
    assert!(out.contains("[2/2] tile=32 rep 0: ok in "), "{out}");
    // Options are validated for every run before the first.
    std::fs::write(
        &cfg,
        format!(
            "name = \"tiny\"\ncommand = \"render\"\nscene = {:?}\n[vary]\ntile = [16, 0]\n",
            small_b()
        ),
    )
    .unwrap();
    fails_with(
        &run_in(d.path(), &["sweep", "tiny.toml", "--force"]),
        &["--tile 0: must be at least 1"],
    );
    let doc = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/sweeps.md"))
        .unwrap();
    assert!(!doc.contains("configs/fig11.toml") && !doc.contains("today `render`"));
}

// ---------------------------------------------------------------- item 9

#[test]
fn item9_scene_helper_writes_a_scene_that_renders() {
    let d = tempfile::tempdir().unwrap();
    let spx = data("spx.inp").display().to_string();
    for (name, extra) in [
        ("front", vec![]),
        (
            "persp",
            vec!["--view", "30,20", "--perspective", "35", "--size", "120x80"],
        ),
        ("top", vec!["--view", "+z"]),
    ] {
        let toml = format!("{name}.toml");
        let mut a = vec![
            "scene",
            spx.as_str(),
            "--field",
            "density",
            "-o",
            toml.as_str(),
        ];
        a.extend(extra);
        let o = run_in(d.path(), &a);
        assert!(o.status.success(), "{:?}", text(&o));
        let written = std::fs::read_to_string(d.path().join(&toml)).unwrap();
        assert!(
            written.starts_with("# Written by `pvrsim scene"),
            "{written}"
        );
        let png = format!("{name}.png");
        let o = run_in(
            d.path(),
            &["render", &toml, "-o", &png, "--stats", "s.json"],
        );
        let (_, err) = text(&o);
        assert!(o.status.success() && !err.contains("empty"), "{err}");
        let st = json(&d.path().join("s.json"));
        assert_eq!(
            st["cells_culled_offscreen"], 0,
            "{name}: the whole mesh is framed"
        );
        let img = image::open(d.path().join(&png)).unwrap().to_rgb8();
        let lit = img.pixels().filter(|p| p.0.iter().any(|&c| c > 10)).count();
        assert!(
            lit * 20 > img.pixels().len(),
            "{name}: only {lit} lit pixels"
        );
    }
    // The front view reproduces the hand-fitted tests/data/spx.toml camera.
    let t = std::fs::read_to_string(d.path().join("front.toml")).unwrap();
    assert!(
        t.contains("eye        = [7.030335, -22.740953, -3.972500]"),
        "{t}"
    );
    assert!(t.contains("height     = 10.334500"), "{t}");
    fails_with(
        &run_in(
            d.path(),
            &["scene", &spx, "--field", "density", "-o", "front.toml"],
        ),
        &["--force"],
    );
    fails_with(
        &run_in(
            d.path(),
            &["scene", &spx, "--field", "nope", "-o", "x.toml"],
        ),
        &["\"density\""],
    );
    fails_with(
        &run_in(
            d.path(),
            &[
                "scene", &spx, "--field", "density", "--view", "up", "-o", "x.toml",
            ],
        ),
        &["--view up"],
    );
}

// ---------------------------------------------------------------- item 10

#[test]
fn item10_nits() {
    let d = tempfile::tempdir().unwrap();
    let spx = data("spx.inp").display().to_string();
    let s = small_b();
    // info ends with a newline.
    let o = run_in(d.path(), &["info", &spx]);
    assert!(text(&o).0.ends_with('\n'));
    // "1 thread", not "1 threads".
    let o = run_in(d.path(), &["render", &s, "--threads", "1"]);
    let out = text(&o).0;
    assert!(
        out.contains(", 1 thread)") && !out.contains("1 threads"),
        "{out}"
    );
    // No "n/a s"; the culled cells are in the table.
    let o = run_in(d.path(), &["cluster", &s, "--nodes", "2", "--no-baselines"]);
    let out = text(&o).0;
    assert!(!out.contains("n/a s"), "{out}");
    assert!(
        out.lines()
            .any(|l| l.contains(" culled ") && l.contains("Tsc s")),
        "{out}"
    );
    // An error is printed once.
    let o = run_in(d.path(), &["render", "missing.toml"]);
    let err = text(&o).1;
    assert_eq!(err.matches("No such file").count(), 1, "{err}");
    // A vector field is rendered as its magnitude, and the user is told.
    let vtk = data("aorta-small.vtk").display().to_string();
    let o = run_in(
        d.path(),
        &[
            "scene", &vtk, "--field", "velocity", "-o", "v.toml", "--size", "60x60",
        ],
    );
    assert!(o.status.success(), "{:?}", text(&o));
    let o = run_in(d.path(), &["render", "v.toml", "-o", "v.png"]);
    assert!(text(&o)
        .1
        .contains("field \"velocity\" has 3 components: rendering its magnitude"));
    // The timeline legend lists only the kinds drawn (no "compute" in a cluster run).
    let cli = <pvrsim::cli::Cli as clap::Parser>::try_parse_from([
        "pvrsim",
        "cluster",
        &s,
        "--nodes",
        "2",
        "--no-baselines",
    ])
    .unwrap();
    let pvrsim::cli::Command::Cluster(a) = cli.command else {
        panic!("not a cluster command")
    };
    let pvrsim::job::ClusterResult::Mesh(frames) = a.run().unwrap() else {
        panic!("a mesh scene")
    };
    let out = &frames[0];
    let kinds = pvrsim::cluster::timeline::kinds_shown(&out.trace);
    assert!(kinds.contains(&pvrsim::net::TraceKind::Scan));
    assert!(
        !kinds.contains(&pvrsim::net::TraceKind::Compute),
        "{kinds:?}"
    );
}

// ------------------------------------------------ the grid renderer's default

/// Without `--renderer` a grid scene is drawn by shear-warp when the view is
/// orthographic and does not magnify the voxels, else by slice3d, and the
/// first line says which; slicer options keep slice3d.
#[test]
fn the_default_grid_renderer_follows_the_view() {
    let d = tempfile::tempdir().unwrap();
    let o = run_in(
        d.path(),
        &["generate", "hydrogen", "--size", "24", "-o", "h.nrrd"],
    );
    assert!(o.status.success(), "{}", text(&o).1);
    let first = |args: &[&str]| {
        let o = run_in(d.path(), args);
        assert!(o.status.success(), "{args:?}: {}", text(&o).1);
        let out = text(&o).0;
        out.lines().next().unwrap_or("").to_string()
    };
    // 256 px across a 24^3 grid: voxels larger than pixels.
    let l = first(&["render", "h.toml", "-o", "a.png"]);
    assert!(l.starts_with("renderer: slice3d"), "{l}");
    // 16 px across it: pixels larger than voxels.
    let small = [
        "render", "h.toml", "-o", "b.png", "--width", "16", "--height", "16",
    ];
    let l = first(&small);
    assert!(l.starts_with("renderer: shearwarp"), "{l}");
    let l = first(&[&small[..], &["--slices", "40"]].concat());
    assert!(l.starts_with("renderer: slice3d"), "{l}");
    // Named: no line about the default.
    let l = first(&[&small[..], &["--renderer", "shearwarp"]].concat());
    assert!(l.starts_with("shearwarp of"), "{l}");
}
