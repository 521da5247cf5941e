//! The stall watchdog (`pvrsim::net::stall`) sees this process stopped
//! with SIGSTOP. Its own test binary: the stop halts every thread of the
//! process, which other tests' deadlines must not share.

use std::time::{Duration, Instant};

use pvrsim::net::stall::{longest_since, watch, RECORD, TICK};

#[test]
fn a_stop_of_the_process_is_seen_and_nothing_before_it() {
    watch();
    let t0 = Instant::now();
    std::thread::sleep(TICK * 4);
    let quiet = longest_since(t0);
    assert!(quiet < RECORD, "a stall of {quiet:?} before any stop");
    // SIGSTOP to ourselves, SIGCONT from a child after 600 ms.
    let pid = std::process::id().to_string();
    let mut cont = std::process::Command::new("sh")
        .args(["-c", &format!("sleep 0.6; kill -CONT {pid}")])
        .spawn()
        .unwrap();
    let t1 = Instant::now();
    // SAFETY: kill with our own pid has no preconditions; the child above
    // continues us.
    unsafe {
        libc::kill(libc::getpid(), libc::SIGSTOP);
    }
    cont.wait().unwrap();
    // The watchdog records at its first wake-up after SIGCONT.
    std::thread::sleep(TICK * 4);
    let seen = longest_since(t1);
    assert!(seen >= Duration::from_millis(300), "saw {seen:?}");
    assert!(seen < Duration::from_secs(5), "saw {seen:?}");
    assert_eq!(longest_since(Instant::now()), Duration::ZERO);
}
