//! [`NodeActor`]: phase 1 of one cluster node as a [`crate::net::Actor`].
//!
//! ```text
//! Start / Wake(SCAN) → step(chunk) up to the next ERT update point     Compute(Scan)
//!                      at an update point: update_table               Compute(Scan)
//!                        with sharing: Send(ErtShare) and go on (weak sharing)
//!                        with DLB, no sharing: Send(Progress) every few chunks
//!                      cells left: Wake(SCAN); none: Send(WorkRequest), wait
//!                        with overlap sharing: Send(ErtReply) to each peer (no manager)
//! ErtReply           → apply_shared (from the manager or a peer)     Compute(Share)
//! WorkForward        → give(1/3, or the help fraction of the nearest cells):
//!                      cells with vertices, or ids with replicated data;
//!                      Send(WorkGrant) to the requester,
//!                      Send(Gave) to the manager                      Compute(Steal)
//! WorkGrant          → take_grant, resume scanning                    Compute(Steal)
//! Finish             → Stop
//! ```
//!
//! Messages are read between chunks only (the driver's inbox semantics), so
//! a reply that arrives mid-chunk is applied before the next chunk. Every
//! compute is charged by the [`CostProfile`] from the operation counts of the
//! work really done. A message that fails to decode is recorded as an error
//! ([`NodeStats::error`]), reported to the manager with [`Control::Abort`]
//! (which ends phase 1 for everyone) and the node stops: no panic.

use crate::manager::protocol::{Control, ErtReply, ErtShare, WorkForward, WorkGrant, WorkRequest};
use crate::net::{Action, Activity, Actor, Codec, Envelope, Event, Message, MessageKind, NodeId};
use crate::node::shard_map::ShardMap;
use crate::node::{compute_time, CostProfile, NodeRenderer, OpCounts, SharedTable};

const SCAN: u64 = 1;

/// How the nodes of a run pace their work, share and give cells.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NodePolicy {
    /// Most cells per chunk (the inbox is polled between chunks; an ERT
    /// update point also ends a chunk).
    pub chunk: usize,
    /// Fraction of its unprocessed cells a donor gives (the paper: 1/3).
    pub give_fraction: f64,
    /// Fewest unprocessed cells a donor keeps giving from (below: refuse).
    pub min_grant: usize,
    /// With DLB and no sharing: send a progress report every this many chunks.
    pub progress_every: u32,
    /// Most shares a node keeps in flight to the manager (sent, reply not
    /// yet back); 0 = no limit, the paper's protocol.
    pub share_window: u32,
    /// Front-first help (with DLB and per-pixel sharing), as a fraction of
    /// the frame's depth range (0: off): shares ask the manager for the
    /// nearest cells of the node with the nearest depth frontier, which the
    /// manager grants when this node's frontier lies more than this behind.
    pub help_gap: f32,
    /// Front-first help: fraction of its unprocessed cells a donor gives
    /// (the nearest ones).
    pub help_fraction: f64,
    /// Release ordering ([`crate::node::release`], with per-pixel sharing):
    /// block edge in pixels; 0: off (nearest-first order).
    pub release_block: u32,
    /// Release ordering: how long (fraction of the frame) a cell waits
    /// after the nodes in front of it start covering its blocks.
    pub release_lag: f32,
}

impl Default for NodePolicy {
    /// Chunks of 100 cells, the paper's third, grants from 3 cells, a
    /// progress report every chunk, one share in flight.
    fn default() -> Self {
        NodePolicy {
            chunk: 100,
            give_fraction: 1.0 / 3.0,
            min_grant: 3,
            progress_every: 1,
            share_window: 1,
            help_gap: 0.0,
            help_fraction: 0.25,
            release_block: 0,
            release_lag: 0.0,
        }
    }
}

/// How a node works in phase 1.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NodeConfig {
    /// The node's rank.
    pub rank: usize,
    /// The manager's rank.
    pub manager: usize,
    /// Weak sharing of ERT tables through the manager.
    pub share: bool,
    /// Dynamic load balancing.
    pub dlb: bool,
    /// Pacing and work-giving knobs, the same for every node of a run.
    pub policy: NodePolicy,
}

