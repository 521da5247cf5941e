//! [`ManagerActor`]: the manager rank of phase 1.
//!
//! - **Weak ERT sharing.** On an [`ErtShare`] it merges the node's table
//!   into its own (per entry the minimum `deepest` among terminated entries,
//!   [`merge_into`]) and answers with the merged table. It never waits for
//!   anybody: each node exchanges at its own update points.
//! - **Load information.** The manager keeps, per node, the last
//!   unprocessed-cell count it heard: from [`ErtShare::remaining`], from
//!   [`Control::Progress`] (sent by nodes with DLB but without sharing), from
//!   [`Control::Gave`], and 0 on a [`WorkRequest`]. "The node with the most
//!   unprocessed cells" is the maximum of these (ties: the lowest rank); the
//!   counts may be stale, which costs at most a refused forward.
//! - **Dynamic load balancing.** A [`WorkRequest`] queues the node; the
//!   manager forwards the oldest waiting request to the busiest node that has
//!   at least `min_grant` cells and no forward pending. The donor sends the
//!   cells straight to the requester and reports [`Control::Gave`]; a donor
//!   with too few cells reports 0 and the request is queued again.
//! - **End of phase 1.** When every node is idle (its last request counted
//!   every grant sent to it) and no forward is pending, no cell is left
//!   anywhere: the manager sends [`Control::Finish`] to all nodes and stops.

use std::collections::VecDeque;

use super::protocol::{Control, ErtReply, ErtShare, WorkForward, WorkRequest};
use super::shard::serve_pixel_share;
use crate::net::{Action, Activity, Actor, Codec, Envelope, Event, MessageKind, NodeId};
use crate::node::levels::{BlockGrid, LevelDelta, LevelStore};
use crate::node::manager_table::merge_into;
use crate::node::pixel_share::PixelStore;
use crate::node::release::{ReleaseShare, ReleaseStore};
use crate::node::shard_map::ShardMap;
use crate::node::{CostProfile, SharedTable};

/// Fewest initial cells per node (mean) for front-first help: with thinner
/// pieces a help grant moves about as many cells as it lets be skipped.
/// Measured on aorta view B (`pvrsim cluster ../shared/data/aorta-view-b.toml
/// --nodes N --ert 0.9 --share --dlb [--help-gap 0]`, docs/experiments/cluster.md):
/// at 64 nodes (4,777 cells each) help is faster (2.041 s vs 2.074 s), at
/// 256 (1,194 each) slower (0.797 s vs 0.668 s).
pub const HELP_MIN_CELLS_PER_NODE: u64 = 2_500;

/// How the manager works.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ManagerConfig {
    /// Number of nodes (ranks `0..nodes`; the manager is rank `nodes`).
    pub nodes: usize,
    /// ERT table shape `(nx, ny)`.
    pub table_dims: (u16, u16),
    /// Dynamic load balancing on.
    pub dlb: bool,
    /// Smallest remaining count (as last heard) for a node to be asked to give.
    pub min_grant: u64,
    /// Level sharing ([`crate::node::levels`]): the block grid and level
    /// count; shares are then [`LevelDelta`]s. `None`: the paper's tables.
    pub levels: Option<(BlockGrid, usize)>,
    /// Per-pixel level sharing ([`crate::node::pixel_share`]): image width,
    /// height and level count; shares are then `PixelLevels` and replies
    /// the certified depths that changed. Takes precedence over `levels`.
    pub pixels: Option<(u32, u32, usize)>,
    /// Front-first help: a node asking for help (in its share) is sent the
    /// nearest cells of the node with the nearest depth frontier when its own
    /// frontier lies more than this depth behind it. `None`: off.
    pub help_gap: Option<f32>,
    /// Release ordering ([`crate::node::release`]): blocks per row and
    /// column. Each node's first share is then its release share; once all
    /// are in, every node gets its release map as its first reply.
    /// `None`: off.
    pub release: Option<(u32, u32)>,
}

/// What the manager did.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct ManagerStats {
    /// ERT tables merged.
    pub shares_merged: u64,
    /// Entries whose merged value got smaller.
    pub entries_improved: u64,
    /// Work requests received.
    pub requests: u64,
    /// Forwards sent to donors.
    pub forwards: u64,
    /// Forwards a donor refused (too few cells).
    pub refused: u64,
    /// Front-first help forwards sent (included in `forwards`).
    pub help_forwards: u64,
    /// Modelled seconds spent merging tables.
    pub busy_s: f64,
    /// Manager shards `K` (per-pixel sharing; 1: unsharded).
    pub shards: usize,
    /// Per shard, modelled seconds spent combining and replying (index 0:
    /// this manager's ERT work, `busy_s`; filled in by the driver).
    pub shard_busy_s: Vec<f64>,
    /// Per shard, shares served.
    pub shard_shares: Vec<u64>,
    /// When the manager sent `Finish` (end of phase 1).
    pub finish_at: Option<f64>,
    /// First protocol error seen, if any.
    pub error: Option<String>,
}

