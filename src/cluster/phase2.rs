//! Phase 2 on the simulated network: the compositor's schedule is executed
//! in-process with real bytes ([`LocalRun`]), and every message of every
//! round is replayed through the discrete-event simulator, so that it is
//! charged to the network model by its encoded size, in the order and at
//! the times the schedule allows.
//!
//! The replay actor of a node, per round: compute (the composite round's
//! final composition), send its messages of the round, then wait until all
//! messages the round brings it have arrived, charging each one's merge
//! cost on arrival; then the next round. A message for a later round that
//! arrives early waits in the inbox counters, as it would on the cluster.
//!
//! Compute costs come from the node's [`CostProfile`]: a segment sent in
//! lists costs its sender `per_segment_sent` (encoding) and its receiver
//! `per_segment_received` (decoding and merging), both measured by `pvrsim
//! calibrate` on a binary swap of the built-in mesh; a profile without them
//! (the shipped ones) charges nothing for encoding and one segment
//! insertion (`per_segment`) for a merge. Compositing a region = one list
//! walk per pixel (`per_list_walked`) plus one list entry per segment held
//! (`per_list_entry_walked`); pasting a gathered pixel = `per_list_walked`
//! (stated, not measured).

use std::collections::BTreeMap;

use crate::compositor::codec::Codec as ListCodec;
use crate::compositor::Strategy;
use crate::compositor::{CompositeStats, ExecOptions, LocalRun, Payload, RegionLists, RoundKind};
use crate::image::Image;
use crate::net::{
    Action, Activity, Actor, Event, MessageKind, NetworkModel, NodeId, SimOptions, SimReport,
    Simulation,
};
use crate::node::CostProfile;

/// One round of one node in the replay.
#[derive(Debug, Clone, Default)]
pub(crate) struct RoundPlan {
    /// Compute before the round's sends.
    pub before: f64,
    /// `(to, bytes, kind)` of the round's messages.
    pub sends: Vec<(usize, usize, MessageKind)>,
    /// Messages the round brings this node.
    pub expect: usize,
}

/// What phase 2 produced.
#[derive(Debug)]
pub struct Phase2 {
    /// The final image at rank 0.
    pub image: Image,
    /// The compositor's counters (bytes per round, with and without the codec).
    pub stats: CompositeStats,
    /// The replay (virtual clock): end time, trace and traffic.
    pub sim: SimReport,
    /// Payload bytes each node sent in phase 2.
    pub bytes_sent: Vec<u64>,
    /// Modelled compositing compute seconds per node.
    pub busy_s: Vec<f64>,
}

struct Replay {
    rounds: Vec<RoundPlan>,
    costs: BTreeMap<(u32, u32), f64>,
    got: Vec<usize>,
    cur: usize,
}

impl Replay {
    fn enter(&mut self, out: &mut Vec<Action>) {
        loop {
            let Some(r) = self.rounds.get(self.cur) else {
                out.push(Action::Stop);
                return;
            };
            if r.before > 0.0 {
                out.push(Action::Compute {
                    seconds: r.before,
                    activity: Activity::Composite,
                });
            }
            for &(to, len, kind) in &r.sends {
                let mut payload = vec![0u8; len.max(4)];
                payload[..4].copy_from_slice(&(self.cur as u32).to_le_bytes());
                out.push(Action::Send {
                    to: NodeId::from(to),
                    kind,
                    payload,
                });
            }
            if self.got[self.cur] < r.expect {
                return;
            }
            self.cur += 1;
        }
    }
}

impl Actor for Replay {
    fn handle(&mut self, _now: f64, event: Event) -> Vec<Action> {
        let mut out = Vec::new();
        match event {
            Event::Start => self.enter(&mut out),
            Event::Wake(_) => {}
            Event::Message(env) => {
                let mut b = [0u8; 4];
                b.copy_from_slice(&env.payload[..4]);
                let r = u32::from_le_bytes(b);
                let cost = self.costs.get(&(r, env.from.0)).copied().unwrap_or(0.0);
                if let Some(g) = self.got.get_mut(r as usize) {
                    *g += 1;
                }
                out.push(Action::Compute {
                    seconds: cost,
                    activity: Activity::Composite,
                });
                if self.cur == r as usize && self.got[self.cur] >= self.rounds[self.cur].expect {
                    self.cur += 1;
                    self.enter(&mut out);
                }
            }
        }
        out
    }
}

/// Runs phase 2 over the nodes' canonical lists: the image (really
/// composited, every message encoded and decoded) and, with `model`, the
/// replay of its messages on the simulated network.
pub fn run(
    strategy: &dyn Strategy,
    codec: &dyn ListCodec,
    lists: Vec<RegionLists>,
    opts: ExecOptions,
    profile: &CostProfile,
    model: &NetworkModel,
    record_trace: bool,
) -> anyhow::Result<Phase2> {
    let n = lists.len();
    let mut run = LocalRun::new(strategy, codec, lists, opts)?;
    let mut plan = ReplayPlan::new(n, run.schedule().rounds.len());
    let mut r = 0usize;
    while let Some(round) = run.next_round() {
        crate::base::cancel::checkpoint();
        if round.kind == RoundKind::Composite {
            for k in 0..n {
                if let Some((px, segs)) = run.held(k) {
                    plan.composite(r, k, px, segs, profile);
                }
            }
        }
        let msgs = run.outgoing()?;
        for m in &msgs {
            plan.message(r, m.from, m.to, m.what, m.bytes.len(), m.raw_bytes, profile);
        }
        run.deliver(msgs)?;
        r += 1;
    }
    let (image, stats) = run.finish()?;
    let (sim, bytes_sent, busy_s) = plan.run(model, record_trace)?;
    Ok(Phase2 {
        image,
        stats,
        sim,
        bytes_sent,
        busy_s,
    })
}

