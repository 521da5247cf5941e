//! The run's timeline: typed spans per node ([`SimTrace`]), written as
//! Chrome trace JSON (the `traceEvents` format that Perfetto and
//! `chrome://tracing` open) by [`SimTrace::to_chrome_json`].
//!
//! In the Chrome file each rank is a process (`pid` = rank) with three
//! threads: `cpu` (compute and idle spans), `nic-out` (sends) and `nic-in`
//! (receives), since a NIC works while its CPU computes. Times are written in
//! microseconds, as the format requires.

use std::io::Write;

use serde::{Deserialize, Serialize};
use serde_json::{json, Value};

use super::actor::Activity;
use super::message::{MessageKind, NodeId};

/// One compute action of one handler call on a real transport: what the
/// cost model said it costs and what it took.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct CpuSample {
    /// The rank.
    pub node: NodeId,
    /// The activity (scan, share, steal, composite, compute).
    pub kind: TraceKind,
    /// Wall-clock start of the call, seconds (the driver's clock).
    pub start: f64,
    /// Modelled seconds (the action's `seconds`).
    pub modelled_s: f64,
    /// Wall seconds of the call (its share, with several actions).
    pub wall_s: f64,
    /// Thread CPU seconds of the call (its share, with several actions).
    pub cpu_s: f64,
}

/// What a span of a node's time was spent on.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
pub enum TraceKind {
    /// Generic computation.
    Compute,
    /// Scan conversion.
    Scan,
    /// ERT table building or merging.
    Share,
    /// Load-balancing work transfer.
    Steal,
    /// Waiting with nothing to do.
    Idle,
    /// Compositing.
    Composite,
    /// A message leaving the node's NIC.
    Send,
    /// A message arriving at the node's NIC.
    Recv,
}

impl TraceKind {
    /// Lower-case name used in traces and reports.
    pub fn name(self) -> &'static str {
        match self {
            TraceKind::Compute => "compute",
            TraceKind::Scan => "scan",
            TraceKind::Share => "share",
            TraceKind::Steal => "steal",
            TraceKind::Idle => "idle",
            TraceKind::Composite => "composite",
            TraceKind::Send => "send",
            TraceKind::Recv => "recv",
        }
    }

    /// The Chrome-trace thread the span goes on: 0 cpu, 1 nic-out, 2 nic-in.
    fn lane(self) -> u32 {
        match self {
            TraceKind::Send => 1,
            TraceKind::Recv => 2,
            _ => 0,
        }
    }
}

impl From<Activity> for TraceKind {
    fn from(a: Activity) -> Self {
        match a {
            Activity::Compute => TraceKind::Compute,
            Activity::Scan => TraceKind::Scan,
            Activity::Share => TraceKind::Share,
            Activity::Steal => TraceKind::Steal,
            Activity::Composite => TraceKind::Composite,
        }
    }
}

/// One span of one node's timeline.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TraceEvent {
    /// The node.
    pub node: NodeId,
    /// Start, seconds.
    pub start: f64,
    /// End, seconds (>= start).
    pub end: f64,
    /// What the time was spent on.
    pub kind: TraceKind,
    /// Payload bytes (messages only; 0 otherwise).
    pub bytes: u64,
    /// The other end of a message.
    pub peer: Option<NodeId>,
    /// The message's kind.
    pub message: Option<MessageKind>,
}

/// All spans of a run, in the order the driver recorded them.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct SimTrace {
    /// The spans.
    pub events: Vec<TraceEvent>,
    /// Real transports only: per compute action, modelled beside measured
    /// wall and thread CPU seconds ([`super::cpu`]). Empty on the virtual
    /// clock.
    #[serde(default)]
    pub cpu: Vec<CpuSample>,
}

impl SimTrace {
    /// Appends a compute-like or idle span.
    pub fn span(&mut self, node: NodeId, start: f64, end: f64, kind: TraceKind) {
        self.events.push(TraceEvent {
            node,
            start,
            end,
            kind,
            bytes: 0,
            peer: None,
            message: None,
        });
    }

