//! The network cost model: when does a message sent at time `t` arrive?
//!
//! This module knows nothing about nodes, ERT tables or images; the
//! simulator ([`crate::net::Simulation`]) asks it about each message and
//! simulated code never sees it (as in SimGrid, where the model and the
//! application only meet in the engine).
//!
//! # Model
//!
//! Ranks hang off one switch, each by a full-duplex link: an *egress* NIC
//! (rank → switch) and an *ingress* NIC (switch → rank), both of bandwidth
//! `B` bytes/s. Parameters ([`NetworkModel`]):
//!
//! | symbol | field | meaning |
//! |---|---|---|
//! | α | `latency_s` | one-way latency of an empty message |
//! | B | `bandwidth_bytes_per_s` | per-link, per-direction line rate |
//! | o | `overhead_s` | extra time a message holds its sender's NIC (LogP gap) |
//! | h | `header_bytes` | per-message header (MPI envelope) |
//! | m, f | `frame_payload_bytes`, `frame_overhead_bytes` | frame payload and per-frame overhead |
//! | S | `bisection_bytes_per_s` | aggregate switch capacity (optional) |
//!
//! A payload of `b` bytes puts on the wire
//!
//! ```text
//! b_w = (b + h) + f * max(1, ceil((b + h) / m))      (b_w = b + h without framing)
//! ```
//!
//! and occupies a link for `w = b_w / B` (the egress for `o + w`).
//!
//! **One message alone** (the alpha-beta model): sent at `t`, it arrives at
//!
//! ```text
//! T = t + o + α + b_w / B
//! ```
//!
//! **Contention.** Each NIC serves messages one at a time in the order they
//! are handed to the model (FIFO); the switch, if limited, is one more FIFO
//! server of rate S. Stages are pipelined (cut-through): a stage may start
//! when the previous one starts, and cannot finish before it. With
//! `E[s]`, `I[d]`, `X` the times the egress of `s`, the ingress of `d` and
//! the switch next fall free:
//!
//! ```text
//! egress:  e0 = max(t, E[s]),         e1 = e0 + o + w,                E[s] = e1
//! switch:  x0 = max(e0, X),           x1 = max(x0 + b_w / S, e1),     X = x0 + b_w / S
//! ingress: i0 = max(x0, I[d]),        i1 = max(i0 + w, x1),           I[d] = i1
//! arrival: T = i1 + α
//! ```
//!
//! (without a switch limit, `x0 = e0`, `x1 = e1`). Consequences, each tested:
//! k messages from one sender at once arrive at `t + α + k (o + w)`; n
//! senders to one receiver at once are limited by that receiver's ingress,
//! the last arriving at `t + α + n w` — the manager's NIC is the shared
//! bottleneck of ERT sharing; and the switch passes at most `S` bytes/s in
//! aggregate.
//!
//! A message to oneself costs nothing and uses no NIC (MPI copies it).
//!
//! # Limits of the model
//!
//! FIFO reservation in the order messages are handed over, with no gap
//! filling: a message can wait at an ingress behind an earlier one that is
//! itself held up at its sender. The switch serves messages in turn at the
//! full rate S instead of sharing S fairly among flows (max-min, as
//! SimGrid's CM02 does), so under a bisection limit individual messages
//! finish in a different order while the aggregate rate is still capped at
//! S. TCP slow start, packet loss and receive-side CPU cost are not
//! modelled.
//!
//! # Presets
//!
//! [`NetworkModel::from_name`] knows `gbe`, `fast-ethernet`, `10gbe`,
//! `infiniband` and `ideal`; their parameters and the source of each number
//! are in `configs/network/<name>.toml`, compiled into the binary, so data
//! and citation stay together. Users define their own with the same TOML
//! keys ([`NetworkModel::from_toml_str`], [`NetworkModel::load`]).

use std::fmt;
use std::path::Path;

use serde::{Deserialize, Serialize};

use super::error::{NetError, NetResult};
use super::message::NodeId;

/// Names and TOML sources of the built-in presets.
const PRESETS: [(&str, &str); 6] = [
    ("gbe", include_str!("../../configs/network/gbe.toml")),
    (
        "fast-ethernet",
        include_str!("../../configs/network/fast-ethernet.toml"),
    ),
    ("10gbe", include_str!("../../configs/network/10gbe.toml")),
    (
        "infiniband",
        include_str!("../../configs/network/infiniband.toml"),
    ),
    ("ideal", include_str!("../../configs/network/ideal.toml")),
    (
        "100base",
        include_str!("../../configs/network/100base.toml"),
    ),
];

