//! Toy protocols written once as actors and run by both drivers: in the
//! simulator (virtual time, timings checked against the cost formula) and
//! on channel transports in threads (wall time).

use std::time::Duration;

use serde::{Deserialize, Serialize};

use crate::net::{
    run_threads, Action, Activity, Actor, ChannelNetwork, Codec, ComputeMode, Event, Message,
    MessageKind, NetworkModel, NodeId, Simulation, TraceKind, WallOptions,
};

#[derive(Serialize, Deserialize)]
struct Ping {
    round: u32,
    data: Vec<u8>,
}
impl Message for Ping {
    const KIND: MessageKind = MessageKind::Control;
}

/// Rank 0: sends `rounds` pings one after another, each after the pong.
pub struct Pinger {
    rounds: u32,
    bytes: usize,
    codec: Codec,
    /// Round trips seen, in order.
    pub rtts: Vec<f64>,
    sent_at: f64,
}

impl Pinger {
    fn ping(&mut self, now: f64, round: u32) -> Action {
        self.sent_at = now;
        let msg = Ping {
            round,
            data: vec![7; self.bytes],
        };
        Action::send(&self.codec, NodeId(1), &msg).expect("encodable")
    }
}

impl Actor for Pinger {
    fn handle(&mut self, now: f64, event: Event) -> Vec<Action> {
        match event {
            Event::Start => vec![self.ping(now, 0)],
            Event::Message(env) => {
                let Ok(pong) = env.decode::<Ping>(&self.codec) else {
                    return vec![Action::Stop];
                };
                assert_eq!(pong.round as usize, self.rtts.len());
                self.rtts.push(now - self.sent_at);
                if self.rtts.len() as u32 == self.rounds {
                    vec![Action::Stop]
                } else {
                    vec![self.ping(now, pong.round + 1)]
                }
            }
            Event::Wake(_) => vec![],
        }
    }
}

/// Rank 1: echoes each ping; stops after the last.
pub struct Ponger {
    rounds: u32,
    codec: Codec,
}

impl Actor for Ponger {
    fn handle(&mut self, _now: f64, event: Event) -> Vec<Action> {
        let Event::Message(env) = event else {
            return vec![];
        };
        let Ok(ping) = env.decode::<Ping>(&self.codec) else {
            return vec![Action::Stop];
        };
        let last = ping.round + 1 == self.rounds;
        let mut out = vec![Action::send(&self.codec, env.from, &ping).expect("encodable")];
        if last {
            out.push(Action::Stop);
        }
        out
    }
}

/// Gather: a worker computes, sends its part to rank 0, stops.
pub struct Worker {
    /// Modelled compute time, seconds.
    pub work_s: f64,
    /// Payload size of its part.
    pub bytes: usize,
}

impl Actor for Worker {
    fn handle(&mut self, _now: f64, event: Event) -> Vec<Action> {
        match event {
            Event::Start => vec![
                Action::Compute {
                    seconds: self.work_s,
                    activity: Activity::Scan,
                },
                Action::Send {
                    to: NodeId(0),
                    kind: MessageKind::Segments,
                    payload: vec![1; self.bytes],
                },
                Action::Stop,
            ],
            _ => vec![],
        }
    }
}

/// Gather root: waits for `expected` parts.
#[derive(Default)]
pub struct Root {
    /// Parts expected.
    pub expected: usize,
    /// (sender, size, arrival time) of each part.
    pub got: Vec<(NodeId, usize, f64)>,
}

impl Actor for Root {
    fn handle(&mut self, now: f64, event: Event) -> Vec<Action> {
        if let Event::Message(env) = event {
            self.got.push((env.from, env.payload.len(), now));
        }
        if self.got.len() == self.expected {
            vec![Action::Stop]
        } else {
            vec![]
        }
    }
}

fn ping_bytes(codec: &Codec, bytes: usize) -> u64 {
    codec
        .encode(&Ping {
            round: 0,
            data: vec![0; bytes],
        })
        .unwrap()
        .len() as u64
}

#[test]
fn ping_pong_in_the_simulator_matches_the_formula() {
    let codec = Codec::default();
    let gbe = NetworkModel::from_name("gbe").unwrap();
    let (rounds, bytes) = (5, 10_000);
    let mut pinger = Pinger {
        rounds,
        bytes,
        codec,
        rtts: vec![],
        sent_at: 0.0,
    };
    let mut ponger = Ponger { rounds, codec };
    let report = Simulation::new(
        gbe.clone(),
        vec![
            Box::new(&mut pinger) as Box<dyn Actor + '_>,
            Box::new(&mut ponger),
        ],
    )
    .run()
    .unwrap();
    assert!(report.unfinished().is_empty());
    let one_way = gbe.latency_s + gbe.wire_time(ping_bytes(&codec, bytes));
    assert_eq!(pinger.rtts.len(), rounds as usize);
    for rtt in &pinger.rtts {
        assert!(
            (rtt - 2.0 * one_way).abs() < 1e-15,
            "{rtt} vs {}",
            2.0 * one_way
        );
    }
    let end = report.stopped_at[0].unwrap();
    assert!((end - f64::from(2 * rounds) * one_way).abs() < 1e-12);
    assert_eq!(report.traffic.total_sent().messages, u64::from(2 * rounds));
}