/// Replays per-node round plans (and per-message merge costs, keyed by
/// `(round, sender)`) on the simulated network: the phase-2 timeline of
/// any partial kind.
pub(crate) fn replay(
    plans: Vec<Vec<RoundPlan>>,
    costs: Vec<BTreeMap<(u32, u32), f64>>,
    model: &NetworkModel,
    record_trace: bool,
) -> anyhow::Result<SimReport> {
    let actors: Vec<Replay> = plans
        .into_iter()
        .zip(costs)
        .map(|(rounds, costs)| Replay {
            got: vec![0; rounds.len()],
            rounds,
            costs,
            cur: 0,
        })
        .collect();
    let sim = Simulation::new(model.clone(), actors)
        .with_options(SimOptions {
            record_trace,
            ..Default::default()
        })
        .run()?;
    anyhow::ensure!(
        sim.unfinished().is_empty(),
        "phase-2 replay deadlocked: ranks {:?} never finished",
        sim.unfinished()
    );
    Ok(sim)
}

/// The replay of a phase 2 on the network model, built message by message
/// (from an in-process run, or from the logs of ranks that ran it over a
/// real transport), with the compute costs of the module docs.
#[derive(Debug, Clone)]
pub struct ReplayPlan {
    plans: Vec<Vec<RoundPlan>>,
    costs: Vec<BTreeMap<(u32, u32), f64>>,
    bytes_sent: Vec<u64>,
    busy: Vec<f64>,
}

impl ReplayPlan {
    /// An empty plan for `n` ranks and `rounds` rounds.
    pub fn new(n: usize, rounds: usize) -> ReplayPlan {
        ReplayPlan {
            plans: vec![vec![RoundPlan::default(); rounds]; n],
            costs: vec![BTreeMap::new(); n],
            bytes_sent: vec![0; n],
            busy: vec![0.0; n],
        }
    }

    /// Rank `k` composites `px` pixels holding `segs` list entries in round `r`.
    pub fn composite(&mut self, r: usize, k: usize, px: usize, segs: usize, profile: &CostProfile) {
        let c = px as f64 * profile.per_list_walked + segs as f64 * profile.per_list_entry_walked;
        self.plans[k][r].before += c;
        self.busy[k] += c;
    }

    /// A message of round `r`: `len` encoded bytes, `raw_bytes` under the raw codec.
    #[allow(clippy::too_many_arguments)]
    pub fn message(
        &mut self,
        r: usize,
        from: usize,
        to: usize,
        what: Payload,
        len: usize,
        raw_bytes: u64,
        profile: &CostProfile,
    ) {
        let (mk, cost) = match what {
            Payload::Lists(rect) => {
                let px = rect.width() as u64 * rect.height() as u64;
                let segs = crate::compositor::codec::raw_lists_segments(raw_bytes, px) as f64;
                let encode = segs * profile.per_segment_sent;
                self.plans[from][r].before += encode;
                self.busy[from] += encode;
                let merge = if profile.per_segment_received > 0.0 {
                    profile.per_segment_received
                } else {
                    profile.per_segment
                };
                (MessageKind::Segments, segs * merge)
            }
            Payload::Pixels(rect) => {
                let px = rect.width() as f64 * rect.height() as f64;
                (MessageKind::Image, px * profile.per_list_walked)
            }
        };
        self.plans[from][r].sends.push((to, len, mk));
        self.plans[to][r].expect += 1;
        self.costs[to].insert((r as u32, from as u32), cost);
        self.bytes_sent[from] += len as u64;
        self.busy[to] += cost;
    }

    /// Replays the plan on `model`: the simulation, payload bytes sent and
    /// modelled compute seconds per rank.
    pub fn run(
        self,
        model: &NetworkModel,
        record_trace: bool,
    ) -> anyhow::Result<(SimReport, Vec<u64>, Vec<f64>)> {
        let sim = replay(self.plans, self.costs, model, record_trace)?;
        Ok((sim, self.bytes_sent, self.busy))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::base::Rect;

    /// One lists message of 3 segments over 2 pixels from rank 0 to 1.
    fn busy_of(profile: &CostProfile) -> Vec<f64> {
        let rect = Rect {
            x0: 0,
            y0: 0,
            x1: 2,
            y1: 1,
        };
        let mut plan = ReplayPlan::new(2, 1);
        let raw = 24 + 4 * 2 + 24 * 3;
        assert_eq!(crate::compositor::codec::raw_lists_segments(raw, 2), 3);
        plan.message(0, 0, 1, Payload::Lists(rect), 40, raw, profile);
        plan.run(&NetworkModel::ideal(), false).unwrap().2
    }

    #[test]
    fn lists_cost_their_sender_encoding_and_their_receiver_merging() {
        let p = CostProfile {
            per_segment: 1.0,
            per_segment_sent: 2.0,
            per_segment_received: 5.0,
            ..Default::default()
        };
        assert_eq!(busy_of(&p), vec![6.0, 15.0]);
        // Shipped profiles (no phase-2 terms): a merge is an insertion,
        // encoding is free, as before the terms existed.
        let old = CostProfile {
            per_segment: 1.0,
            ..Default::default()
        };
        assert_eq!(busy_of(&old), vec![0.0, 3.0]);
    }
}