/// What a node did in phase 1 (times are the driver's: virtual or wall).
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct NodeStats {
    /// End of the node's last scan chunk: its scan-conversion time `Tsc`.
    pub tsc_s: f64,
    /// Seconds of scan conversion (chunks and ERT updates).
    pub scan_s: f64,
    /// Of which ERT table updates.
    pub update_s: f64,
    /// Seconds applying the manager's tables.
    pub share_s: f64,
    /// Seconds packing and unpacking stolen cells.
    pub steal_s: f64,
    /// Cells placed on the node at the start.
    pub cells_initial: u64,
    /// Cells given away (DLB).
    pub cells_given: u64,
    /// Cells taken from others (DLB).
    pub cells_taken: u64,
    /// Global schedule ([`crate::node::schedule`]): cells of this node's
    /// placement part dealt to other nodes for the frame (nothing travels).
    #[serde(default)]
    pub cells_scheduled_out: u64,
    /// Global schedule: cells of other nodes' parts dealt to this node.
    #[serde(default)]
    pub cells_scheduled_in: u64,
    /// Global schedule: leaves keyed at the start (0: no schedule computed).
    #[serde(default)]
    pub schedule_keyed: u64,
    /// Global schedule: the placement's stacking along the view
    /// ([`crate::node::schedule::stacking`]), which decides whether the
    /// schedule computed is applied.
    #[serde(default)]
    pub schedule_stacking: f64,
    /// Global schedule: applied (else the node scans its placement part).
    #[serde(default)]
    pub schedule_applied: bool,
    /// Tables sent to the manager.
    pub shares_sent: u64,
    /// Replies applied.
    pub replies_applied: u64,
    /// Work requests sent.
    pub requests_sent: u64,
    /// Payload bytes sent, all kinds.
    pub bytes_sent: u64,
    /// Payload bytes sent per kind (`MessageKind::name`).
    pub bytes_sent_by_kind: std::collections::BTreeMap<String, u64>,
    /// The first error, if the node failed.
    pub error: Option<String>,
}

/// One node of phase 1. See the module docs.
#[derive(Debug)]
pub struct NodeActor {
    cfg: NodeConfig,
    codec: Codec,
    profile: CostProfile,
    renderer: NodeRenderer,
    waiting: bool,
    done: bool,
    grants_taken: u32,
    chunks_since_progress: u32,
    /// Per sender, the latest table received while out of cells, applied
    /// only if cells arrive (a sender's table only improves — the manager's
    /// merge, or a peer's own entries — so its latest supersedes).
    deferred: Vec<(usize, SharedTable)>,
    /// Overlap sharing: the ranks this node sends its table to directly.
    peers: Vec<usize>,
    /// Per manager shard (shard 0: the manager), shares sent whose replies
    /// have not come back yet.
    in_flight: Vec<u32>,
    /// A front-first help request is out (cleared by any grant).
    help_pending: bool,
    /// The release share is out, its reply not applied yet.
    release_pending: bool,
    /// The unprocessed count the manager last heard from this node.
    reported: u64,
    /// Global schedule ([`crate::node::schedule`]): leaves this node keys
    /// at Start to compute the frame's schedule (0: no schedule).
    keyed: u64,
    stats: NodeStats,
}

impl NodeActor {
    /// A node over `renderer`, which already holds its initial cells.
    pub fn new(
        cfg: NodeConfig,
        renderer: NodeRenderer,
        profile: CostProfile,
        codec: Codec,
        cells_initial: u64,
    ) -> NodeActor {
        let mut renderer = renderer;
        if cfg.share && cfg.policy.release_block > 0 {
            renderer.enable_release(cfg.policy.release_block, cfg.policy.release_lag);
        }
        NodeActor {
            cfg,
            codec,
            profile,
            renderer,
            waiting: false,
            done: false,
            grants_taken: 0,
            chunks_since_progress: 0,
            deferred: Vec::new(),
            peers: Vec::new(),
            in_flight: vec![0],
            help_pending: false,
            release_pending: false,
            reported: u64::MAX,
            keyed: 0,
            stats: NodeStats {
                cells_initial,
                ..Default::default()
            },
        }
    }

