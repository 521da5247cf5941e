//! A careful user's second pass (issue 55), one case each: outputs into
//! folders that do not exist, hints that name only written files, options
//! without effect, sweeps of generated data, summary lines true to the run,
//! orbits that crop, one overwrite policy. Every case runs the binary in a
//! temporary directory on bundled or generated data.

mod cli_support;

use std::path::Path;

use cli_support::*;

/// Runs `args` in `dir` and checks it succeeded; (stdout, stderr).
fn ok(dir: &Path, args: &[&str]) -> (String, String) {
    let o = run_in(dir, args);
    let (out, err) = text(&o);
    assert!(
        o.status.success(),
        "pvrsim {}: {:?}\nstdout: {out}\nstderr: {err}",
        args.join(" "),
        o.status
    );
    assert!(!err.contains("panicked"), "{err}");
    (out, err)
}

/// A hydrogen grid (16^3) and its scene in `dir/NAME.nrrd`, `NAME.toml`.
fn hydrogen(dir: &Path, name: &str) {
    ok(
        dir,
        &[
            "generate",
            "hydrogen",
            "--size",
            "16",
            "-o",
            &format!("{name}.nrrd"),
        ],
    );
}

// ------------------------------------------------ outputs into new folders

#[test]
fn every_command_that_writes_creates_one_missing_folder_and_says_so() {
    let d = tempfile::tempdir().unwrap();
    let p = d.path();
    let s = small_b();
    let mesh = data("aorta-small.vtk").display().to_string();
    // (args, the file it writes, the folder it creates)
    let cases: Vec<(Vec<&str>, &str, &str)> = vec![
        (
            vec![
                "generate",
                "mesh-field",
                "--input",
                &s,
                "--size",
                "12",
                "-o",
                "nd7/ab.nrrd",
            ],
            "nd7/ab.nrrd",
            "nd7",
        ),
        (
            vec!["generate", "hydrogen", "--size", "8", "-o", "nd8/h.nrrd"],
            "nd8/h.toml",
            "nd8",
        ),
        (
            vec!["partition", &mesh, "--pieces", "4", "-o", "nd9/m.pvtu"],
            "nd9/m_3.vtu",
            "nd9",
        ),
        (
            vec!["scene", &mesh, "--field", "speed", "-o", "nd10/s.toml"],
            "nd10/s.toml",
            "nd10",
        ),
        (
            vec!["render", &s, "-o", "nd11/x.png", "--stats", "nd12/s.json"],
            "nd12/s.json",
            "nd12",
        ),
    ];
    for (args, file, dir) in &cases {
        let (_, err) = ok(p, args);
        assert!(
            err.contains(&format!("note: created directory {dir}")),
            "{args:?}: {err}"
        );
        assert!(p.join(file).exists(), "{args:?}: no {file}");
    }
    // issue 53: `partition -o new/dir/m.pvtu` makes new/dir (new exists).
    std::fs::create_dir(p.join("new")).unwrap();
    let (_, err) = ok(
        p,
        &["partition", &mesh, "--pieces", "8", "-o", "new/dir/m.pvtu"],
    );
    assert!(err.contains("note: created directory new/dir"), "{err}");
    assert!(p.join("new/dir/m_7.vtu").exists());
    // Two missing levels: "cannot write", never an error that reads like a
    // missing input, and nothing created.
    for args in [
        vec!["generate", "hydrogen", "--size", "8", "-o", "a1/b/h.nrrd"],
        vec!["partition", &mesh, "--pieces", "2", "-o", "a2/b/m.pvtu"],
    ] {
        let o = run_in(p, &args);
        fails_with(&o, &["cannot write", "at most one missing level"]);
        assert!(!text(&o).1.contains("No such file"), "{}", text(&o).1);
    }
    assert!(!p.join("a1").exists() && !p.join("a2").exists());
}

// ------------------------------------------------ hints name written files

#[test]
fn demo_hints_name_only_files_it_wrote() {
    let d = tempfile::tempdir().unwrap();
    let p = d.path();
    for (nodes, dir) in [("0", "big"), ("2", "small")] {
        let (out, _) = ok(
            p,
            &[
                "demo",
                "--cells",
                "3000",
                "--nodes",
                nodes,
                "--pieces",
                "4",
                "--out-dir",
                dir,
            ],
        );
        let mut named = 0;
        for line in out.lines().filter(|l| l.contains("pvrsim ")) {
            for w in line.split_whitespace().filter(|w| w.ends_with(".toml")) {
                named += 1;
                assert!(p.join(w).exists(), "`{line}` names {w}, not written");
            }
        }
        assert!(named >= 2, "{out}");
    }
}

// ------------------------------------------------ no option without effect

