//! [`NodeRenderer`]: the scan-conversion phase of one cluster node, in
//! steps, with early ray termination on the paper's global `D x D` table.
//!
//! ## Model
//!
//! The node owns its cells as compact [`cells::NodeCell`]s over a table of
//! their projected vertices (built when a `WorkUnit` arrives: vertices
//! projected, empty and off-screen cells culled, exactly as the
//! single-machine binning does — the same function, `cell_record`; the
//! [`CellRecord`](crate::render::cell::bin::CellRecord) scan conversion
//! takes is rebuilt from them, `cells.rs`),
//! kept in processing order: front to back by `(nearest depth, cell id)` by
//! default, the order every tile of the single-machine renderer uses, or by
//! cell id ("stored"). Cells `[0, next)` are processed, `[next, len)` are not.
//! It owns whole-screen ray-segment lists (one list per pixel of the image).
//!
//! [`NodeRenderer::step`] processes cells in order: with ERT on, each cell is
//! first tested against the table (the paper tests only cells whose pixel
//! range fits in one entry, [`ErtSpan::Single`]; [`ErtSpan::Multi`] tests
//! all cells against every entry they cover; a local max-pyramid can be added
//! on top), then scan-converted into the lists. A step stops after
//! `max_cells` cells or at the next update point, whichever comes first.
//!
//! ## Update schedule and tables
//!
//! As on one machine ([`schedule`]): the table is rebuilt after every
//! `remaining / C` processed cells (at least one), `remaining` counted at
//! the previous update (or at the first step). [`NodeRenderer::update_point_reached`]
//! says when; the driver then calls [`NodeRenderer::update_table`] and, with
//! weak sharing, sends [`NodeRenderer::local_table`] to the manager and
//! applies its answer with [`NodeRenderer::apply_shared`]. The update walks
//! only the lists that changed since the last one (per-pixel termination
//! depths are cached and only ever decrease, so the paper's "temporarily
//! deeper `deepest`" cannot happen) and recomputes only the entries whose
//! pixels changed. Why merging the manager's table is safe: [`super::table`].
//!
//! ## Dynamic load balancing: which cells are given
//!
//! [`NodeRenderer::give_work`] gives the **last** `floor(remaining * fraction)`
//! unprocessed cells in processing order — with front-to-back order, the
//! farthest ones. Reasons: (1) the donor's own order stays intact, so its
//! ERT sees its front cells first, as without DLB; (2) the far cells are the
//! ones most likely to be skipped, and with weak sharing the receiver can
//! skip them against the donor's (and everyone's) terminated entries — the
//! donor has already scanned the front part of its piece when it gives;
//! (3) it is O(k) and needs no geometry. The cost: the receiver starts on
//! cells behind segments it does not hold, so without sharing it skips fewer
//! of them than the donor would have. A receiver merges the cells into its
//! own unprocessed cells, in its processing order.
//!
//! With replicated data ([`NodeRenderer::set_replica`]) the same cells are
//! given, as ids only ([`super::replica::IdUnit`]); the receiver builds
//! their records from its own copy of the mesh.
//!
//! The sharing structures live in `sharing.rs`, giving and taking cells in
//! `grant.rs`.
//!
//! ## Costs
//!
//! Every method that works returns or records [`OpCounts`]; the driver turns
//! them into simulated seconds with [`super::cost`]. Nothing here reads a
//! clock, spawns a thread or does I/O.

mod cells;
mod grant;
mod release;
mod sharing;

use std::sync::Arc;

pub use grant::Given;
use sharing::NodeLevels;
pub use sharing::{level_depths_counted, termination_depth_counted};

use super::ops::OpCounts;
use super::pixel_share::NodePixelLevels;
use super::replica::Replica;
use super::table::{NodeTable, SharedTable, TableError};
use crate::base::segment::Segment;
use crate::base::Rect;
use crate::render::cell::ert::pyramid::Pyramid;
use crate::render::cell::ert::schedule;
use crate::render::cell::ert::ErtMode;
use crate::render::cell::ert::{ErtSpan, ErtStructure};

