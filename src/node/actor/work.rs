//! A node's own work in phase 1: scanning chunks up to the next ERT update
//! point, sharing its table with the manager's shards, the release share,
//! and the sends and failures they make.

use super::{NodeActor, SCAN};
use crate::net::{Action, Activity, Message, NodeId};
use crate::node::protocol::{Control, ErtReply, ErtShare, WorkRequest};
use crate::node::{compute_time, OpCounts};

impl NodeActor {
    pub(super) fn secs(&self, ops: &OpCounts) -> f64 {
        compute_time(ops, &self.profile)
    }

    pub(super) fn send<M: Message>(&mut self, out: &mut Vec<Action>, to: usize, m: &M) {
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

    pub(super) fn fail(&mut self, out: &mut Vec<Action>, e: String) {
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
    pub(super) fn scan(&mut self, t: f64, out: &mut Vec<Action>) {
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
    pub(super) fn share_with(&mut self, shard: usize, out: &mut Vec<Action>) -> f64 {
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
    pub(super) fn send_release(&mut self, out: &mut Vec<Action>) -> f64 {
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
}
