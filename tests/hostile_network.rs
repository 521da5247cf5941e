//! Issue 26, the worker's side: idle and slow connections never lock a
//! legitimate coordinator out; an authenticated coordinator that sends
//! nothing is dropped after a short idle deadline while a second one is
//! told "busy"; a token file readable by others is warned about; an
//! unauthenticated peer learns nothing from a refusal. Only 127.0.0.1 is
//! used; every test is bounded in time.

use std::io::{Read, Write};
use std::net::TcpStream;
use std::time::{Duration, Instant};

use pvrsim::cluster::remote::Coordinator;
use pvrsim::net::tcp::{self, Role, TcpOptions, Token};

mod transport_support;
use transport_support::*;

fn coordinator(addrs: Vec<String>, token: Token) -> Coordinator {
    Coordinator {
        workers: addrs,
        token,
        tcp: TcpOptions::default(),
        recv_timeout: Duration::from_secs(60),
        reassign: false,
    }
}

/// 50 silent connections (and a few that stop half-way through the
/// preamble) held open against each of two workers: the frame still
/// runs, mesh between the workers included, well within the time one
/// handshake timeout per idle connection would take.
#[test]
fn a_frame_succeeds_while_50_idle_connections_are_held_open() {
    let (input, cfg) = config(&data("aorta-small-view-b.toml"), &["--nodes", "2"]);
    let dir = tempfile::tempdir().unwrap();
    let tok = token_file(dir.path(), "token");
    let w0 = WorkerProc::start_with(Some(&tok), &[], false);
    let w1 = WorkerProc::start_with(Some(&tok), &[], false);
    let mut idle = Vec::new();
    for w in [&w0, &w1] {
        for i in 0..50 {
            let mut s = TcpStream::connect(&w.addr).unwrap();
            if i % 10 == 0 {
                let _ = s.write_all(b"PVRSIM\r"); // a slow, partial preamble
            }
            idle.push(s);
        }
    }
    let t = Instant::now();
    let (out, _) = coordinator(
        vec![w0.addr.clone(), w1.addr.clone()],
        Token::load(&tok).unwrap(),
    )
    .run(&input, &cfg)
    .unwrap();
    assert_eq!(out.report.n_nodes, 2);
    assert!(
        t.elapsed() < Duration::from_secs(20),
        "took {:?}",
        t.elapsed()
    );
    // The idle ones are cut at the pre-authentication deadline.
    assert!(w0.wait_line("no complete handshake within", Duration::from_secs(10)));
    drop(idle);
}

/// An authenticated coordinator that sends nothing: a second coordinator
/// is told the worker is busy (naming worker 0) within seconds, and once
/// the idle one is dropped a third runs its frame.
#[test]
fn authenticated_idle_coordinator_gets_dropped_and_others_hear_busy() {
    let (input, cfg) = config(&data("aorta-small-view-b.toml"), &["--nodes", "1"]);
    let dir = tempfile::tempdir().unwrap();
    let tok = token_file(dir.path(), "token");
    let token = Token::load(&tok).unwrap();
    let w = WorkerProc::start_with(Some(&tok), &[], false);
    let rt = tcp::runtime().unwrap();
    let (idle, _) = rt
        .block_on(tcp::connect(
            &w.addr,
            &token,
            Role::Coordinator,
            1,
            &TcpOptions::default(),
        ))
        .unwrap();
    let t = Instant::now();
    let e = coordinator(vec![w.addr.clone()], token.clone())
        .run(&input, &cfg)
        .unwrap_err();
    let e = format!("{e:#}");
    assert!(e.contains("worker 0") && e.contains("busy"), "{e}");
    assert!(
        t.elapsed() < Duration::from_secs(5),
        "took {:?}",
        t.elapsed()
    );
    assert!(w.wait_line("failed", Duration::from_secs(15)));
    let (out, _) = coordinator(vec![w.addr.clone()], token)
        .run(&input, &cfg)
        .unwrap();
    assert_eq!(out.report.n_nodes, 1);
    drop(idle);
}

/// A token file with mode 644 is used, with a warning (as ssh does).
#[cfg(unix)]
#[test]
fn world_readable_token_file_is_warned_about() {
    use std::os::unix::fs::PermissionsExt;
    let dir = tempfile::tempdir().unwrap();
    let tok = token_file(dir.path(), "open-token");
    std::fs::set_permissions(&tok, std::fs::Permissions::from_mode(0o644)).unwrap();
    let w = WorkerProc::start(Some(&tok), &[]);
    assert!(w.wait_line("readable by others", Duration::from_secs(10)));
}

/// A peer that fails the handshake gets one fixed refusal, with no reason.
#[test]
fn unauthenticated_peer_gets_no_detail() {
    let dir = tempfile::tempdir().unwrap();
    let tok = token_file(dir.path(), "token");
    let w = WorkerProc::start(Some(&tok), &[]);
    let mut s = TcpStream::connect(&w.addr).unwrap();
    s.set_read_timeout(Some(Duration::from_secs(10))).unwrap();
    let mut hello = b"PVRSIM\r\n".to_vec();
    hello.extend_from_slice(&[99, 0, 1, 0, 0, 0, 0]); // version 99
    hello.extend_from_slice(&[0u8; 32]);
    s.write_all(&hello).unwrap();
    let mut back = Vec::new();
    let _ = s.read_to_end(&mut back);
    let back = String::from_utf8_lossy(&back);
    assert!(back.contains("handshake refused"), "{back}");
    assert!(!back.contains("version"), "{back}");
    // The worker's own log has the reason.
    assert!(w.wait_line("protocol version 99", Duration::from_secs(10)));
}