use crate::render::cell::list::SegmentLists;
use crate::render::cell::project::{PerspRays, ProjectedVertices};
use crate::render::cell::{scan_cell, CellOrder, Integrator, PreparedTf};
use crate::render::cell::{Pending, ScanCounts, ScanTarget};
use crate::scene::View;

/// Early ray termination on a node.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NodeErt {
    /// On with its threshold, or off.
    pub mode: ErtMode,
    /// `D`: the table has `D x D` entries over the whole image.
    pub divisions: u32,
    /// Update constant `C`.
    pub update_c: u32,
    /// Which cells the table tests (`Single`: the paper).
    pub span: ErtSpan,
    /// `Pyramid` (default): cells are also tested against a per-pixel
    /// max-pyramid (the sequential renderer's best test), and weak sharing
    /// sends per-pixel opacity levels ([`super::pixel_share`]). `Flat`: the
    /// paper's `D x D` table only, and its per-entry sharing.
    pub structure: ErtStructure,
    /// Opacity levels `L` shared per block with weak sharing
    /// ([`super::levels`]); 1 with `share_sub = 1`: the paper's table.
    pub share_levels: u8,
    /// Blocks per entry axis shared with weak sharing ([`super::levels`]).
    pub share_sub: u8,
}

impl NodeErt {
    /// ERT off.
    pub const OFF: NodeErt = NodeErt {
        mode: ErtMode::Off,
        ..NodeErt::PAPER
    };

    /// The paper's setting: threshold 0.9, `D = 20`, `C = 100`, single-entry test.
    pub const PAPER: NodeErt = NodeErt {
        mode: ErtMode::On(0.9),
        divisions: 20,
        update_c: 100,
        span: ErtSpan::Single,
        structure: ErtStructure::Flat,
        share_levels: 1,
        share_sub: 1,
    };

    /// Whether ERT runs.
    pub fn enabled(&self) -> bool {
        self.mode.is_on()
    }

    /// The threshold (1 when off).
    pub fn threshold(&self) -> f32 {
        self.mode.threshold()
    }

    /// Whether weak sharing sends opacity levels per block
    /// ([`super::levels`]) instead of the paper's per-entry table (flat
    /// structure only).
    pub fn level_sharing(&self) -> bool {
        self.enabled()
            && self.structure == ErtStructure::Flat
            && (self.share_levels > 1 || self.share_sub > 1)
    }

    /// Whether weak sharing sends per-pixel opacity levels
    /// ([`super::pixel_share`]): the pyramid structure.
    pub fn pixel_sharing(&self) -> bool {
        self.enabled() && self.structure == ErtStructure::Pyramid
    }
}

/// Options of a node renderer.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NodeOptions {
    /// Segment integrator.
    pub integrator: Integrator,
    /// Partial composition on insertion.
    pub partial_composition: bool,
    /// Processing order.
    pub cell_order: CellOrder,
    /// Early ray termination.
    pub ert: NodeErt,
    /// Keep the lists in canonical form (see
    /// [`crate::base::canonical`]): with ERT off the cluster's image
    /// is then bit for bit `pvrsim render --canonical`'s, whatever the node
    /// count and placement. Off by default: on aorta-small view B, 8 nodes,
    /// it stores 4.4x the list entries and sends 3.5x the phase-2 bytes
    /// (`docs/experiments/cluster.md`).
    pub canonical: bool,
}

impl Default for NodeOptions {
    fn default() -> Self {
        NodeOptions {
            integrator: Integrator::Exact,
            partial_composition: true,
            cell_order: CellOrder::FrontToBack,
            ert: NodeErt::PAPER,
            canonical: false,
        }
    }
}

/// What one [`NodeRenderer::step`] did.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct StepReport {
    /// Operation counts.
    pub ops: OpCounts,
    /// Cells taken from the queue (tested, skipped or scanned).
    pub processed: usize,
    /// Unprocessed cells left.
    pub remaining: usize,
    /// Whether an update point has been reached (call `update_table`).
    pub update_due: bool,
}

