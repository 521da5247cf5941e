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
//! ([`NodeStats::error`]), reported to the manager with [`Control::Abort`](crate::node::protocol::Control::Abort)
//! (which ends phase 1 for everyone) and the node stops: no panic.
//!
//! Files: this one holds the actor's state and its event handler;
//! `config.rs` its configuration and counters; `work.rs` scanning, sharing
//! and the release share; `messages.rs` what it does with each message.

mod config;
mod messages;
mod work;

pub use config::{NodeConfig, NodePolicy, NodeStats};

use crate::net::{Action, Activity, Actor, Codec, Event};
use crate::node::shard_map::ShardMap;
use crate::node::{CostProfile, NodeRenderer, OpCounts, SharedTable};

const SCAN: u64 = 1;

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
    /// local table straight to `peers` as an [`ErtReply`](crate::node::protocol::ErtReply); they merge it with
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