#[test]
fn ping_pong_over_channels_in_threads() {
    let codec = Codec::default();
    let rounds = 20;
    let mut pinger = Pinger {
        rounds,
        bytes: 1000,
        codec,
        rtts: vec![],
        sent_at: 0.0,
    };
    let mut ponger = Ponger { rounds, codec };
    let net = ChannelNetwork::new(2);
    let report = run_threads(
        &net,
        vec![
            Box::new(&mut pinger) as Box<dyn Actor + Send + '_>,
            Box::new(&mut ponger),
        ],
        WallOptions {
            compute: ComputeMode::Skip,
            recv_timeout: Duration::from_secs(20),
        },
    )
    .unwrap();
    assert_eq!(pinger.rtts.len(), rounds as usize);
    assert!(pinger.rtts.iter().all(|r| *r >= 0.0));
    assert_eq!(report.traffic.total_sent().messages, u64::from(2 * rounds));
    assert_eq!(report.stopped_at.len(), 2);
}

fn gather_actors(n: usize, work_s: f64, bytes: usize) -> (Root, Vec<Worker>) {
    let root = Root {
        expected: n - 1,
        got: vec![],
    };
    let workers = (1..n).map(|_| Worker { work_s, bytes }).collect();
    (root, workers)
}

#[test]
fn gather_in_the_simulator_is_limited_by_the_root_ingress() {
    let gbe = NetworkModel::from_name("gbe").unwrap();
    let (n, c, bytes) = (9, 0.25, 100_000);
    let (mut root, mut workers) = gather_actors(n, c, bytes);
    let mut actors: Vec<Box<dyn Actor + '_>> = vec![Box::new(&mut root)];
    actors.extend(
        workers
            .iter_mut()
            .map(|w| Box::new(w) as Box<dyn Actor + '_>),
    );
    let report = Simulation::new(gbe.clone(), actors).run().unwrap();
    assert!(report.unfinished().is_empty());
    let w = gbe.wire_time(bytes as u64);
    // All 8 parts leave at c; the root's ingress takes them in rank order.
    for (k, (from, size, at)) in root.got.iter().enumerate() {
        assert_eq!(*from, NodeId::from(k + 1));
        assert_eq!(*size, bytes);
        let expect = c + gbe.latency_s + (k + 1) as f64 * w;
        assert!((at - expect).abs() < 1e-12, "part {k}: {at} vs {expect}");
    }
    let last = c + gbe.latency_s + (n - 1) as f64 * w;
    assert!((report.end_time - last).abs() < 1e-12);
    // Each worker scanned for c, then sat on the NIC for w.
    assert_eq!(report.trace.total(NodeId(3), TraceKind::Scan), c);
    assert_eq!(report.traffic.sent_by_dest[0].messages, (n - 1) as u64);
}

#[test]
fn gather_over_channels_in_threads() {
    let (n, c, bytes) = (9, 0.01, 100_000);
    let (mut root, mut workers) = gather_actors(n, c, bytes);
    let mut actors: Vec<Box<dyn Actor + Send + '_>> = vec![Box::new(&mut root)];
    actors.extend(
        workers
            .iter_mut()
            .map(|w| Box::new(w) as Box<dyn Actor + Send + '_>),
    );
    let net = ChannelNetwork::new(n);
    let report = run_threads(
        &net,
        actors,
        WallOptions {
            compute: ComputeMode::Sleep,
            recv_timeout: Duration::from_secs(20),
        },
    )
    .unwrap();
    let mut from: Vec<_> = root.got.iter().map(|g| g.0).collect();
    from.sort();
    assert_eq!(from, (1..n).map(NodeId::from).collect::<Vec<_>>());
    assert!(root.got.iter().all(|g| g.1 == bytes && g.2 >= c));
    assert!(report.end_time >= c);
    assert_eq!(report.traffic.total_sent().bytes, ((n - 1) * bytes) as u64);
    // Workers slept their modelled compute.
    assert!(report.trace.total(NodeId(1), TraceKind::Scan) >= c);
}

/// The node pattern from README.md: scan in chunks, share after each chunk
/// with the manager, handle replies between chunks (via `Wake`).
struct Scanner {
    chunks: u32,
    done: u32,
    replies: u32,
    chunk_s: f64,
    /// What happened, in order: 'c' chunk, 'r' reply.
    log: String,
}

const CHUNK: u64 = 1;

impl Actor for Scanner {
    fn handle(&mut self, _now: f64, event: Event) -> Vec<Action> {
        let mut out = vec![];
        match event {
            Event::Start | Event::Wake(CHUNK) => {
                self.done += 1;
                self.log.push('c');
                out.push(Action::Compute {
                    seconds: self.chunk_s,
                    activity: Activity::Scan,
                });
                out.push(Action::Send {
                    to: NodeId(0),
                    kind: MessageKind::ErtShare,
                    payload: vec![0; 32],
                });
                if self.done < self.chunks {
                    out.push(Action::Wake(CHUNK));
                }
            }
            Event::Message(_) => {
                self.replies += 1;
                self.log.push('r');
            }
            Event::Wake(_) => {}
        }
        if self.done == self.chunks && self.replies == self.chunks {
            out.push(Action::Stop);
        }
        out
    }
}

/// The manager: merges each share (costs time) and replies.
struct Manager {
    expected: u32,
    seen: u32,
    merge_s: f64,
}

impl Actor for Manager {
    fn handle(&mut self, _now: f64, event: Event) -> Vec<Action> {
        let Event::Message(env) = event else {
            return vec![];
        };
        self.seen += 1;
        let mut out = vec![
            Action::Compute {
                seconds: self.merge_s,
                activity: Activity::Share,
            },
            Action::Send {
                to: env.from,
                kind: MessageKind::ErtReply,
                payload: vec![0; 32],
            },
        ];
        if self.seen == self.expected {
            out.push(Action::Stop);
        }
        out
    }
}

fn scanners(n: usize, chunks: u32, chunk_s: f64) -> Vec<Scanner> {
    (1..n)
        .map(|_| Scanner {
            chunks,
            done: 0,
            replies: 0,
            chunk_s,
            log: String::new(),
        })
        .collect()
}

#[test]
fn chunked_scan_with_sharing_in_the_simulator() {
    // Reply to chunk k arrives while chunk k+1 runs (the merge is shorter
    // than a chunk), so it is handled right after chunk k+1: c c r c r c r r.
    let (n, chunks) = (3, 4);
    let mut nodes = scanners(n, chunks, 1e-2);
    let mut mgr = Manager {
        expected: (n as u32 - 1) * chunks,
        seen: 0,
        merge_s: 1e-3,
    };
    let mut actors: Vec<Box<dyn Actor + '_>> = vec![Box::new(&mut mgr)];
    actors.extend(nodes.iter_mut().map(|s| Box::new(s) as Box<dyn Actor + '_>));
    let report = Simulation::new(NetworkModel::from_name("gbe").unwrap(), actors)
        .run()
        .unwrap();
    assert!(report.unfinished().is_empty(), "{:?}", report.unfinished());
    for s in &nodes {
        assert_eq!(s.log, "ccrcrcrr");
    }
    let share = report.trace.total(NodeId(0), TraceKind::Share);
    assert!((share - f64::from((n as u32 - 1) * chunks) * 1e-3).abs() < 1e-12);
    let kinds = &report.traffic.sent_by_kind;
    assert_eq!(kinds[&MessageKind::ErtShare].messages, 8);
    assert_eq!(kinds[&MessageKind::ErtReply].messages, 8);
}

#[test]
fn chunked_scan_with_sharing_over_channels_in_threads() {
    let (n, chunks) = (3, 4);
    let mut nodes = scanners(n, chunks, 5e-3);
    let mut mgr = Manager {
        expected: (n as u32 - 1) * chunks,
        seen: 0,
        merge_s: 0.0,
    };
    let mut actors: Vec<Box<dyn Actor + Send + '_>> = vec![Box::new(&mut mgr)];
    actors.extend(
        nodes
            .iter_mut()
            .map(|s| Box::new(s) as Box<dyn Actor + Send + '_>),
    );
    let net = ChannelNetwork::new(n);
    let options = WallOptions {
        compute: ComputeMode::Sleep,
        recv_timeout: Duration::from_secs(20),
    };
    run_threads(&net, actors, options).unwrap();
    for s in &nodes {
        // Timing on real threads varies; the protocol's outcome does not.
        assert_eq!(s.log.matches('c').count(), 4);
        assert_eq!(s.log.matches('r').count(), 4);
        assert!(s.log.starts_with('c'));
    }
}