    /// Overlap sharing (no manager for ERT): at every update point, send the
    /// local table straight to `peers` as an [`ErtReply`]; they merge it with
    /// the same per-entry rule as the manager's. Empty (the default): off.
    pub fn set_peers(&mut self, peers: Vec<usize>) {
        self.peers = peers;
    }

    /// Per-pixel sharing with a sharded manager ([`ShardMap`]): shard `s`
    /// is rank `manager + s`; at each update point the node sends each
    /// shard owning a tile under its footprint the changed pixels of its
    /// tiles (shard 0 always: the load report travels with it), each shard
    /// with its own share window. Call before the run; `K = 1` (the
    /// default) is the unsharded protocol.
    pub fn set_manager_shards(&mut self, map: ShardMap) {
        self.renderer.set_manager_shards(map);
        self.in_flight = vec![0; map.count()];
    }

    /// Global schedule ([`crate::node::schedule`]): at Start the node keys
    /// `w.keyed` leaves to compute the frame's schedule itself (charged as
    /// [`OpCounts::units_keyed`]); if `applied`, the schedule dealt
    /// `w.given[rank]` cells of its placement part to others and
    /// `w.received[rank]` cells of theirs to it. No message carries them:
    /// every node holds the mesh and computes the same schedule, and the
    /// node's cells (from [`NodeActor::new`]'s renderer) are already the
    /// scheduled ones.
    pub fn set_schedule(&mut self, w: &crate::node::schedule::WaveSchedule, applied: bool) {
        let k = self.cfg.rank;
        self.keyed = w.keyed;
        self.stats.schedule_keyed = w.keyed;
        self.stats.schedule_stacking = w.stacking;
        self.stats.schedule_applied = applied;
        if applied {
            self.stats.cells_scheduled_out += w.given[k];
            self.stats.cells_scheduled_in += w.received[k];
        }
    }

    /// The ranks this node shares its table with directly (overlap sharing).
    pub fn peers(&self) -> &[usize] {
        &self.peers
    }

    /// The renderer (lists, counters).
    pub fn renderer(&self) -> &NodeRenderer {
        &self.renderer
    }

    /// Takes the renderer out (for phase 2), leaving an empty one behind.
    pub fn into_renderer(self) -> NodeRenderer {
        self.renderer
    }

    /// What the node did.
    pub fn stats(&self) -> &NodeStats {
        &self.stats
    }

    fn secs(&self, ops: &OpCounts) -> f64 {
        compute_time(ops, &self.profile)
    }

    fn send<M: Message>(&mut self, out: &mut Vec<Action>, to: usize, m: &M) {
        match Action::send(&self.codec, NodeId::from(to), m) {
            Ok(a) => {
                if let Action::Send { payload, kind, .. } = &a {
                    self.stats.bytes_sent += payload.len() as u64;
                    *self
                        .stats
                        .bytes_sent_by_kind
                        .entry(kind.name().to_string())
                        .or_default() += payload.len() as u64;
                }
                out.push(a);
            }
            Err(e) => self.fail(out, format!("encoding a message to rank {to}: {e}")),
        }
    }

    fn fail(&mut self, out: &mut Vec<Action>, e: String) {
        if self.stats.error.is_none() {
            self.stats.error = Some(e);
        }
        if !self.done {
            self.done = true;
            if let Ok(a) =
                Action::send(&self.codec, NodeId::from(self.cfg.manager), &Control::Abort)
            {
                out.push(a);
            }
            out.push(Action::Stop);
        }
    }

