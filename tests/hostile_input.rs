//! Issue 26, files and options: each hostile input of the issue is replayed
//! and must end with exit code 1 within a few seconds, no panic or abort,
//! and a message naming the file, key, option or worker. (The worker's
//! network cases are in tests/hostile_network.rs.)

use std::io::Read;
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

mod cli_support;
use cli_support::*;

/// Runs `pvrsim ARGS` in `dir`, killing it after `limit`; asserts it ends
/// within the limit with exit code 1, no panic, no allocation abort, and a
/// stderr holding every `needle`. Returns stderr.
fn refused_within(dir: &Path, args: &[&str], limit: Duration, needles: &[&str]) -> String {
    let t = Instant::now();
    let mut child = Command::new(EXE)
        .args(args)
        .current_dir(dir)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut err = child.stderr.take().unwrap();
    let reader = std::thread::spawn(move || {
        let mut s = String::new();
        let _ = err.read_to_string(&mut s);
        s
    });
    let status = loop {
        if let Some(st) = child.try_wait().unwrap() {
            break st;
        }
        if t.elapsed() > limit {
            let _ = child.kill();
            let _ = child.wait();
            panic!("pvrsim {args:?} still running after {limit:?}");
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    let err = reader.join().unwrap();
    assert_eq!(status.code(), Some(1), "pvrsim {args:?}: {status:?}\n{err}");
    assert!(!err.contains("panicked"), "{err}");
    assert!(!err.contains("memory allocation"), "{err}");
    for n in needles {
        assert!(err.contains(n), "`{n}` not in stderr of {args:?}: {err}");
    }
    err
}

const FEW: Duration = Duration::from_secs(10);

fn nhdr(dir: &Path, name: &str, data_file: &str) -> String {
    let p = dir.join(name);
    std::fs::write(
        &p,
        format!(
            "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 4 4 4\nencoding: raw\ndata file: {data_file}\n"
        ),
    )
    .unwrap();
    p.display().to_string()
}

#[test]
fn nrrd_data_file_dev_zero_is_refused_at_once() {
    let d = tempfile::tempdir().unwrap();
    let h = nhdr(d.path(), "zero.nhdr", "/dev/zero");
    refused_within(d.path(), &["info", &h], FEW, &["zero.nhdr", "data file"]);
    // Through a symbolic link inside the folder: not a regular file.
    #[cfg(unix)]
    {
        std::os::unix::fs::symlink("/dev/zero", d.path().join("z.raw")).unwrap();
        let h = nhdr(d.path(), "link.nhdr", "z.raw");
        refused_within(
            d.path(),
            &["info", &h],
            FEW,
            &["link.nhdr", "character device"],
        );
    }
}

#[test]
fn nrrd_data_file_outside_the_folder_is_refused_before_reading() {
    let d = tempfile::tempdir().unwrap();
    let h = nhdr(d.path(), "up.nhdr", "../../../../etc/passwd");
    refused_within(
        d.path(),
        &["info", &h],
        FEW,
        &["up.nhdr", "data file", "outside the header's folder"],
    );
}

#[test]
fn nrrd_data_file_larger_than_the_header_allows_is_refused() {
    let d = tempfile::tempdir().unwrap();
    let f = std::fs::File::create(d.path().join("big.raw")).unwrap();
    f.set_len(64 << 20).unwrap(); // sparse: 64 MiB for a 4x4x4 header
    let h = nhdr(d.path(), "big.nhdr", "big.raw");
    refused_within(d.path(), &["info", &h], FEW, &["big.nhdr", "more than the"]);
}

#[test]
fn a_directory_or_fifo_as_the_scene_data_is_refused() {
    let d = tempfile::tempdir().unwrap();
    std::fs::create_dir(d.path().join("dir.nrrd")).unwrap();
    refused_within(d.path(), &["info", "dir.nrrd"], FEW, &["dir.nrrd"]);
    #[cfg(unix)]
    {
        let fifo = d.path().join("fifo.nrrd");
        let ok = Command::new("mkfifo")
            .arg(&fifo)
            .status()
            .unwrap()
            .success();
        assert!(ok);
        refused_within(
            d.path(),
            &["info", "fifo.nrrd"],
            FEW,
            &["fifo.nrrd", "FIFO"],
        );
    }
}

/// A small grid scene (hydrogen 16³) in `dir`: its .toml path.
fn grid_scene(dir: &Path) -> String {
    let o = run_in(
        dir,
        &["generate", "hydrogen", "--size", "16", "-o", "h.nrrd"],
    );
    assert!(o.status.success(), "{:?}", text(&o));
    dir.join("h.toml").display().to_string()
}

#[test]
fn huge_generated_volumes_are_refused_up_front() {
    let d = tempfile::tempdir().unwrap();
    let p = d.path();
    refused_within(
        p,
        &["generate", "hydrogen", "--size", "100000", "-o", "h.nrrd"],
        FEW,
        &["--size 100000x100000x100000", "16384"],
    );
    refused_within(
        p,
        &[
            "generate",
            "marschner-lobb",
            "--size",
            "100000x100000x100000",
            "-o",
            "m.nrrd",
        ],
        FEW,
        &["--size"],
    );
    // Below the side limit, the memory estimate and MemAvailable decide.
    let e = refused_within(
        p,
        &["generate", "hydrogen", "--size", "16000", "-o", "h.nrrd"],
        FEW,
        &["--size", "of memory", "available"],
    );
    assert!(e.contains("TiB") || e.contains("GiB"), "{e}");
    assert!(!p.join("h.nrrd").exists());
}

#[test]
fn huge_splat_options_are_refused_up_front() {
    let d = tempfile::tempdir().unwrap();
    let s = grid_scene(d.path());
    let p = d.path();
    refused_within(p, &["splat", &s, "--sigma", "1000"], FEW, &["--sigma 1000"]);
    refused_within(
        p,
        &["splat", &s, "--width", "65536", "--height", "65536"],
        FEW,
        &["--width/--height", "65536x65536", "32768"],
    );
    refused_within(
        p,
        &["splat", &s, "--threads", "100000"],
        FEW,
        &["--threads 100000"],
    );
}

#[test]
fn huge_render_options_are_refused_up_front() {
    let d = tempfile::tempdir().unwrap();
    let s = grid_scene(d.path());
    let p = d.path();
    refused_within(
        p,
        &["render", &s, "--threads", "100000"],
        FEW,
        &["--threads 100000"],
    );
    refused_within(
        p,
        &["render", &s, "--slices", "100000000"],
        FEW,
        &["--slices 100000000", "65536"],
    );
    refused_within(
        p,
        &[
            "render",
            &small_b(),
            "--width",
            "65536",
            "--height",
            "65536",
        ],
        FEW,
        &["65536"],
    );
}

#[test]
fn huge_cluster_options_are_refused_up_front() {
    let d = tempfile::tempdir().unwrap();
    let p = d.path();
    let b = small_b();
    for how in [
        &["--clock", "wall"][..],
        &["--transport", "threads"],
        &["--transport", "processes"],
    ] {
        let mut args = vec!["cluster", &b, "--nodes", "5000"];
        args.extend_from_slice(how);
        let e = refused_within(p, &args, FEW, &["--nodes 5000", "at most", how[1]]);
        assert!(e.contains("simulated clock"), "{e}");
    }
    refused_within(
        p,
        &["cluster", &b, "--width", "65536", "--height", "65536"],
        FEW,
        &["65536"],
    );
    // The simulated clock runs every node on one thread: its budget is memory.
    refused_within(
        p,
        &["cluster", &b, "--nodes", "100000000"],
        FEW,
        &["100000000 nodes"],
    );
}

#[test]
fn a_sweep_with_one_huge_point_is_refused_before_its_first_run() {
    let d = tempfile::tempdir().unwrap();
    let p = d.path();
    let cfg = p.join("sweep.toml");
    std::fs::write(
        &cfg,
        format!(
            "name = \"huge\"\ncommand = \"cluster\"\nscene = {:?}\n[fixed]\nclock = \"wall\"\n\
             width = 20\nheight = 20\n[vary]\nnodes = [2, 5000]\n",
            small_b()
        ),
    )
    .unwrap();
    let out = p.join("out");
    refused_within(
        p,
        &[
            "sweep",
            cfg.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ],
        FEW,
        &["--nodes 5000", "at most"],
    );
    assert!(
        !out.join("huge").join("results.csv").exists(),
        "no point ran: the refusal came before the first"
    );
}

#[test]
fn negative_ert_gets_the_range_message() {
    let d = tempfile::tempdir().unwrap();
    for cmd in ["render", "cluster"] {
        let e = refused_within(d.path(), &[cmd, &small_b(), "--ert", "-1"], FEW, &["--ert"]);
        assert!(!e.contains("unexpected argument"), "{e}");
    }
}

/// The bundled small scene with `from` replaced by `to`, the data path made
/// absolute.
fn edited_scene(dir: &Path, from: &str, to: &str) -> String {
    let text = std::fs::read_to_string(data("aorta-small-view-b.toml")).unwrap();
    assert!(text.contains(from), "{from}");
    let text = text.replace(from, to).replace(
        "path  = \"aorta-small.vtk\"",
        &format!(
            "path  = {:?}",
            data("aorta-small.vtk").display().to_string()
        ),
    );
    let p = dir.join("edited.toml");
    std::fs::write(&p, text).unwrap();
    p.display().to_string()
}

#[test]
fn scene_arrays_of_the_wrong_length_are_errors_naming_the_key() {
    let d = tempfile::tempdir().unwrap();
    let p = d.path();
    let cases = [
        (
            "background = [0, 0, 0]",
            "background = [0, 0, 1, 7, 9]",
            "image.background",
        ),
        (
            "background = [0, 0, 0]",
            "background = [0, 0]",
            "image.background",
        ),
        (
            "eye        = [-2.5, 0, 232.7]",
            "eye        = [-2.5, 0, 232.7, 99]",
            "camera.eye",
        ),
        (
            "up         = [0, 1, 0]",
            "up         = [0, 1, 0, 0]",
            "camera.up",
        ),
        (
            "target     = [-2.5, 0, 0]",
            "target     = [-2.5, 0]",
            "camera.target",
        ),
    ];
    for (from, to, key) in cases {
        let s = edited_scene(p, from, to);
        refused_within(
            p,
            &["render", &s, "-o", "x.png"],
            FEW,
            &["edited.toml", key, "exactly 3"],
        );
    }
    assert!(!p.join("x.png").exists());
}

#[test]
fn generate_does_not_overwrite_without_force() {
    let d = tempfile::tempdir().unwrap();
    let p = d.path();
    std::fs::write(p.join("keep.nrrd"), "precious").unwrap();
    refused_within(
        p,
        &["generate", "hydrogen", "--size", "8", "-o", "keep.nrrd"],
        FEW,
        &["keep.nrrd", "--force"],
    );
    assert_eq!(
        std::fs::read_to_string(p.join("keep.nrrd")).unwrap(),
        "precious"
    );
    // Its scene too.
    std::fs::write(p.join("other.toml"), "precious").unwrap();
    refused_within(
        p,
        &["generate", "hydrogen", "--size", "8", "-o", "other.nrrd"],
        FEW,
        &["other.toml", "--force"],
    );
    assert!(!p.join("other.nrrd").exists());
    let o = run_in(
        p,
        &[
            "generate",
            "hydrogen",
            "--size",
            "8",
            "-o",
            "keep.nrrd",
            "--force",
        ],
    );
    assert!(o.status.success(), "{:?}", text(&o));
}

#[test]
fn sweep_plot_naming_a_missing_column_is_an_error() {
    let d = tempfile::tempdir().unwrap();
    let p = d.path();
    let cfg = p.join("sweep.toml");
    std::fs::write(
        &cfg,
        format!(
            "name = \"tiny\"\nscene = {:?}\n[fixed]\nthreads = 1\nwidth = 20\nheight = 20\n\
             [vary]\ntile = [16]\n[[plot]]\nx = \"tile\"\ny = \"time_scna_s\"\n",
            small_b()
        ),
    )
    .unwrap();
    refused_within(
        p,
        &[
            "sweep",
            cfg.to_str().unwrap(),
            "--out",
            p.join("out").to_str().unwrap(),
        ],
        Duration::from_secs(60),
        &["sweep.toml", "time_scna_s"],
    );
}

#[test]
fn vti_cut_inside_its_data_array_says_truncated() {
    let d = tempfile::tempdir().unwrap();
    let full = std::fs::read(data("volume/mni-crop.vti")).unwrap();
    let at = full.windows(10).position(|w| w == b"<DataArray").unwrap();
    std::fs::write(d.path().join("cut.vti"), &full[..at + 400]).unwrap();
    let e = refused_within(
        d.path(),
        &["info", "cut.vti"],
        FEW,
        &["cut.vti", "truncated"],
    );
    assert!(!e.contains("the file has none"), "{e}");
}