/// One node's scan conversion. See the module docs.
#[derive(Debug, Clone)]
pub struct NodeRenderer {
    view: View,
    tf: PreparedTf,
    opts: NodeOptions,
    full: Rect,
    persp: Option<PerspRays>,
    /// Cells, processed ones first.
    records: Vec<cells::NodeCell>,
    next: usize,
    /// The vertices `records` index.
    verts: cells::VertexTable,
    lists: SegmentLists,
    /// Per pixel, cached termination depth (`+inf`: not terminated).
    depth: Vec<f32>,
    table: NodeTable,
    pyramid: Option<Pyramid>,
    since_update: usize,
    interval: Option<usize>,
    totals: OpCounts,
    levels: Option<NodeLevels>,
    pixel_levels: Option<NodePixelLevels>,
    /// Inclusive pixel range `[x0, x1, y0, y1]` of every cell ever held
    /// (`x0 > x1`: none).
    footprint: [u32; 4],
    /// Replicated data: the whole mesh; cells given and taken travel as
    /// ids ([`super::replica`]). `None`: partitioned, cells travel with
    /// their vertices.
    replica: Option<Arc<Replica>>,
    /// Cells skipped by ERT out of order, when a DLB donor tested the cells
    /// it was about to give (`grant.rs`): processed, not in `records`.
    pre_skipped: Vec<u32>,
    /// Release ordering ([`crate::node::release`]), if on.
    release: Option<release::Release>,
    /// The queue every step's scan target uses.
    pending: Box<Pending>,
}

impl NodeRenderer {
    /// A node rendering `view` with transfer function `tf`, no cells yet.
    pub fn new(view: View, tf: PreparedTf, opts: NodeOptions) -> NodeRenderer {
        let (w, h) = (view.width, view.height);
        let mut lists = SegmentLists::new(w, h);
        let ert = opts.ert.enabled();
        if ert {
            lists.track_changes();
        }
        let persp = ProjectedVertices::new_sequential(&view, &[], &[]);
        NodeRenderer {
            view,
            tf,
            opts,
            full: Rect {
                x0: 0,
                y0: 0,
                x1: w,
                y1: h,
            },
            persp: persp.perspective.then(|| persp.rays()),
            records: Vec::new(),
            next: 0,
            verts: cells::VertexTable::default(),
            lists,
            depth: if ert {
                vec![f32::INFINITY; (w * h) as usize]
            } else {
                Vec::new()
            },
            table: NodeTable::new(w, h, opts.ert.divisions),
            pyramid: (ert && opts.ert.structure == ErtStructure::Pyramid)
                .then(|| Pyramid::new(w, h, 1, 1)),
            since_update: 0,
            interval: None,
            totals: OpCounts::default(),
            levels: None,
            pixel_levels: None,
            footprint: [u32::MAX, 0, u32::MAX, 0],
            replica: None,
            pre_skipped: Vec::new(),
            release: None,
            pending: Box::default(),
        }
    }

    /// The options.
    pub fn options(&self) -> &NodeOptions {
        &self.opts
    }

    /// The view.
    pub fn view(&self) -> &View {
        &self.view
    }

    /// Nearest depth of the next unprocessed cell (`+inf`: none).
    pub fn front_depth(&self) -> f32 {
        self.records
            .get(self.next)
            .map_or(f32::INFINITY, |c| c.near)
    }

    /// The processing-order key of the next unprocessed cell.
    pub fn next_order_key(&self) -> Option<u64> {
        self.records.get(self.next).map(|c| c.order_key())
    }

    /// Per pixel, the cached termination depth as of the last table update:
    /// the node's own lists, and with per-pixel sharing also the manager's
    /// certified depths (`+inf`: not terminated; empty with ERT off).
    pub fn termination_depths(&self) -> &[f32] {
        &self.depth
    }

    /// Unprocessed cells.
    pub fn remaining(&self) -> usize {
        self.records.len() - self.next
    }

    /// Cells processed so far (tested, skipped or scanned).
    pub fn processed(&self) -> usize {
        self.next + self.pre_skipped.len()
    }