    /// One chunk of scan conversion, starting at local time `t`.
    fn scan(&mut self, t: f64, out: &mut Vec<Action>) {
        let mut t = t;
        if self.renderer.remaining() > 0 {
            let r = self.renderer.step(self.cfg.policy.chunk.max(1));
            let s = self.secs(&r.ops);
            out.push(Action::Compute {
                seconds: s,
                activity: Activity::Scan,
            });
            t += s;
            self.stats.scan_s += s;
            if r.update_due {
                let ops = self.renderer.update_table();
                let s = self.secs(&ops);
                out.push(Action::Compute {
                    seconds: s,
                    activity: Activity::Scan,
                });
                t += s;
                self.stats.scan_s += s;
                self.stats.update_s += s;
                // Shares from a node with less than a chunk left would
                // reach the others after their own last chunks, and the
                // schedule's updates crowd there (every remaining / C
                // cells): they would only queue at the manager, ahead of
                // the work requests. So with a share window a node shares
                // only with at least a chunk left and at most `share_window`
                // shares in flight (its table keeps improving meanwhile; the
                // next share carries it). Window 0: the paper's protocol.
                let window = self.cfg.policy.share_window;
                let worth_sharing =
                    window == 0 || self.renderer.remaining() >= self.cfg.policy.chunk.max(1);
                if self.cfg.share && worth_sharing {
                    // Per manager shard (one without sharding): the shards
                    // owning tiles under the footprint, each with room.
                    let touched = self
                        .renderer
                        .manager_shards_touched()
                        .unwrap_or_else(|| vec![true]);
                    for (shard, _) in touched.iter().enumerate().filter(|(_, &on)| on) {
                        if window == 0 || self.in_flight[shard] < window {
                            t += self.share_with(shard, out);
                        }
                    }
                } else if !self.cfg.share && !self.peers.is_empty() && worth_sharing {
                    let m = ErtReply {
                        table: self.renderer.local_table().encode(),
                    };
                    self.stats.shares_sent += 1;
                    for k in 0..self.peers.len() {
                        self.send(out, self.peers[k], &m);
                    }
                }
            }
            self.stats.tsc_s = t;
            self.chunks_since_progress += 1;
            let rem = self.renderer.remaining() as u64;
            // With sharing, the shares carry the count; but a node stops
            // sharing with less than a chunk left or a full window, and a
            // stale count makes the manager pick donors that have nothing
            // left (refused forwards: 135 of 226 at 256 nodes on view B).
            // So it also reports whenever its count fell by a quarter since
            // the manager last heard it: a few small messages per node.
            let stale = self.cfg.share && rem * 4 <= self.reported.saturating_mul(3);
            if self.cfg.dlb
                && (!self.cfg.share || stale)
                && rem > 0
                && self.chunks_since_progress >= self.cfg.policy.progress_every.max(1)
            {
                self.chunks_since_progress = 0;
                self.reported = rem;
                let m = Control::Progress { remaining: rem };
                self.send(out, self.cfg.manager, &m);
            }
        }
        if self.renderer.remaining() > 0 {
            out.push(Action::Wake(SCAN));
        } else if !self.waiting {
            self.waiting = true;
            self.stats.requests_sent += 1;
            let m = WorkRequest {
                grants_taken: self.grants_taken,
            };
            self.send(out, self.cfg.manager, &m);
        }
    }

    /// Sends manager shard `shard` (rank `manager + shard`) this node's ERT
    /// information for its tiles: per-pixel levels, a level delta or the
    /// local table by the run's mode; the load report and a help request
    /// ride with shard 0's. Returns the seconds charged for packing.
    fn share_with(&mut self, shard: usize, out: &mut Vec<Action>) -> f64 {
        self.in_flight[shard] += 1;
        let mut t = 0.0;
        let delta = self
            .renderer
            .take_pixel_levels(shard)
            .or_else(|| self.renderer.take_level_delta());
        let table = match delta {
            Some((bytes, ops)) => {
                let s = self.secs(&ops);
                out.push(Action::Compute {
                    seconds: s,
                    activity: Activity::Share,
                });
                t += s;
                self.stats.share_s += s;
                bytes
            }
            None => self.renderer.local_table().encode(),
        };
        let help =
            shard == 0 && self.cfg.policy.help_gap > 0.0 && self.cfg.dlb && !self.help_pending;
        self.help_pending |= help;
        let m = ErtShare {
            remaining: self.renderer.remaining() as u64,
            front: self.renderer.front_depth(),
            help,
            table,
        };
        self.stats.shares_sent += 1;
        if shard == 0 {
            self.reported = m.remaining;
        }
        self.send(out, self.cfg.manager + shard, &m);
        t
    }