/// The manager rank. See the module docs.
#[derive(Debug)]
pub struct ManagerActor {
    cfg: ManagerConfig,
    codec: Codec,
    profile: CostProfile,
    table: SharedTable,
    store: Option<LevelStore>,
    pixels: Option<PixelStore>,
    shards: ShardMap,
    release: Option<ReleaseStore>,
    remaining: Vec<u64>,
    /// Per node, `grants_taken` of its latest request (`None`: none yet).
    request_taken: Vec<Option<u32>>,
    /// Per node, non-empty grants the manager knows were sent to it.
    grants_to: Vec<u32>,
    /// Per node, a forward to it as donor is pending.
    asked: Vec<bool>,
    /// Per node, a forward on its behalf is pending.
    pending: Vec<bool>,
    /// Per node, a front-first help forward on its behalf is pending.
    help_pending: Vec<bool>,
    /// Per node, the depth frontier it last reported (`+inf`: unknown or done).
    front: Vec<f32>,
    waiting: VecDeque<usize>,
    finished: bool,
    stats: ManagerStats,
}

impl ManagerActor {
    /// A manager for `cfg.nodes` nodes whose initial unprocessed-cell counts
    /// are `initial` (the placement is decided before the run, so the
    /// manager knows it); merging costs `per_shared_entry` of `profile` per
    /// entry.
    pub fn new(
        cfg: ManagerConfig,
        initial: Vec<u64>,
        profile: CostProfile,
        codec: Codec,
    ) -> ManagerActor {
        let n = cfg.nodes;
        let mut remaining = initial;
        remaining.resize(n, 0);
        // Front-first help scales with the pieces: below
        // HELP_MIN_CELLS_PER_NODE cells per node it moves more than it
        // saves (measured, see the constant), so it is off.
        let mean = remaining.iter().sum::<u64>() / n.max(1) as u64;
        let mut cfg = cfg;
        if mean < HELP_MIN_CELLS_PER_NODE {
            cfg.help_gap = None;
        }
        ManagerActor {
            table: SharedTable::empty(cfg.table_dims.0, cfg.table_dims.1),
            store: cfg.levels.map(|(g, l)| LevelStore::new(g, l, n)),
            pixels: cfg.pixels.map(|(w, h, l)| PixelStore::new(w, h, l, n)),
            shards: ShardMap::single(),
            release: cfg.release.map(|d| ReleaseStore::new(d, n)),
            cfg,
            codec,
            profile,
            remaining,
            request_taken: vec![None; n],
            grants_to: vec![0; n],
            asked: vec![false; n],
            pending: vec![false; n],
            help_pending: vec![false; n],
            front: vec![f32::NEG_INFINITY; n],
            waiting: VecDeque::new(),
            finished: false,
            stats: ManagerStats {
                shards: 1,
                ..Default::default()
            },
        }
    }

    /// Shards the per-pixel store by screen tile ([`ShardMap`]): this
    /// manager keeps shard 0 and ends phase 1 for shards `1..K` too (ranks
    /// `nodes + 1 ..`, [`super::ShardActor`]s). Call before the run.
    pub fn set_shards(&mut self, map: ShardMap) {
        self.shards = map;
        self.stats.shards = map.count();
    }