#[test]
fn options_without_their_setting_are_warned_about_or_refused() {
    let d = tempfile::tempdir().unwrap();
    let s = small_b();
    let base = [
        "cluster",
        &s,
        "--nodes",
        "2",
        "--no-baselines",
        "-o",
        "c.png",
    ];
    // (extra args, a warning expected in stderr or None for "no warning")
    let cases: &[(&[&str], Option<&str>)] = &[
        // The README's example with the default (pyramid) structure.
        (
            &[
                "--ert",
                "0.9",
                "--share",
                "--dlb",
                "--share-levels",
                "4",
                "--share-sub",
                "3",
            ],
            Some("warning: --share-sub 3 has no effect"),
        ),
        (
            &[
                "--ert",
                "0.9",
                "--share",
                "--dlb",
                "--ert-structure",
                "flat",
                "--share-levels",
                "4",
                "--share-sub",
                "3",
            ],
            None,
        ),
        (
            &["--paper", "--ert", "0.9", "--share", "--share-levels", "4"],
            Some("warning: --share-levels/--share-sub has no effect: --paper"),
        ),
        (
            &["--coherence", "placement"],
            Some("warning: --coherence has no effect"),
        ),
    ];
    for (extra, warning) in cases {
        let mut args = base.to_vec();
        args.extend_from_slice(extra);
        let (_, err) = ok(d.path(), &args);
        match warning {
            Some(w) => assert!(err.contains(w), "{extra:?}: {err}"),
            None => assert!(!err.contains("warning:"), "{extra:?}: {err}"),
        }
    }
    // Refused: transport options without their transport, worker counts.
    let o = run_in(
        d.path(),
        &["cluster", &s, "--nodes", "2", "--workers", "a:1,b:2"],
    );
    fails_with(
        &o,
        &["--workers/--hostfile/--token-file needs --transport tcp"],
    );
    let o = run_in(
        d.path(),
        &[
            "cluster",
            &s,
            "--nodes",
            "3",
            "--transport",
            "tcp",
            "--workers",
            "127.0.0.1:9,127.0.0.1:10",
        ],
    );
    fails_with(&o, &["--nodes 3 needs 3 workers; --workers lists 2"]);
    assert!(!text(&o).1.contains("frame 0"), "{}", text(&o).1);
}

// ------------------------------------------------ sweeps of generated data

#[test]
fn sweeps_make_their_generated_data_once_and_dry_runs_say_what_they_would_make() {
    let d = tempfile::tempdir().unwrap();
    let p = d.path();
    std::fs::create_dir(p.join("configs")).unwrap();
    let config = r#"
name = "made"
command = "render"
requires = ["../data/h.nrrd"]
scene = "../data/h.toml"

[[make]]
files = ["../data/h.nrrd", "../data/h.toml"]
run = "generate hydrogen --size 16 -o ../data/h.nrrd"

[fixed]
threads = 1

[vary]
width = [16, 24]
height = [16]
"#;
    std::fs::write(p.join("configs/made.toml"), config).unwrap();
    // A dry run makes nothing and lists the command.
    let (out, _) = ok(p, &["sweep", "configs/made.toml", "--dry-run"]);
    assert!(out.contains("make  pvrsim generate hydrogen"), "{out}");
    assert!(out.contains("estimated duration unknown"), "{out}");
    assert!(!p.join("data").exists());
    // The run makes it, with progress, then renders.
    let (_, err) = ok(p, &["sweep", "configs/made.toml", "--out", "res"]);
    assert!(err.contains("making generated data (1 of 1"), "{err}");
    assert!(p.join("data/h.nrrd").exists() && p.join("res/made/results.csv").exists());
    // Cached: a second sweep finds it.
    let (_, err) = ok(
        p,
        &["sweep", "configs/made.toml", "--out", "res", "--force"],
    );
    assert!(!err.contains("making generated data"), "{err}");
    // Now the grid scene is readable: the dry run estimates it by the model.
    let (out, _) = ok(
        p,
        &["sweep", "configs/made.toml", "--out", "res2", "--dry-run"],
    );
    assert!(out.contains("2 from a size model"), "{out}");
    // A missing file nothing makes: the error names it and how to make the rest.
    std::fs::write(
        p.join("configs/half.toml"),
        config
            .replace(
                r#"requires = ["../data/h.nrrd"]"#,
                r#"requires = ["../data/h.nrrd", "../data/other.nrrd"]"#,
            )
            .replace("../data/h", "../data2/h"),
    )
    .unwrap();
    let o = run_in(p, &["sweep", "configs/half.toml"]);
    fails_with(
        &o,
        &[
            "required file(s) not found",
            "other.nrrd",
            "pvrsim generate hydrogen --size 16",
        ],
    );
    // The shipped grid tables say how (and the dry run lists it).
    let cfg = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("configs/table2-grid.toml"),
    )
    .unwrap();
    std::fs::write(p.join("configs/t2.toml"), cfg).unwrap();
    let (out, _) = ok(p, &["sweep", "configs/t2.toml", "--dry-run"]);
    assert!(out.contains("make  pvrsim generate paper-engine"), "{out}");
}

