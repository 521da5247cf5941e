//! Semantics of the discrete-event driver: busy actors, wakes, deadlock
//! reports, bad actions, scale and determinism.

use std::time::Instant;

use crate::net::{
    Action, Activity, Actor, Event, MessageKind, NetError, NetworkModel, NodeId, SimOptions,
    SimReport, Simulation, TraceKind,
};

use super::protocols::{Root, Worker};

/// Records every event it sees with its time; runs a scripted reaction.
struct Probe {
    log: Vec<(f64, String)>,
    on_start: Vec<Action>,
    on_wake: Vec<Action>,
}

impl Actor for Probe {
    fn handle(&mut self, now: f64, event: Event) -> Vec<Action> {
        match event {
            Event::Start => {
                self.log.push((now, "start".into()));
                std::mem::take(&mut self.on_start)
            }
            Event::Message(e) => {
                self.log.push((now, format!("msg {}", e.payload[0])));
                vec![]
            }
            Event::Wake(t) => {
                self.log.push((now, format!("wake {t}")));
                std::mem::take(&mut self.on_wake)
            }
        }
    }
}

fn send(to: u32, tag: u8) -> Action {
    Action::Send {
        to: NodeId(to),
        kind: MessageKind::Control,
        payload: vec![tag],
    }
}

fn compute(s: f64) -> Action {
    Action::Compute {
        seconds: s,
        activity: Activity::Compute,
    }
}

#[test]
fn messages_wait_while_busy_and_wake_comes_after_them() {
    // Rank 0 computes 1 s then wakes itself; rank 1 sends at t = 0 and
    // t = 0.5 (ideal network: instant delivery).
    let mut a = Probe {
        log: vec![],
        on_start: vec![compute(1.0), Action::Wake(9)],
        on_wake: vec![Action::Stop],
    };
    let mut b = Probe {
        log: vec![],
        on_start: vec![send(0, 1), compute(0.5), send(0, 2), Action::Stop],
        on_wake: vec![],
    };
    let report = Simulation::new(
        NetworkModel::ideal(),
        vec![Box::new(&mut a), Box::new(&mut b)],
    )
    .run()
    .unwrap();
    assert_eq!(
        a.log,
        vec![
            (0.0, "start".to_string()),
            (1.0, "msg 1".to_string()),
            (1.0, "msg 2".to_string()),
            (1.0, "wake 9".to_string()),
        ]
    );
    assert_eq!(report.stopped_at, vec![Some(1.0), Some(0.5)]);
}

#[test]
fn messages_to_stopped_actors_are_dropped() {
    let mut a = Probe {
        log: vec![],
        on_start: vec![Action::Stop],
        on_wake: vec![],
    };
    let mut b = Probe {
        log: vec![],
        on_start: vec![compute(1.0), send(0, 1), Action::Stop],
        on_wake: vec![],
    };
    let report = Simulation::new(
        NetworkModel::ideal(),
        vec![Box::new(&mut a), Box::new(&mut b)],
    )
    .run()
    .unwrap();
    assert_eq!(report.dropped, 1);
    assert_eq!(a.log.len(), 1);
}

#[test]
fn a_deadlock_is_reported_not_hung() {
    let mut root = Root {
        expected: 2,
        got: vec![],
    };
    let mut w = Worker {
        work_s: 0.1,
        bytes: 8,
    };
    let report = Simulation::new(
        NetworkModel::ideal(),
        vec![Box::new(&mut root) as Box<dyn Actor + '_>, Box::new(&mut w)],
    )
    .run()
    .unwrap();
    assert_eq!(report.unfinished(), vec![NodeId(0)]);
}

#[test]
fn invalid_actions_are_errors() {
    for bad in [
        compute(-1.0),
        compute(f64::NAN),
        compute(f64::INFINITY),
        send(7, 0),
    ] {
        let mut a = Probe {
            log: vec![],
            on_start: vec![bad.clone()],
            on_wake: vec![],
        };
        let r = Simulation::new(NetworkModel::ideal(), vec![Box::new(&mut a)]).run();
        assert!(
            matches!(r, Err(NetError::Sim(_)) | Err(NetError::NoSuchRank { .. })),
            "{bad:?}"
        );
    }
}

#[test]
fn endless_wakes_hit_the_event_limit() {
    struct Spinner;
    impl Actor for Spinner {
        fn handle(&mut self, _: f64, _: Event) -> Vec<Action> {
            vec![compute(1e-3), Action::Wake(0)]
        }
    }
    let r = Simulation::new(NetworkModel::ideal(), vec![Box::new(Spinner)])
        .with_options(SimOptions {
            max_events: 1000,
            ..SimOptions::default()
        })
        .run();
    assert!(matches!(r, Err(NetError::Sim(_))));
}

#[test]
fn idle_time_is_traced() {
    let mut root = Root {
        expected: 1,
        got: vec![],
    };
    let mut w = Worker {
        work_s: 2.0,
        bytes: 8,
    };
    let report = Simulation::new(
        NetworkModel::ideal(),
        vec![Box::new(&mut root) as Box<dyn Actor + '_>, Box::new(&mut w)],
    )
    .run()
    .unwrap();
    assert_eq!(report.trace.total(NodeId(0), TraceKind::Idle), 2.0);
    assert_eq!(report.trace.total(NodeId(1), TraceKind::Scan), 2.0);
}

/// 256 actors: 255 workers with uneven compute times send 16 KiB each to
/// rank 0 over GbE.
fn all_to_one(n: usize) -> (SimReport, Vec<(NodeId, usize, f64)>) {
    let mut root = Root {
        expected: n - 1,
        got: vec![],
    };
    let mut workers: Vec<Worker> = (1..n)
        .map(|i| Worker {
            // Deterministic spread of 0..10 ms.
            work_s: ((i * 7919) % 100) as f64 * 1e-4,
            bytes: 16 * 1024,
        })
        .collect();
    let mut actors: Vec<Box<dyn Actor + '_>> = vec![Box::new(&mut root)];
    actors.extend(
        workers
            .iter_mut()
            .map(|w| Box::new(w) as Box<dyn Actor + '_>),
    );
    let report = Simulation::new(NetworkModel::from_name("gbe").unwrap(), actors)
        .run()
        .unwrap();
    (report, root.got)
}

#[test]
fn all_to_one_256_is_fast_and_deterministic() {
    let t0 = Instant::now();
    let (r1, got1) = all_to_one(256);
    let elapsed = t0.elapsed();
    let (r2, got2) = all_to_one(256);
    assert!(elapsed.as_secs_f64() < 0.5, "took {elapsed:?}");
    assert!(r1.unfinished().is_empty());
    assert_eq!(got1.len(), 255);
    // Identical, bit for bit.
    assert_eq!(r1, r2);
    assert_eq!(got1, got2);
    // The root's ingress is the bottleneck: 255 parts need at least
    // 255 * w after the first leaves.
    let gbe = NetworkModel::from_name("gbe").unwrap();
    let w = gbe.wire_time(16 * 1024);
    assert!(r1.end_time >= 255.0 * w);
    // Arrivals are spaced by at least w (one at a time through the NIC).
    for pair in got1.windows(2) {
        assert!(pair[1].2 - pair[0].2 >= w * (1.0 - 1e-9));
    }
    // The trace converts to Chrome JSON with one X event per span.
    let json = r1.trace.to_chrome_json();
    let x = json["traceEvents"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|e| e["ph"] == "X")
        .count();
    assert_eq!(x, r1.trace.events.len());
}
