//! Issue 25: faults over `--transport processes` (the coordinator spawns
//! one worker child per node), for mesh frames (binary swap) and grid
//! frames (master, binary swap). In each case the child of rank 2 gets a
//! hidden hook through `pvrsim cluster --test-worker-hook 2:...`: a
//! `kill -9`, or with `--test-stop` a `SIGSTOP`, at set-up, in phase 1
//! (while rendering, for grids) or in phase 2. Heartbeat deadline 1 s.
//!
//! - `--on-failure reassign` (run in this process, the children from the
//!   `pvrsim` binary): the frame completes on the 3 survivors with the
//!   undisturbed image (bit for bit at `--canonical --ert 1` for meshes
//!   and grid frames with a master; grid binary swap over 3 within
//!   1/255), and the report names worker 2, the phase and what moved. A
//!   stopped child is continued (`SIGCONT`) as soon as a peer has closed
//!   a connection to it (a peer gave it up; the coordinator may not have
//!   decided yet, or the retry may run without it), and is gone (killed
//!   and reaped) when the frame returns; for meshes the SIGCONT must
//!   reach a child during its frame at least once.
//! - `--on-failure abort` (`pvrsim cluster` as a child): a non-zero exit
//!   within the deadline + 2 s of the fault (the hook's own stderr line),
//!   the coordinator's error naming worker 2 and the phase, no panic, no
//!   image written, and none of its children left (a stopped one
//!   included).
//!
//! The processes transport has no pool that outlives a command: each
//! frame spawns its own children, so "the next frame on the same pool"
//! is, here, that nothing of the failed command remains.

use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::Duration;

mod transport_support;
use transport_support::*;

/// The heartbeat deadline, as given to `pvrsim cluster`.
const HB_ARG: &str = "1";

/// Worker 2's fault: the hook of its child; `stop`: `--test-stop` (the
/// hook stops the child instead of killing it).
#[derive(Debug, Clone, Copy)]
struct Fault {
    hook: &'static str,
    stop: bool,
}

impl Fault {
    /// The value of `--test-worker-hook`.
    fn arg(self) -> String {
        let stop = if self.stop { "--test-stop " } else { "" };
        format!("2:{stop}{}", self.hook)
    }
}

/// Each hook with its phase, killed and stopped.
fn cases(hooks: &[(&'static str, &'static str)]) -> Vec<(Fault, &'static str)> {
    hooks
        .iter()
        .flat_map(|&(hook, phase)| [false, true].map(|stop| (Fault { hook, stop }, phase)))
        .collect()
}

/// The arguments of a frame over processes: `common`, the deadline,
/// `--on-failure`, and the fault's hook.
fn args(common: &[&str], on_failure: &str, fault: Option<Fault>) -> Vec<String> {
    let mut v: Vec<String> = common.iter().map(|s| s.to_string()).collect();
    v.extend(
        [
            "--transport",
            "processes",
            "--heartbeat-timeout",
            HB_ARG,
            "--on-failure",
            on_failure,
        ]
        .map(String::from),
    );
    if let Some(f) = fault {
        v.push("--test-worker-hook".into());
        v.push(f.arg());
    }
    v
}

fn strs(v: &[String]) -> Vec<&str> {
    v.iter().map(String::as_str).collect()
}

/// Serialises the stop cases: [`Continuer`] finds the stopped child among
/// this process's children (the tests run in parallel).
static STOPS: Mutex<()> = Mutex::new(());

/// For a stop case: a thread that waits for the child stopped by the
/// hook, leaves it stopped until a peer has closed a connection to it
/// (the coordinator or a survivor gave it up: it was declared lost), then
/// continues it, while the retry runs if the frame is still running: the
/// child comes back to a frame that has moved on.
struct Continuer {
    done: Arc<AtomicBool>,
    thread: JoinHandle<Option<(u32, bool)>>,
}