// ------------------------------------------------ summaries true to the run

#[test]
fn summary_lines_are_true_to_the_run() {
    let d = tempfile::tempdir().unwrap();
    let p = d.path();
    let s = small_b();
    let (out, _) = ok(
        p,
        &[
            "cluster", &s, "--nodes", "2", "--clock", "wall", "-o", "w.png",
        ],
    );
    let line = out
        .lines()
        .find(|l| l.starts_with("data: replicated"))
        .unwrap();
    assert!(!line.contains("n/a"), "{line}");
    assert!(
        line.contains("by the network model; the wall clock does not time it"),
        "{line}"
    );
    // A grid cluster on the wall clock names no network model and no "Wall".
    hydrogen(p, "h");
    let (out, _) = ok(
        p,
        &[
            "cluster", "h.toml", "--nodes", "2", "--clock", "wall", "-o", "g.png",
        ],
    );
    assert!(
        out.contains("wall clock (times measured on this host)"),
        "{out}"
    );
    assert!(!out.contains("Wall") && !out.contains("gbe"), "{out}");
    let (out, _) = ok(p, &["cluster", "h.toml", "--nodes", "2", "-o", "g.png"]);
    assert!(out.contains("gbe network model, virtual clock"), "{out}");
    // bench's missing data: where the default path resolves.
    let o = run_in(p, &["bench", "--data-dir", "nothing-here"]);
    let shown = p.join("nothing-here");
    fails_with(
        &o,
        &[
            &format!("(= {})", shown.display()),
            "relative to the current folder",
        ],
    );
}

// ------------------------------------------------ orbits that crop

#[test]
fn an_orbit_that_crops_says_so_and_fit_orbit_holds_the_data() {
    let d = tempfile::tempdir().unwrap();
    let p = d.path();
    // Aorta view B: orthographic, fitted to the long vessel seen from one side.
    let base = [
        "cluster",
        &small_b(),
        "--nodes",
        "2",
        "--no-baselines",
        "--frames",
        "4",
        "--turn",
        "90",
        "-o",
        "o.png",
    ];
    let (_, err) = ok(p, &base);
    assert!(
        err.contains("warning: the orbit crops the data in"),
        "{err}"
    );
    assert!(err.contains("--fit-orbit"), "{err}");
    let mut fit = base.to_vec();
    fit.push("--fit-orbit");
    let (_, err) = ok(p, &fit);
    assert!(!err.contains("crops"), "{err}");
    assert!(
        err.contains("note: --fit-orbit: orthographic height"),
        "{err}"
    );
    // No turn, no crop: nothing said.
    let (_, err) = ok(
        p,
        &[
            "cluster",
            &small_b(),
            "--nodes",
            "2",
            "--no-baselines",
            "--frames",
            "2",
            "-o",
            "o.png",
        ],
    );
    assert!(!err.contains("crops"), "{err}");
    // --fit-orbit is for orbits.
    let o = run_in(p, &["cluster", &small_b(), "--fit-orbit"]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o).1);
}

// ------------------------------------------------ one overwrite policy

#[test]
fn results_are_replaced_with_a_note_inputs_need_force() {
    let d = tempfile::tempdir().unwrap();
    let p = d.path();
    let s = small_b();
    let mesh = data("aorta-small.vtk").display().to_string();
    ok(p, &["render", &s, "--width", "20", "--height", "20"]);
    let (_, err) = ok(p, &["render", &s, "--width", "20", "--height", "20"]);
    assert!(err.contains("note: replacing out.png (-o)"), "{err}");
    // Inputs of other runs: refused without --force, replaced with it.
    let inputs: [&[&str]; 3] = [
        &["scene", &mesh, "--field", "speed", "-o", "s.toml"],
        &["generate", "hydrogen", "--size", "8", "-o", "h.nrrd"],
        &["partition", &mesh, "--pieces", "2", "-o", "m.pvtu"],
    ];
    for args in inputs {
        ok(p, args);
        fails_with(&run_in(p, args), &["--force"]);
        let mut forced = args.to_vec();
        forced.push("--force");
        let (_, err) = ok(p, &forced);
        assert!(err.contains("note: replacing"), "{args:?}: {err}");
    }
}
