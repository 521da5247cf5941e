//! What a node does with each message of phase 1: shared tables, work
//! forwarded to it, grants, control.

use super::NodeActor;
use crate::net::{Action, Activity, Envelope, MessageKind};
use crate::node::protocol::{Control, ErtReply, WorkForward, WorkGrant};
use crate::node::{OpCounts, SharedTable};

impl NodeActor {
    /// Charges one applied ERT reply (`ops` of applying it) as share time.
    fn charge_reply(&mut self, ops: &OpCounts, out: &mut Vec<Action>) {
        let s = self.secs(ops);
        self.stats.share_s += s;
        self.stats.replies_applied += 1;
        out.push(Action::Compute {
            seconds: s,
            activity: Activity::Share,
        });
    }

    pub(super) fn on_message(
        &mut self,
        now: f64,
        env: Envelope,
        out: &mut Vec<Action>,
    ) -> Result<(), String> {
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
                    self.charge_reply(&ops, out);
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
                self.charge_reply(&ops, out);
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