impl Continuer {
    fn start() -> Continuer {
        let done = Arc::new(AtomicBool::new(false));
        let d = Arc::clone(&done);
        let thread = std::thread::spawn(move || {
            let pid = stopped_child(std::process::id(), "--test-stop", &d)?;
            while !peer_closed_on(pid) && !d.load(Ordering::SeqCst) {
                std::thread::sleep(Duration::from_millis(1));
            }
            // SAFETY: kill has no preconditions; `pid` is this process's
            // child (not yet reaped: the frame still holds it, or it is
            // gone and kill fails).
            let landed = unsafe { libc::kill(pid as libc::pid_t, libc::SIGCONT) } == 0;
            Some((pid, landed))
        });
        Continuer { done, thread }
    }

    /// After the frame: checks that the stopped child is gone; whether the
    /// SIGCONT reached it while the frame ran (else the frame was over and
    /// the child killed first).
    fn finish(self, case: &str) -> bool {
        self.done.store(true, Ordering::SeqCst);
        let seen = self.thread.join().unwrap();
        let (pid, landed) = seen.unwrap_or_else(|| panic!("{case}: no child was seen stopped"));
        assert!(
            stat(pid).is_none_or(|(st, _)| st == 'Z'),
            "{case}: the stopped child {pid} outlived the frame: {:?}",
            stat(pid)
        );
        landed
    }
}

/// An abort case through the CLI: a non-zero exit within the deadline +
/// 2 s of the fault, the coordinator's error (its last `error:` line and
/// what follows) naming `who` and `phase`, no panic, no image, no child
/// left.
fn abort_case(case: &str, scene: &Path, common: &[&str], fault: Fault, who: &str, phase: &str) {
    let dir = tempfile::tempdir().unwrap();
    let png = dir.path().join("out.png");
    let mut a = vec![scene.to_str().unwrap().to_string()];
    a.extend(args(common, "abort", Some(fault)));
    a.extend(["-o".to_string(), png.to_str().unwrap().to_string()]);
    let run = cluster_cli_watched(&strs(&a), Duration::from_secs(30));
    let all = run.stderr();
    assert!(!run.ok, "{case}: exit 0\n{all}");
    assert!(!all.contains("panicked"), "{case}: a panic\n{all}");
    let at = run
        .line_at("itself")
        .unwrap_or_else(|| panic!("{case}: the hook did not fire\n{all}"));
    let took = run.end.saturating_sub(at);
    assert!(
        took < HB + Duration::from_secs(2),
        "{case}: failed {took:?} after the fault\n{all}"
    );
    let from = all.rfind("\nerror: ").map_or(0, |i| i + 1);
    let err = &all[from..];
    assert!(err.contains(who), "{case}: names no {who}: {err}");
    assert!(err.contains(phase), "{case}: names no phase {phase}: {err}");
    assert!(!png.exists(), "{case}: an image was written");
    // (The children seen are a sample: a frame that fails at once may end
    // between two polls. The token-folder scan finds any child left.)
    let left = run.children_left(Duration::from_millis(500));
    assert!(left.is_empty(), "{case}: children left behind: {left:?}");
}

/// A reassign case in this process: the frame's result; with a stop,
/// the child continued after its loss and gone afterwards (`continued`
/// counts the SIGCONTs that reached it while the frame ran).
fn reassign_case<T>(
    case: &str,
    fault: Fault,
    continued: &mut usize,
    run: impl FnOnce() -> anyhow::Result<T>,
) -> T {
    let _serial = fault
        .stop
        .then(|| STOPS.lock().unwrap_or_else(|e| e.into_inner()));
    let cont = fault.stop.then(Continuer::start);
    let r = run();
    if let Some(c) = cont {
        *continued += usize::from(c.finish(case));
    }
    r.unwrap_or_else(|e| panic!("{case}: {e:#}"))
}

/// Some SIGCONT must have reached a stopped child during its frame (or
/// the continuing was not tested).
fn check_continued(what: &str, continued: usize) {
    assert!(
        continued > 0,
        "{what}: every stopped child was continued only after its frame had ended"
    );
}

fn program() -> pvrsim::cluster::remote::spawn::WorkerProgram {
    pvrsim::cluster::remote::spawn::WorkerProgram::exe(Path::new(EXE))
}