/// Parameters of the network (see the module docs for the math).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NetworkModel {
    /// Preset or user name.
    pub name: String,
    /// One line for `pvrsim list`.
    #[serde(default)]
    pub description: String,
    /// α: one-way latency of an empty message, seconds.
    pub latency_s: f64,
    /// B: per-link, per-direction bandwidth in bytes/s; `None` = unlimited.
    #[serde(default)]
    pub bandwidth_bytes_per_s: Option<f64>,
    /// o: seconds a message holds its sender's NIC besides its bytes.
    #[serde(default)]
    pub overhead_s: f64,
    /// h: header bytes added to every message.
    #[serde(default)]
    pub header_bytes: u64,
    /// m: payload bytes per frame; `None` = no framing.
    #[serde(default)]
    pub frame_payload_bytes: Option<u64>,
    /// f: overhead bytes per frame on the wire.
    #[serde(default)]
    pub frame_overhead_bytes: u64,
    /// S: aggregate switch capacity in bytes/s; `None` = non-blocking.
    #[serde(default)]
    pub bisection_bytes_per_s: Option<f64>,
}

impl NetworkModel {
    /// Names accepted by [`NetworkModel::from_name`].
    pub fn preset_names() -> impl Iterator<Item = &'static str> {
        PRESETS.iter().map(|(n, _)| *n)
    }

    /// A built-in preset by name (`gbe`, `fast-ethernet`, `10gbe`,
    /// `infiniband`, `ideal`).
    pub fn from_name(name: &str) -> NetResult<Self> {
        let (_, src) = PRESETS.iter().find(|(n, _)| *n == name).ok_or_else(|| {
            let known: Vec<_> = Self::preset_names().collect();
            NetError::Config {
                key: "name".into(),
                msg: format!(
                    "unknown network preset `{name}`; known: {} (or load a TOML file)",
                    known.join(", ")
                ),
            }
        })?;
        Self::from_toml_str(src)
    }

    /// The zero-cost model (every message arrives when sent).
    pub fn ideal() -> Self {
        NetworkModel {
            name: "ideal".into(),
            description: String::new(),
            latency_s: 0.0,
            bandwidth_bytes_per_s: None,
            overhead_s: 0.0,
            header_bytes: 0,
            frame_payload_bytes: None,
            frame_overhead_bytes: 0,
            bisection_bytes_per_s: None,
        }
    }

    /// Parses and validates a model from TOML text.
    pub fn from_toml_str(src: &str) -> NetResult<Self> {
        let m: NetworkModel = toml::from_str(src).map_err(|e| NetError::Config {
            key: "(toml)".into(),
            msg: e.to_string(),
        })?;
        m.validate()?;
        Ok(m)
    }

    /// Loads a model from a TOML file (`configs/network/*.toml` form).
    pub fn load(path: &Path) -> NetResult<Self> {
        let src = std::fs::read_to_string(path).map_err(|e| NetError::Config {
            key: path.display().to_string(),
            msg: e.to_string(),
        })?;
        Self::from_toml_str(&src)
    }

    /// Checks every parameter is finite and in range.
    pub fn validate(&self) -> NetResult<()> {
        let bad = |key: &str, msg: &str| {
            Err(NetError::Config {
                key: key.into(),
                msg: msg.into(),
            })
        };
        if !(self.latency_s.is_finite() && self.latency_s >= 0.0) {
            return bad("latency_s", "must be a finite number >= 0 (seconds)");
        }
        if !(self.overhead_s.is_finite() && self.overhead_s >= 0.0) {
            return bad("overhead_s", "must be a finite number >= 0 (seconds)");
        }
        for (key, v) in [
            ("bandwidth_bytes_per_s", self.bandwidth_bytes_per_s),
            ("bisection_bytes_per_s", self.bisection_bytes_per_s),
        ] {
            if let Some(v) = v {
                if !(v.is_finite() && v > 0.0) {
                    return bad(
                        key,
                        "must be a finite number > 0 (bytes/s); omit it for unlimited",
                    );
                }
            }
        }
        if self.frame_payload_bytes == Some(0) {
            return bad("frame_payload_bytes", "must be > 0; omit it for no framing");
        }
        Ok(())
    }

    /// Bytes on the wire for a payload of `bytes`: `b_w` in the module docs.
    pub fn wire_bytes(&self, bytes: u64) -> u64 {
        let b = bytes.saturating_add(self.header_bytes);
        match self.frame_payload_bytes {
            Some(m) if m > 0 => {
                let frames = b.div_ceil(m).max(1);
                b.saturating_add(frames.saturating_mul(self.frame_overhead_bytes))
            }
            _ => b,
        }
    }

    /// Seconds a payload of `bytes` occupies one link: `w = b_w / B`.
    pub fn wire_time(&self, bytes: u64) -> f64 {
        match self.bandwidth_bytes_per_s {
            Some(bw) => self.wire_bytes(bytes) as f64 / bw,
            None => 0.0,
        }
    }

    /// Arrival time of one message on an idle network:
    /// `t + o + α + b_w / B`.
    pub fn uncontended_arrival(&self, t: f64, bytes: u64) -> f64 {
        t + self.overhead_s + self.wire_time(bytes) + self.latency_s
    }

    /// Computes when a message of `bytes` sent by `from` to `to` at `t`
    /// arrives, and reserves the NICs and switch in `state`. Deterministic:
    /// the same calls in the same order give the same times.
    pub fn transfer(
        &self,
        state: &mut NetState,
        from: NodeId,
        to: NodeId,
        bytes: u64,
        t: f64,
    ) -> NetResult<Transfer> {
        let n = state.egress_free.len();
        for r in [from, to] {
            if r.index() >= n {
                return Err(NetError::NoSuchRank { to: r, size: n });
            }
        }
        if from == to {
            return Ok(Transfer {
                send_start: t,
                send_end: t,
                recv_start: t,
                arrival: t,
                wire_bytes: 0,
            });
        }
        let b_w = self.wire_bytes(bytes);
        let w = self.wire_time(bytes);
        let e0 = t.max(state.egress_free[from.index()]);
        let e1 = e0 + self.overhead_s + w;
        state.egress_free[from.index()] = e1;
        let (x0, x1) = match self.bisection_bytes_per_s {
            Some(s) => {
                let x0 = e0.max(state.switch_free);
                let occupied = x0 + b_w as f64 / s;
                state.switch_free = occupied;
                (x0, occupied.max(e1))
            }
            None => (e0, e1),
        };
        let i0 = x0.max(state.ingress_free[to.index()]);
        let i1 = (i0 + w).max(x1);
        state.ingress_free[to.index()] = i1;
        Ok(Transfer {
            send_start: e0,
            send_end: e1,
            recv_start: i0 + self.latency_s,
            arrival: i1 + self.latency_s,
            wire_bytes: b_w,
        })
    }
}