    /// Records, after the run, what shards `1..K` did beside this manager's
    /// own ERT work (shard 0) in [`ManagerStats::shard_busy_s`] and
    /// [`ManagerStats::shard_shares`].
    pub fn record_shards<'a>(&mut self, shards: impl Iterator<Item = &'a super::ShardStats>) {
        self.stats.shard_busy_s = vec![self.stats.busy_s];
        self.stats.shard_shares = vec![self.stats.shares_merged];
        for s in shards {
            self.stats.shard_busy_s.push(s.busy_s);
            self.stats.shard_shares.push(s.shares_merged);
        }
    }

    /// What the manager did.
    pub fn stats(&self) -> &ManagerStats {
        &self.stats
    }

    /// The merged table.
    pub fn table(&self) -> &SharedTable {
        &self.table
    }

    fn idle(&self, j: usize) -> bool {
        self.request_taken[j] == Some(self.grants_to[j])
    }

    fn send<M: crate::net::Message>(&mut self, out: &mut Vec<Action>, to: usize, m: &M) {
        match Action::send(&self.codec, NodeId::from(to), m) {
            Ok(a) => out.push(a),
            Err(e) => self.fail(format!("encoding a message to node {to}: {e}")),
        }
    }

    fn fail(&mut self, e: String) {
        if self.stats.error.is_none() {
            self.stats.error = Some(e);
        }
    }

    fn on_message(&mut self, env: Envelope, out: &mut Vec<Action>) -> Result<(), String> {
        let j = env.from.index();
        if j >= self.cfg.nodes {
            // A shard reports an error (it stops on our Finish).
            if j < self.cfg.nodes + self.shards.count() && env.kind == MessageKind::Control {
                let m: Control = env.decode(&self.codec).map_err(|e| e.to_string())?;
                if m == Control::Abort {
                    return Err(format!("manager shard {} aborted", j - self.cfg.nodes));
                }
            }
            return Err(format!("message from unknown rank {}", env.from));
        }
        match env.kind {
            MessageKind::ErtShare => {
                let m: ErtShare = env.decode(&self.codec).map_err(|e| e.to_string())?;
                if m.front.is_nan() {
                    return Err(format!("share from node {j} with a NaN frontier"));
                }
                self.front[j] = m.front;
                if let Some(rs) = self.release.as_mut().filter(|rs| !rs.has(j)) {
                    // Release ordering: node j's first share is its map.
                    let d = ReleaseShare::decode(&m.table, rs.dims()).map_err(|e| e.to_string())?;
                    let (mut work, all) = rs.put(j, d).map_err(|e| e.to_string())?;
                    let mut replies = Vec::new();
                    if all {
                        let (r, w) = rs.replies();
                        work += w;
                        replies = r;
                    }
                    let secs = work as f64 * self.profile.per_shared_entry;
                    self.stats.busy_s += secs;
                    self.remaining[j] = m.remaining;
                    out.push(Action::Compute {
                        seconds: secs,
                        activity: Activity::Share,
                    });
                    for (k, r) in replies.into_iter().enumerate() {
                        self.send(out, k, &ErtReply { table: r.encode() });
                    }
                    return Ok(());
                }
                if m.help {
                    self.help(j, out);
                }
                if let Some(store) = self.pixels.as_mut() {
                    let (reply, work) = serve_pixel_share(store, &self.shards, 0, j, &m.table)?;
                    let secs = work as f64 * self.profile.per_shared_entry;
                    self.stats.shares_merged += 1;
                    self.stats.entries_improved += reply.pixels.len() as u64;
                    self.stats.busy_s += secs;
                    self.remaining[j] = m.remaining;
                    out.push(Action::Compute {
                        seconds: secs,
                        activity: Activity::Share,
                    });
                    let reply = ErtReply {
                        table: reply.encode(),
                    };
                    self.send(out, j, &reply);
                    return Ok(());
                }
                let (improved, work) = match self.store.as_mut() {
                    Some(store) => {
                        let d = LevelDelta::decode(&m.table, store.grid())
                            .map_err(|e| e.to_string())?;
                        let before = self.table.clone();
                        let work = store
                            .apply(j, &d, &mut self.table)
                            .map_err(|e| e.to_string())?;
                        let improved = before
                            .deepest
                            .iter()
                            .zip(&self.table.deepest)
                            .filter(|(a, b)| b < a)
                            .count();
                        (improved, work)
                    }
                    None => {
                        let t = SharedTable::decode(&m.table).map_err(|e| e.to_string())?;
                        let improved =
                            merge_into(&mut self.table, &t).map_err(|e| e.to_string())?;
                        (improved, self.table.len() as u64)
                    }
                };
                let secs = work as f64 * self.profile.per_shared_entry;
                self.stats.shares_merged += 1;
                self.stats.entries_improved += improved as u64;
                self.stats.busy_s += secs;
                self.remaining[j] = m.remaining;
                out.push(Action::Compute {
                    seconds: secs,
                    activity: Activity::Share,
                });
                let reply = ErtReply {
                    table: self.table.encode(),
                };
                self.send(out, j, &reply);
            }
            MessageKind::WorkRequest => {
                let m: WorkRequest = env.decode(&self.codec).map_err(|e| e.to_string())?;
                self.stats.requests += 1;
                self.request_taken[j] = Some(m.grants_taken);
                self.remaining[j] = 0;
                self.front[j] = f32::INFINITY;
                if self.idle(j) && !self.pending[j] && !self.waiting.contains(&j) {
                    self.waiting.push_back(j);
                }
            }
            MessageKind::Control => {
                let m: Control = env.decode(&self.codec).map_err(|e| e.to_string())?;
                match m {
                    Control::Progress { remaining } => self.remaining[j] = remaining,
                    Control::Gave {
                        to,
                        cells,
                        remaining,
                        help,
                    } => {
                        let to = to as usize;
                        if to >= self.cfg.nodes {
                            return Err(format!("grant report names unknown node {to}"));
                        }
                        if help {
                            if !self.help_pending[to] {
                                return Err(format!(
                                    "help report from {j} for node {to}, none pending"
                                ));
                            }
                            self.asked[j] = false;
                            self.help_pending[to] = false;
                            self.remaining[j] = remaining;
                            if cells > 0 {
                                self.grants_to[to] += 1;
                                self.remaining[to] += cells;
                            } else {
                                self.stats.refused += 1;
                            }
                            return Ok(());
                        }
                        self.asked[j] = false;
                        self.pending[to] = false;
                        self.remaining[j] = remaining;
                        if cells > 0 {
                            self.grants_to[to] += 1;
                            self.remaining[to] = cells;
                        } else {
                            self.stats.refused += 1;
                        }
                        // Idle now: either refused, or its request counting
                        // this grant overtook the report.
                        if self.idle(to) && !self.waiting.contains(&to) {
                            self.waiting.push_front(to);
                        }
                    }
                    Control::Abort => {
                        self.fail(format!("node {j} aborted"));
                        self.finish(out);
                    }
                    Control::Finish => return Err(format!("node {j} sent Finish")),
                }
            }
            other => return Err(format!("unexpected {other} message from node {j}")),
        }
        Ok(())
    }

    fn dispatch(&mut self, out: &mut Vec<Action>) {
        if !self.cfg.dlb {
            return;
        }
        while let Some(&r) = self.waiting.front() {
            let donor = (0..self.cfg.nodes)
                .filter(|&d| d != r && !self.idle(d) && !self.asked[d] && !self.pending[d])
                .filter(|&d| self.remaining[d] >= self.cfg.min_grant)
                .max_by_key(|&d| (self.remaining[d], std::cmp::Reverse(d)));
            let Some(d) = donor else { break };
            self.waiting.pop_front();
            self.asked[d] = true;
            self.pending[r] = true;
            self.stats.forwards += 1;
            // Until the donor reports, assume it gives a third.
            self.remaining[d] -= self.remaining[d] / 3;
            self.send(
                out,
                d,
                &WorkForward {
                    requester: r as u32,
                    front: false,
                },
            );
        }
    }

    /// Front-first help for node `r`: forward to the node with the nearest
    /// frontier when `r`'s lies more than `help_gap` behind it.
    fn help(&mut self, r: usize, out: &mut Vec<Action>) {
        let Some(gap) = self.cfg.help_gap else { return };
        if !self.cfg.dlb || self.help_pending[r] || self.pending[r] {
            return;
        }
        let donor = (0..self.cfg.nodes)
            .filter(|&d| d != r && !self.idle(d) && !self.asked[d] && !self.help_pending[d])
            .filter(|&d| self.remaining[d] >= self.cfg.min_grant && self.front[d].is_finite())
            .min_by(|&a, &b| self.front[a].total_cmp(&self.front[b]).then(a.cmp(&b)));
        let Some(d) = donor else { return };
        if self.front[r] - self.front[d] <= gap {
            return;
        }
        self.asked[d] = true;
        self.help_pending[r] = true;
        self.stats.forwards += 1;
        self.stats.help_forwards += 1;
        self.remaining[d] -= self.remaining[d] / 3;
        self.send(
            out,
            d,
            &WorkForward {
                requester: r as u32,
                front: true,
            },
        );
    }

    fn finish(&mut self, out: &mut Vec<Action>) {
        if self.finished {
            return;
        }
        self.finished = true;
        for k in 0..self.cfg.nodes {
            self.send(out, k, &Control::Finish);
        }
        for s in 1..self.shards.count() {
            self.send(out, self.cfg.nodes + s, &Control::Finish);
        }
        out.push(Action::Stop);
    }
}

impl Actor for ManagerActor {
    fn handle(&mut self, now: f64, event: Event) -> Vec<Action> {
        let mut out = Vec::new();
        if self.finished {
            return out;
        }
        match event {
            Event::Start | Event::Wake(_) => {}
            Event::Message(env) => {
                if let Err(e) = self.on_message(env, &mut out) {
                    self.fail(e);
                    self.finish(&mut out);
                    return out;
                }
            }
        }
        self.dispatch(&mut out);
        let all_idle = (0..self.cfg.nodes).all(|j| self.idle(j));
        if all_idle && !self.asked.iter().any(|&a| a) && !self.finished {
            let t: f64 = out
                .iter()
                .map(|a| match a {
                    Action::Compute { seconds, .. } => *seconds,
                    _ => 0.0,
                })
                .sum();
            self.stats.finish_at = Some(now + t);
            self.finish(&mut out);
        }
        out
    }
}