#[test]
fn mesh_frames_over_processes_survive_every_fault_at_every_phase() {
    let scene = data("aorta-small-view-b.toml");
    let common = ["--nodes", "4", "--canonical", "--ert", "1"];
    let frame = |on_failure: &str, fault: Option<Fault>| {
        let a = args(&common, on_failure, fault);
        let (input, cfg) = config(&scene, &strs(&a));
        let net = cluster_args(&scene, &strs(&a)).net;
        pvrsim::job::nodes::run_processes(&net, &program(), &input, &cfg)
    };
    let reference = bits(&frame("abort", None).unwrap().0.image);
    let hooks = [
        ("--test-kill-at-setup", "set-up"),
        ("--test-kill-after-chunks 2", "phase 1"),
        ("--test-kill-in-phase2", "phase 2"),
    ];
    let mut continued = 0;
    for (fault, phase) in cases(&hooks) {
        let case = format!("mesh, {fault:?}, reassign");
        let (out, m) = reassign_case(&case, fault, &mut continued, || {
            frame("reassign", Some(fault))
        });
        assert_eq!(bits(&out.image), reference, "{case}: not the same image");
        let re = m.reassigned.expect("a reassignment in the report");
        assert_one_loss(&case, &re, phase, "worker 2 ");
        assert_eq!(out.report.n_nodes, 3, "{case}");

        let mut cli = vec!["--no-baselines"];
        cli.extend(common);
        let case = format!("mesh, {fault:?}, abort");
        abort_case(&case, &scene, &cli, fault, "worker 2", phase);
    }
    check_continued("mesh", continued);
}

/// Grid frames, 4 children, 8 bricks: with a master (the layers go to the
/// coordinator) and worker to worker (binary swap).
#[test]
fn grid_frames_over_processes_survive_every_fault_at_every_phase() {
    let dir = tempfile::tempdir().unwrap();
    let scene = grid_scene(dir.path(), (48, 40));
    let mut continued = 0;
    for comp in ["--master", "--compositor=binary-swap"] {
        let common = ["--nodes", "4", "--subvolumes", "2", "--ert", "1", comp];
        let frame = |on_failure: &str, fault: Option<Fault>| {
            let a = args(&common, on_failure, fault);
            let (input, cfg) = grid_config(&scene, &strs(&a));
            let net = cluster_args(&scene, &strs(&a)).net;
            let cams = [input.scene.camera];
            pvrsim::cli::cluster_grid::run_processes(&net, &program(), &input, &cfg, &cams)
                .map(|mut v| v.pop().expect("one frame"))
        };
        let reference = frame("abort", None).unwrap().image;
        let mut hooks = vec![
            ("--test-kill-at-setup", "set-up"),
            ("--test-kill-after-chunks 0", "rendering"),
        ];
        if comp != "--master" {
            hooks.push(("--test-kill-in-phase2", "phase 2"));
        }
        for (fault, phase) in cases(&hooks) {
            let case = format!("grid {comp}, {fault:?}, reassign");
            let out = reassign_case(&case, fault, &mut continued, || {
                frame("reassign", Some(fault))
            });
            if comp == "--master" {
                assert_eq!(bits(&out.image), bits(&reference), "{case}");
            } else {
                let d = out.image.error_against_rgba(&reference).max_abs;
                assert!(d <= 1.0, "{case}: {d}/255 from the undisturbed image");
            }
            let re = out.report.transport.unwrap().reassigned;
            let re = re.unwrap_or_else(|| panic!("{case}: no reassignment in the report"));
            let ev = assert_one_loss(&case, &re, phase, "grid worker 2 ");
            assert_eq!(ev.moved, 2, "{case}: {ev:?}");

            let case = format!("grid {comp}, {fault:?}, abort");
            abort_case(&case, &scene, &common, fault, "grid worker 2", phase);
        }
    }
    // Not required here: the tiny grid retries are often over before the
    // SIGCONT (the grid cases still check the frame and that the stopped
    // child is gone).
    eprintln!("grid: {continued} SIGCONT(s) reached a stopped child during its frame");
}