impl fmt::Display for NetworkModel {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: alpha = {} us", self.name, self.latency_s * 1e6)?;
        match self.bandwidth_bytes_per_s {
            Some(b) => write!(f, ", B = {} MB/s", b / 1e6)?,
            None => write!(f, ", B = unlimited")?,
        }
        if self.overhead_s > 0.0 {
            write!(f, ", o = {} us", self.overhead_s * 1e6)?;
        }
        if self.header_bytes > 0 {
            write!(f, ", header {} B", self.header_bytes)?;
        }
        if let Some(m) = self.frame_payload_bytes {
            write!(f, ", frames {m} + {} B", self.frame_overhead_bytes)?;
        }
        if let Some(s) = self.bisection_bytes_per_s {
            write!(f, ", bisection {} MB/s", s / 1e6)?;
        }
        Ok(())
    }
}

/// When the NICs and the switch next fall free (seconds). One per network;
/// owned by the simulator.
#[derive(Clone, Debug, PartialEq)]
pub struct NetState {
    egress_free: Vec<f64>,
    ingress_free: Vec<f64>,
    switch_free: f64,
}

impl NetState {
    /// An idle network of `n` ranks.
    pub fn new(n: usize) -> Self {
        NetState {
            egress_free: vec![0.0; n],
            ingress_free: vec![0.0; n],
            switch_free: 0.0,
        }
    }
}

/// The timing of one message, as computed by [`NetworkModel::transfer`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Transfer {
    /// When the first byte leaves the sender's NIC (`e0`).
    pub send_start: f64,
    /// When the sender's NIC is done with it (`e1`).
    pub send_end: f64,
    /// When the first byte reaches the receiver (`i0 + α`).
    pub recv_start: f64,
    /// When the whole message has arrived (`T`).
    pub arrival: f64,
    /// Bytes on the wire including headers and framing (`b_w`).
    pub wire_bytes: u64,
}
