//! How a [`TcpTransport`] ends its links: a writer that cannot flush (its
//! peer reads nothing) is ended after the close's wait instead of being
//! left on the runtime with its socket and queued frames; and after a
//! failed frame, a rank that was itself not running for half its
//! heartbeat deadline leaves without `Goodbye` (its peers see it lost),
//! while one that ran throughout says `Goodbye`.

use std::io::Read;
use std::sync::Arc;
use std::time::{Duration, Instant};

use pvrsim::net::tcp::{decode_all, Link, LinkFrame, TcpOptions, TcpTransport};
use pvrsim::net::{Codec, MessageKind, NodeId, RemoteTransport, Transport};

/// The tests stop this whole process (every test's threads): one at a
/// time.
static SERIAL: std::sync::Mutex<()> = std::sync::Mutex::new(());

fn serial() -> std::sync::MutexGuard<'static, ()> {
    SERIAL.lock().unwrap_or_else(|e| e.into_inner())
}

fn runtime() -> Arc<tokio::runtime::Runtime> {
    tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .map(Arc::new)
        .unwrap()
}

/// Rank 0's transport (of 2) linked to rank 1, whose end is a bare socket
/// the test holds.
fn linked(
    rt: &Arc<tokio::runtime::Runtime>,
    opts: TcpOptions,
) -> (TcpTransport, std::net::TcpStream) {
    let l = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let peer = std::net::TcpStream::connect(l.local_addr().unwrap()).unwrap();
    let (mine, _) = l.accept().unwrap();
    mine.set_nonblocking(true).unwrap();
    let stream = {
        let _g = rt.enter();
        tokio::net::TcpStream::from_std(mine).unwrap()
    };
    let link = Link {
        rank: NodeId(1),
        name: "worker 1 (test)".into(),
        stream,
    };
    let t = TcpTransport::new(Arc::clone(rt), NodeId(0), 2, vec![link], opts).unwrap();
    (t, peer)
}

/// Everything the peer reads until the connection ends (or 10 s).
fn read_all(mut peer: std::net::TcpStream) -> Vec<u8> {
    peer.set_read_timeout(Some(Duration::from_secs(10)))
        .unwrap();
    let mut v = Vec::new();
    let _ = peer.read_to_end(&mut v);
    v
}

#[test]
fn a_close_that_cannot_flush_ends_the_writer() {
    let _s = serial();
    let rt = runtime();
    let (t, peer) = linked(&rt, TcpOptions::default());
    // 64 MiB queued: far more than the socket buffers take.
    let mb = 1 << 20;
    for _ in 0..64 {
        t.send(NodeId(1), MessageKind::Segments, vec![7u8; mb])
            .unwrap();
    }
    let t0 = Instant::now();
    t.close(Duration::from_millis(300));
    assert!(t0.elapsed() < Duration::from_secs(2), "{:?}", t0.elapsed());
    let until = Instant::now() + Duration::from_secs(2);
    while rt.metrics().num_alive_tasks() > 0 && Instant::now() < until {
        std::thread::sleep(Duration::from_millis(10));
    }
    assert_eq!(
        rt.metrics().num_alive_tasks(),
        0,
        "a link's task outlived the close"
    );
    // The peer sees the link end, not the rest of the frames later.
    let got = read_all(peer);
    assert!(
        got.len() < 64 * mb,
        "{} bytes: every frame still went out",
        got.len()
    );
}

/// Stops this process for `stop` (a SIGSTOP from outside, and a SIGCONT
/// after `stop`), after a moment.
fn stop_me(stop: Duration) {
    std::thread::sleep(Duration::from_millis(100));
    let me = std::process::id();
    let s = stop.as_secs_f64();
    std::process::Command::new("sh")
        .args([
            "-c",
            &format!("kill -STOP {me}; sleep {s}; kill -CONT {me}"),
        ])
        .spawn()
        .unwrap()
        .wait()
        .unwrap();
}

/// A peer's `Goodbye` is a clean end, unless this process was stopped
/// long enough for the peer to have given up on it: with a 1 s deadline
/// and heartbeats every 0.6 s, a stop of 0.5 s (with the period before it,
/// the peer may have heard nothing for 1.1 s). The peer sends heartbeats
/// every 100 ms, so that this side's own deadline never passes.
#[test]
fn a_goodbye_after_a_stop_past_the_deadline_ends_the_frame() {
    let _s = serial();
    use std::io::Write;
    use std::sync::atomic::{AtomicBool, Ordering};
    pvrsim::net::stall::watch();
    for stop in [Duration::ZERO, Duration::from_millis(500)] {
        let rt = runtime();
        let opts = TcpOptions {
            deadline: Duration::from_secs(1),
            heartbeat: Duration::from_millis(600),
            ..Default::default()
        };
        let (t, mut peer) = linked(&rt, opts);
        let done = Arc::new(AtomicBool::new(false));
        let beat = {
            let (mut p, done) = (peer.try_clone().unwrap(), Arc::clone(&done));
            std::thread::spawn(move || {
                while !done.load(Ordering::SeqCst) {
                    let _ = p.write_all(&[pvrsim::net::tcp::frame::TAG_HEARTBEAT]);
                    std::thread::sleep(Duration::from_millis(100));
                }
            })
        };
        if !stop.is_zero() {
            stop_me(stop);
        }
        done.store(true, Ordering::SeqCst);
        beat.join().unwrap();
        peer.write_all(&[pvrsim::net::tcp::frame::TAG_GOODBYE])
            .unwrap();
        let r = t.recv_timeout(Duration::from_millis(300));
        if stop.is_zero() {
            assert!(matches!(r, Ok(None)), "{r:?}");
        } else {
            let e = r.expect_err("a Goodbye after the stop").to_string();
            assert!(e.contains("not running"), "{e}");
        }
    }
}

/// The frames the peer read after `close_after_failure`, and what it
/// returned, with this process stopped for `stop` first (0: not).
fn after_failure(stop: Duration) -> (Vec<LinkFrame>, bool) {
    pvrsim::net::stall::watch();
    let rt = runtime();
    let opts = TcpOptions {
        deadline: Duration::from_secs(1),
        ..Default::default()
    };
    let (t, peer) = linked(&rt, opts);
    let since = Instant::now();
    t.send(NodeId(1), MessageKind::Session, b"failed".to_vec())
        .unwrap();
    if !stop.is_zero() {
        stop_me(stop);
    }
    let lost = t.close_after_failure(since, Duration::from_secs(2));
    let (frames, err) = decode_all(&read_all(peer), &Codec::default());
    assert!(err.is_none(), "{err:?}");
    (frames, lost)
}

#[test]
fn a_rank_stopped_past_its_deadline_leaves_without_goodbye() {
    let _s = serial();
    let (frames, lost) = after_failure(Duration::ZERO);
    assert!(!lost);
    let kinds = |f: &[LinkFrame]| -> Vec<&'static str> {
        f.iter()
            .filter(|f| !matches!(f, LinkFrame::Heartbeat))
            .map(|f| match f {
                LinkFrame::Data(_) => "data",
                LinkFrame::Goodbye => "goodbye",
                LinkFrame::Heartbeat => unreachable!(),
            })
            .collect()
    };
    assert_eq!(kinds(&frames), ["data", "goodbye"]);
    let (frames, lost) = after_failure(Duration::from_secs(1));
    assert!(lost, "a 1 s stop with a 1 s deadline");
    assert_eq!(
        kinds(&frames),
        ["data"],
        "the queued message, then no Goodbye"
    );
}