    /// Everything counted so far.
    pub fn totals(&self) -> OpCounts {
        self.totals
    }

    /// Cells to process before the next update point (`usize::MAX` without ERT).
    pub fn cells_until_update(&self) -> usize {
        if !self.opts.ert.enabled() {
            return usize::MAX;
        }
        let interval = self
            .interval
            .unwrap_or_else(|| schedule::interval(self.remaining(), self.opts.ert.update_c));
        interval.saturating_sub(self.since_update)
    }

    /// Whether the node should update its table now: ERT is on, cells are
    /// left, and `remaining / C` cells have been processed since the last update.
    pub fn update_point_reached(&self) -> bool {
        self.opts.ert.enabled() && self.remaining() > 0 && self.cells_until_update() == 0
    }

    /// Processes up to `max_cells` cells, stopping early at an update point.
    pub fn step(&mut self, max_cells: usize) -> StepReport {
        let ert = self.opts.ert;
        if ert.enabled() && self.interval.is_none() {
            self.interval = Some(schedule::interval(self.remaining(), ert.update_c));
        }
        let flat = self.flat_table();
        let limit = max_cells.min(self.cells_until_update());
        let end = self.next + limit.min(self.remaining());
        let mut ops = OpCounts::default();
        let mut counts = ScanCounts::default();
        {
            let Self {
                records,
                verts,
                lists,
                table,
                pyramid,
                tf,
                opts,
                full,
                persp,
                pending,
                ..
            } = self;
            let mut target = ScanTarget::new(
                lists,
                *full,
                tf,
                opts.integrator,
                opts.partial_composition,
                opts.canonical,
                &mut counts,
                pending,
            );
            // Vertices are fetched this many cells ahead of their record.
            const AHEAD: usize = 8;
            for (k, c) in records[self.next..end].iter().enumerate() {
                if let Some(ahead) = records.get(self.next + k + AHEAD) {
                    verts.prefetch(ahead);
                }
                if ert.enabled() {
                    ops.cells_tested += 1;
                    let range = c.range();
                    let skip = (flat
                        && match ert.span {
                            ErtSpan::Single => table.skip_single(range, c.near),
                            ErtSpan::Multi => table.skip_multi(range, c.near),
                        })
                        || pyramid.as_ref().is_some_and(|p| p.skip(range, c.near));
                    if skip {
                        ops.cells_skipped_ert += 1;
                        continue;
                    }
                }
                ops.cells_projected += 1;
                let rec = verts.record(c);
                ops.cells_degenerate += scan_cell(&rec, *full, persp.as_ref(), &mut target);
            }
            target.flush();
        }
        ops.pixels_tested = counts.pixels_tested;
        ops.segments_generated = counts.segments_generated;
        ops.segments_merged = counts.segments_merged;
        ops.segment_pieces = counts.segment_pieces;
        let processed = end - self.next;
        self.next = end;
        self.since_update += processed;
        self.totals.add(&ops);
        StepReport {
            ops,
            processed,
            remaining: self.remaining(),
            update_due: self.update_point_reached(),
        }
    }