    /// Release ordering, at the start: the node's release share goes to
    /// the manager as its first [`ErtShare`] (one share in flight); the
    /// first reply is the release map.
    /// Returns the seconds charged.
    fn send_release(&mut self, out: &mut Vec<Action>) -> f64 {
        let Some((bytes, ops)) = self.renderer.take_release_share() else {
            return 0.0;
        };
        let s = self.secs(&ops);
        out.push(Action::Compute {
            seconds: s,
            activity: Activity::Share,
        });
        self.stats.share_s += s;
        self.release_pending = true;
        self.in_flight[0] += 1;
        self.stats.shares_sent += 1;
        let m = ErtShare {
            remaining: self.renderer.remaining() as u64,
            front: self.renderer.front_depth(),
            help: false,
            table: bytes,
        };
        self.send(out, self.cfg.manager, &m);
        s
    }

    fn on_message(&mut self, now: f64, env: Envelope, out: &mut Vec<Action>) -> Result<(), String> {
        let err = |e: &dyn std::fmt::Display| format!("{} from {}: {e}", env.kind, env.from);
        match env.kind {
            MessageKind::ErtReply => {
                let m: ErtReply = env.decode(&self.codec).map_err(|e| err(&e))?;
                let from = env.from.index();
                if let Some(n) = from
                    .checked_sub(self.cfg.manager)
                    .and_then(|s| self.in_flight.get_mut(s))
                {
                    *n = n.saturating_sub(1);
                }
                if self.release_pending && env.from.index() == self.cfg.manager {
                    self.release_pending = false;
                    let ops = self.renderer.apply_release(&m.table).map_err(|e| err(&e))?;
                    let s = self.secs(&ops);
                    self.stats.share_s += s;
                    out.push(Action::Compute {
                        seconds: s,
                        activity: Activity::Share,
                    });
                    return Ok(());
                }
                if self.renderer.pixel_share_shape().is_some() {
                    // Per-pixel deltas: each carries only what changed, so
                    // none may be dropped; applied even while waiting.
                    let ops = self
                        .renderer
                        .apply_pixel_depths(&m.table)
                        .map_err(|e| err(&e))?;
                    let s = self.secs(&ops);
                    self.stats.share_s += s;
                    self.stats.replies_applied += 1;
                    out.push(Action::Compute {
                        seconds: s,
                        activity: Activity::Share,
                    });
                    return Ok(());
                }
                let t = SharedTable::decode(&m.table).map_err(|e| err(&e))?;
                let (nx, ny) = self.renderer.table_dims();
                if (t.nx as u32, t.ny as u32) != (nx, ny) {
                    return Err(format!(
                        "{} from {}: table of {}x{} entries, expected {nx}x{ny}",
                        env.kind, env.from, t.nx, t.ny
                    ));
                }
                if self.waiting {
                    let from = env.from.index();
                    match self.deferred.iter_mut().find(|(f, _)| *f == from) {
                        Some(slot) => slot.1 = t,
                        None => self.deferred.push((from, t)),
                    }
                    return Ok(());
                }
                let ops = self.renderer.apply_shared(&t).map_err(|e| err(&e))?;
                let s = self.secs(&ops);
                self.stats.share_s += s;
                self.stats.replies_applied += 1;
                out.push(Action::Compute {
                    seconds: s,
                    activity: Activity::Share,
                });
            }
            MessageKind::WorkRequest => {
                let m: WorkForward = env.decode(&self.codec).map_err(|e| err(&e))?;
                let rem = self.renderer.remaining();
                let fraction = if m.front {
                    self.cfg.policy.help_fraction
                } else {
                    self.cfg.policy.give_fraction
                };
                let k = (rem as f64 * fraction).floor() as usize;
                let cells = if rem >= self.cfg.policy.min_grant.max(1) && k > 0 {
                    let before = self.renderer.totals();
                    let unit = self.renderer.give(fraction, m.front);
                    let after = self.renderer.totals();
                    let ops = OpCounts {
                        work_cells_moved: after.work_cells_moved - before.work_cells_moved,
                        cell_ids_moved: after.cell_ids_moved - before.cell_ids_moved,
                        cells_tested: after.cells_tested - before.cells_tested,
                        cells_skipped_ert: after.cells_skipped_ert - before.cells_skipped_ert,
                        ..Default::default()
                    };
                    let s = self.secs(&ops);
                    self.stats.steal_s += s;
                    out.push(Action::Compute {
                        seconds: s,
                        activity: Activity::Steal,
                    });
                    let n = unit.len() as u64;
                    self.stats.cells_given += n;
                    // Every cell may have been skipped before giving
                    // (`NodeRenderer::give`): a DLB requester then gets no
                    // grant, as for a refusal (`Gave { cells: 0 }`); a
                    // help requester gets an empty one.
                    if n > 0 || m.front {
                        let g = WorkGrant {
                            unit: unit.encode(),
                        };
                        self.send(out, m.requester as usize, &g);
                    }
                    n
                } else {
                    if m.front {
                        // The helper is not waiting, but it must learn that
                        // nothing comes: an empty grant.
                        let g = WorkGrant {
                            unit: self.renderer.empty_grant().encode(),
                        };
                        self.send(out, m.requester as usize, &g);
                    }
                    0
                };
                self.reported = self.renderer.remaining() as u64;
                let report = Control::Gave {
                    to: m.requester,
                    cells,
                    remaining: self.renderer.remaining() as u64,
                    help: m.front,
                };
                self.send(out, self.cfg.manager, &report);
            }
            MessageKind::WorkGrant => {
                let m: WorkGrant = env.decode(&self.codec).map_err(|e| err(&e))?;
                self.help_pending = false;
                let (mut ops, n) = self.renderer.take_grant(&m.unit).map_err(|e| err(&e))?;
                if n == 0 {
                    return Ok(());
                }
                for (_, t) in std::mem::take(&mut self.deferred) {
                    ops.add(&self.renderer.apply_shared(&t).map_err(|e| err(&e))?);
                    self.stats.replies_applied += 1;
                }
                let s = self.secs(&ops);
                self.stats.steal_s += s;
                self.stats.cells_taken += n as u64;
                self.grants_taken += 1;
                out.push(Action::Compute {
                    seconds: s,
                    activity: Activity::Steal,
                });
                if self.waiting {
                    self.waiting = false;
                    self.scan(now + s, out);
                }
            }
            MessageKind::Control => {
                let m: Control = env.decode(&self.codec).map_err(|e| err(&e))?;
                match m {
                    Control::Finish => {
                        self.done = true;
                        out.push(Action::Stop);
                    }
                    other => return Err(format!("unexpected {other:?} from {}", env.from)),
                }
            }
            other => return Err(format!("unexpected {other} message from {}", env.from)),
        }
        Ok(())
    }
}

impl Actor for NodeActor {
    fn handle(&mut self, now: f64, event: Event) -> Vec<Action> {
        let mut out = Vec::new();
        if self.done {
            return out;
        }
        match event {
            Event::Start => {
                let mut s = 0.0;
                if self.keyed > 0 {
                    let ops = OpCounts {
                        units_keyed: self.keyed,
                        ..Default::default()
                    };
                    s = self.secs(&ops);
                    self.stats.steal_s += s;
                    out.push(Action::Compute {
                        seconds: s,
                        activity: Activity::Steal,
                    });
                }
                if self.cfg.share {
                    s += self.send_release(&mut out);
                }
                self.scan(now + s, &mut out)
            }
            Event::Wake(SCAN) => {
                if !self.waiting {
                    self.scan(now, &mut out)
                }
            }
            Event::Wake(_) => {}
            Event::Message(env) => {
                if let Err(e) = self.on_message(now, env, &mut out) {
                    self.fail(&mut out, e);
                }
            }
        }
        out
    }
}