    /// Appends a message span (`Send` on the sender or `Recv` on the
    /// receiver).
    #[allow(clippy::too_many_arguments)]
    pub fn message(
        &mut self,
        node: NodeId,
        start: f64,
        end: f64,
        kind: TraceKind,
        peer: NodeId,
        message: MessageKind,
        bytes: u64,
    ) {
        self.events.push(TraceEvent {
            node,
            start,
            end,
            kind,
            bytes,
            peer: Some(peer),
            message: Some(message),
        });
    }

    /// Total seconds `node` spent in spans of `kind`.
    pub fn total(&self, node: NodeId, kind: TraceKind) -> f64 {
        self.events
            .iter()
            .filter(|e| e.node == node && e.kind == kind)
            .map(|e| e.end - e.start)
            .sum()
    }

    /// The latest end time of any span (0 for an empty trace).
    pub fn end_time(&self) -> f64 {
        self.events.iter().map(|e| e.end).fold(0.0, f64::max)
    }

    /// The trace as a Chrome trace JSON value (`{"traceEvents": [...]}`).
    pub fn to_chrome_json(&self) -> Value {
        let mut nodes: Vec<NodeId> = self.events.iter().map(|e| e.node).collect();
        nodes.sort();
        nodes.dedup();
        let mut out = Vec::with_capacity(self.events.len() + 4 * nodes.len());
        for n in &nodes {
            out.push(
                json!({"ph": "M", "name": "process_name", "pid": n.0, "tid": 0,
                            "args": {"name": format!("rank {}", n.0)}}),
            );
            for (tid, name) in [(0, "cpu"), (1, "nic-out"), (2, "nic-in")] {
                out.push(
                    json!({"ph": "M", "name": "thread_name", "pid": n.0, "tid": tid,
                                "args": {"name": name}}),
                );
            }
        }
        for e in &self.events {
            let name = match e.message {
                Some(m) => format!("{} {}", e.kind.name(), m.name()),
                None => e.kind.name().to_string(),
            };
            let mut args = serde_json::Map::new();
            if e.bytes > 0 || e.message.is_some() {
                args.insert("bytes".into(), json!(e.bytes));
            }
            if let Some(p) = e.peer {
                args.insert("peer".into(), json!(p.0));
            }
            out.push(json!({
                "name": name,
                "cat": e.kind.name(),
                "ph": "X",
                "ts": e.start * 1e6,
                "dur": (e.end - e.start).max(0.0) * 1e6,
                "pid": e.node.0,
                "tid": e.kind.lane(),
                "args": Value::Object(args),
            }));
        }
        json!({"traceEvents": out, "displayTimeUnit": "ms"})
    }

    /// Writes the Chrome trace JSON to `w`.
    pub fn write_chrome_json<W: Write>(&self, w: W) -> std::io::Result<()> {
        serde_json::to_writer(w, &self.to_chrome_json()).map_err(std::io::Error::other)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chrome_json_has_complete_events_in_microseconds() {
        let mut t = SimTrace::default();
        t.span(NodeId(1), 0.5, 0.75, TraceKind::Scan);
        t.message(
            NodeId(1),
            0.75,
            0.76,
            TraceKind::Send,
            NodeId(0),
            MessageKind::ErtShare,
            900,
        );
        let mut buf = Vec::new();
        t.write_chrome_json(&mut buf).unwrap();
        let v: Value = serde_json::from_slice(&buf).unwrap();
        let evs = v["traceEvents"].as_array().unwrap();
        let x: Vec<_> = evs.iter().filter(|e| e["ph"] == "X").collect();
        assert_eq!(x.len(), 2);
        assert_eq!(x[0]["name"], "scan");
        assert_eq!(x[0]["ts"], 500000.0);
        assert_eq!(x[0]["dur"], 250000.0);
        assert_eq!(x[0]["pid"], 1);
        assert_eq!(x[0]["tid"], 0);
        assert_eq!(x[1]["name"], "send ert-share");
        assert_eq!(x[1]["tid"], 1);
        assert_eq!(x[1]["args"]["bytes"], 900);
        assert_eq!(x[1]["args"]["peer"], 0);
        // Metadata names the process and its three lanes.
        let meta = evs.iter().filter(|e| e["ph"] == "M").count();
        assert_eq!(meta, 4);
        assert_eq!(t.total(NodeId(1), TraceKind::Scan), 0.25);
    }
}