    /// Rebuilds the local table (and pyramid) from the lists that changed
    /// since the last update, and restarts the schedule.
    pub fn update_table(&mut self) -> OpCounts {
        let mut ops = OpCounts::default();
        if !self.opts.ert.enabled() {
            return ops;
        }
        let thr = self.opts.ert.threshold();
        let w = self.view.width;
        let flat = self.flat_table();
        let Self {
            lists,
            depth,
            table,
            pyramid,
            levels,
            pixel_levels,
            ..
        } = self;
        lists.drain_changed(|idx, list| {
            let (d, walked) = match (levels.as_mut(), pixel_levels.as_mut()) {
                (None, None) => termination_depth_counted(list, thr),
                (_, Some(pl)) => {
                    let l = pl.alphas.len();
                    let cached = &mut pl.pix[idx * l..(idx + 1) * l];
                    let (walked, changed) = level_depths_counted(list, &pl.alphas, cached);
                    let d = cached[l - 1];
                    if changed {
                        pl.mark(idx);
                    }
                    (d, walked)
                }
                (Some(lv), None) => {
                    let l = lv.alphas.len();
                    let (x, y) = (idx as u32 % w, idx as u32 / w);
                    let cached = &mut lv.pix[idx * l..(idx + 1) * l];
                    let (walked, changed) = level_depths_counted(list, &lv.alphas, cached);
                    if changed {
                        let b = lv.grid.block_of(x, y);
                        if !lv.dirty_flag[b] {
                            lv.dirty_flag[b] = true;
                            lv.dirty.push(b as u32);
                        }
                    }
                    (cached[l - 1], walked)
                }
            };
            ops.lists_walked += 1;
            ops.list_entries_walked += walked as u64;
            if d < depth[idx] {
                depth[idx] = d;
                let (x, y) = (idx as u32 % w, idx as u32 / w);
                if flat {
                    table.mark(x, y);
                }
                if let Some(p) = pyramid.as_mut() {
                    p.mark(x, y);
                }
            }
        });
        if flat {
            table.rebuild(depth, &mut ops);
        }
        if let Some(p) = pyramid.as_mut() {
            ops.table_pixels_read += p.rebuild_counted(depth);
        }
        if let Some(lv) = levels.as_mut() {
            lv.rebuild(w, &mut ops);
        }
        self.since_update = 0;
        self.interval = None;
        self.totals.add(&ops);
        ops
    }

    /// Whether the flat `D x D` table is kept and tested: always but with
    /// per-pixel sharing, where the max-pyramid over the node's and the
    /// manager's per-pixel depths is the whole test (the flat entry's max
    /// over `D x D` pixels is almost never tighter, and keeping it costs a
    /// whole entry per changed pixel: 137 us under `pentium4`).
    pub fn flat_table(&self) -> bool {
        self.pyramid.is_none() || self.pixel_levels.is_none()
    }

    /// The node's own ERT information, to send to the manager.
    pub fn local_table(&self) -> SharedTable {
        self.table.local_table()
    }

    /// Entries per row and column of the ERT table.
    pub fn table_dims(&self) -> (u32, u32) {
        self.table.dims()
    }

    /// Merges the manager's table: per entry the min of everything received
    /// (safe: see [`super::table`]). Cells are tested against
    /// `min(local, shared)` from the next step on.
    pub fn apply_shared(&mut self, t: &SharedTable) -> Result<OpCounts, TableError> {
        let n = self.table.apply_shared(t)?;
        let ops = OpCounts {
            shared_entries_merged: n,
            ..Default::default()
        };
        self.totals.add(&ops);
        Ok(ops)
    }

    /// The whole-screen segment lists (row-major over the image), for compositing.
    pub fn lists(&self) -> &SegmentLists {
        &self.lists
    }

    /// The list of pixel `(i, j)`.
    pub fn list(&self, i: u32, j: u32) -> &[Segment] {
        self.lists.list((j * self.view.width + i) as usize)
    }

    /// Global ids of the unprocessed cells, in processing order.
    pub fn unprocessed_cells(&self) -> impl Iterator<Item = u32> + '_ {
        self.records[self.next..].iter().map(|c| c.cell)
    }

    /// Global ids of the processed cells (tested, skipped or scanned), in
    /// processing order, then those a DLB donor skipped before giving.
    pub fn processed_cells(&self) -> impl Iterator<Item = u32> + '_ {
        self.records[..self.next]
            .iter()
            .map(|c| c.cell)
            .chain(self.pre_skipped.iter().copied())
    }

    /// Runs the node to completion alone: steps, and updates at every update
    /// point (no sharing). Returns the total counts of this call.
    pub fn run_to_end(&mut self) -> OpCounts {
        let mut ops = OpCounts::default();
        while self.remaining() > 0 {
            let r = self.step(usize::MAX);
            ops.add(&r.ops);
            if r.update_due {
                ops.add(&self.update_table());
            }
        }
        ops
    }
}
