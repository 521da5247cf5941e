//! Giving and taking cells (dynamic load balancing, front-first help):
//! as work units with their vertices (partitioned data) or as cell ids
//! (replicated data, [`crate::node::replica`]).

use std::borrow::Cow;
use std::sync::Arc;

use super::cells::{NodeCell, TableVertex};
use super::NodeRenderer;
use crate::node::ops::OpCounts;
use crate::node::replica::{IdUnit, Replica};
use crate::node::work::{WorkCell, WorkError, WorkUnit};
use crate::render::cell::bin::{cell_record, Culled};
use crate::render::cell::ert::ErtSpan;
use crate::render::cell::project::ProjectedVertices;
use crate::render::cell::CellOrder;

/// Cells given away: what a work grant carries.
#[derive(Debug, Clone, PartialEq)]
pub enum Given {
    /// Cells with their vertices (partitioned data).
    Cells(WorkUnit),
    /// Cell ids (replicated data).
    Ids(IdUnit),
}

impl Given {
    /// Number of cells.
    pub fn len(&self) -> usize {
        match self {
            Given::Cells(u) => u.len(),
            Given::Ids(u) => u.len(),
        }
    }

    /// Whether no cell is given.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The wire form ([`WorkUnit::encode`] or [`IdUnit::encode`]).
    pub fn encode(&self) -> Vec<u8> {
        match self {
            Given::Cells(u) => u.encode(),
            Given::Ids(u) => u.encode(),
        }
    }
}

impl NodeRenderer {
    /// Replicated data: this node holds the whole mesh, so from now on
    /// cells are given and taken as ids ([`NodeRenderer::give`],
    /// [`NodeRenderer::take_grant`]). Call before the first cell arrives.
    pub fn set_replica(&mut self, replica: Arc<Replica>) {
        self.replica = Some(replica);
    }

    /// Whether the node holds the whole mesh (replicated data).
    pub fn replicated(&self) -> bool {
        self.replica.is_some()
    }

    /// An empty grant in this node's data mode (a refused help request).
    pub fn empty_grant(&self) -> Given {
        if self.replicated() {
            Given::Ids(IdUnit::default())
        } else {
            Given::Cells(WorkUnit::default())
        }
    }

    /// Gives away `floor(remaining * fraction)` unprocessed cells: the
    /// nearest ones with `front` (front-first help), else the last ones
    /// (DLB, see the module docs). Partitioned data: a work unit, packing
    /// counted in `work_cells_moved`; replicated data: their ids, counted in
    /// `cell_ids_moved`. Both added to [`NodeRenderer::totals`].
    ///
    /// With the pyramid structure a DLB donor first tests the cells it is
    /// about to give against its current termination depths (the test
    /// [`NodeRenderer::step`] does, counted the same way): the far cells
    /// given are the likeliest to be behind terminated pixels already, and a
    /// test costs far less than moving a cell and building its record on the
    /// receiver. Those are skipped here and only the others are given.
    /// Front-first help gives the nearest cells, which are rarely behind
    /// anything: no test.
    pub fn give(&mut self, fraction: f64, front: bool) -> Given {
        let mut given = self.take_out(fraction, front);
        if !front && self.pyramid.is_some() && self.opts.ert.enabled() {
            given = self.skip_before_giving(given);
        }
        if self.replicated() {
            self.totals.cell_ids_moved += given.len() as u64;
            Given::Ids(IdUnit::new(given.iter().map(|c| c.cell).collect()))
        } else {
            Given::Cells(self.pack(&given))
        }
    }

    /// Tests `cells` (taken out of the queue) against the table and the
    /// pyramid; keeps the skipped ones as processed, returns the others.
    fn skip_before_giving(&mut self, cells: Vec<NodeCell>) -> Vec<NodeCell> {
        let span = self.opts.ert.span;
        let flat = self.flat_table();
        let mut ops = OpCounts::default();
        let mut keep = Vec::with_capacity(cells.len());
        for c in cells {
            ops.cells_tested += 1;
            let range = c.range();
            let skip = (flat
                && match span {
                    ErtSpan::Single => self.table.skip_single(range, c.near),
                    ErtSpan::Multi => self.table.skip_multi(range, c.near),
                })
                || self.pyramid.as_ref().is_some_and(|p| p.skip(range, c.near));
            if skip {
                ops.cells_skipped_ert += 1;
                self.pre_skipped.push(c.cell);
            } else {
                keep.push(c);
            }
        }
        self.totals.add(&ops);
        keep
    }

    /// Takes the bytes of a grant ([`Given::encode`] in this node's data
    /// mode), validates them and adds the cells. Returns the counts (the
    /// unpacking in `work_cells_moved` or `cell_ids_moved`, the records as
    /// for initial cells) and the number of cells.
    pub fn take_grant(&mut self, bytes: &[u8]) -> Result<(OpCounts, usize), WorkError> {
        match self.replica.clone() {
            None => {
                let unit = WorkUnit::decode(bytes)?;
                if unit.is_empty() {
                    return Ok((OpCounts::default(), 0));
                }
                Ok((self.take_work(&unit)?, unit.len()))
            }
            Some(rep) => {
                let ids = IdUnit::decode(bytes, rep.cells())?;
                if ids.is_empty() {
                    return Ok((OpCounts::default(), 0));
                }
                let mut ops = self.add_work(&rep.unit(&ids.ids))?;
                ops.cell_ids_moved = ids.len() as u64;
                self.totals.cell_ids_moved += ops.cell_ids_moved;
                Ok((ops, ids.len()))
            }
        }
    }

    /// Takes `floor(remaining * fraction)` unprocessed cells out of the
    /// queue: the first ones with `front`, else the last ones.
    fn take_out(&mut self, fraction: f64, front: bool) -> Vec<NodeCell> {
        let rem = self.remaining();
        let k = ((rem as f64 * fraction.clamp(0.0, 1.0)).floor() as usize).min(rem);
        if front {
            self.records.drain(self.next..self.next + k).collect()
        } else {
            self.records.split_off(self.records.len() - k)
        }
    }

    /// Adds a unit of cells (initial placement); validates it first.
    pub fn add_work(&mut self, unit: &WorkUnit) -> Result<OpCounts, WorkError> {
        unit.validate()?;
        Ok(self.add_cells(
            &unit.vertex_ids,
            Cow::Borrowed(&unit.positions),
            &unit.scalars,
            unit.cells.iter().copied(),
        ))
    }

    /// Adds cells whose vertices are `vertex_ids`, `positions` and
    /// `scalars` (indexed by the cells' `v`), as [`NodeRenderer::add_work`]
    /// adds a unit's: the caller vouches for what [`WorkUnit::validate`]
    /// checks (a worker's own pieces, read and checked by the reader, are
    /// added so without building a unit: a unit and the piece it came from
    /// would be resident together; their positions are moved in).
    pub fn add_cells(
        &mut self,
        vertex_ids: &[u32],
        positions: Cow<'_, [[f64; 3]]>,
        scalars: &[f32],
        cells: impl ExactSizeIterator<Item = WorkCell>,
    ) -> OpCounts {
        let mut ops = OpCounts::default();
        let s: Vec<f64> = scalars.iter().map(|&s| s as f64).collect();
        let pv = ProjectedVertices::new_sequential(&self.view, &positions, &s);
        drop(s);
        ops.vertices_projected = vertex_ids.len() as u64;
        ops.cells_received = cells.len() as u64;
        // The vertices join the table (below, once culled); the cells index
        // them there.
        let base = self.verts.len() as u32;
        if self.replica.is_none() {
            // Partitioned data: keep the world positions to give cells away with.
            let world = &mut self.verts.world;
            match positions {
                // A worker's first piece: moved in, not copied.
                Cow::Owned(p) if world.is_empty() => *world = p,
                p => world.extend_from_slice(&p),
            }
        }
        let from = self.records.len();
        self.records.reserve(cells.len());
        for c in cells {
            match cell_record(c.id, c.v, &pv, &self.tf, self.full) {
                Ok(rec) => {
                    let f = &mut self.footprint;
                    f[0] = f[0].min(rec.range[0]);
                    f[1] = f[1].max(rec.range[1]);
                    f[2] = f[2].min(rec.range[2]);
                    f[3] = f[3].max(rec.range[3]);
                    self.records
                        .push(NodeCell::new(&rec, c.v.map(|l| base + l)));
                }
                Err(Culled::Empty | Culled::Offscreen | Culled::NoPixelCentre) => {
                    ops.cells_culled += 1
                }
            }
        }
        self.verts.v.extend(
            vertex_ids
                .iter()
                .zip(pv.pos.iter().zip(&pv.s))
                .map(|(&id, (&pos, &s))| TableVertex { pos, s, id }),
        );
        drop(pv);
        if self.release_ordered() {
            self.sort_released(from, &mut ops);
        } else {
            let order = self.opts.cell_order;
            let rest = &mut self.records[self.next..];
            match order {
                CellOrder::FrontToBack => rest.sort_unstable_by_key(|c| c.order_key()),
                CellOrder::Stored => rest.sort_unstable_by_key(|c| c.cell),
            }
        }
        self.totals.add(&ops);
        ops
    }

    /// Takes a unit given by another node (DLB): [`NodeRenderer::add_work`],
    /// with the unpacking counted in `work_cells_moved`.
    pub fn take_work(&mut self, unit: &WorkUnit) -> Result<OpCounts, WorkError> {
        let mut ops = self.add_work(unit)?;
        ops.work_cells_moved = unit.len() as u64;
        self.totals.work_cells_moved += ops.work_cells_moved;
        Ok(ops)
    }

    /// Gives away the last `floor(remaining * fraction)` unprocessed cells
    /// (see the module docs). The packing cost is `work_cells_moved =
    /// unit.len()`, also added to [`NodeRenderer::totals`].
    pub fn give_work(&mut self, fraction: f64) -> WorkUnit {
        let given = self.take_out(fraction, false);
        self.pack(&given)
    }

    /// Packs cells taken out of the queue into a work unit with their
    /// vertices, counting them in `work_cells_moved`.
    fn pack(&mut self, given: &[NodeCell]) -> WorkUnit {
        let (t, replica) = (&self.verts, &self.replica);
        // Where in the table each global vertex of the cells given is.
        let mut at = std::collections::HashMap::new();
        for c in given {
            for (g, l) in t.global_ids(c).into_iter().zip(c.v()) {
                at.insert(g, l as usize);
            }
        }
        let cells = given.iter().map(|c| (c.cell, t.global_ids(c)));
        let unit = WorkUnit::gather(cells, |g| match replica {
            Some(r) => (r.mesh.points[g as usize], r.s_norm[g as usize] as f32),
            None => {
                let l = at[&g];
                (t.world[l], t.v[l].s)
            }
        });
        self.totals.work_cells_moved += given.len() as u64;
        unit
    }

    /// Gives away the **first** `floor(remaining * fraction)` unprocessed
    /// cells (the nearest, in front-to-back order): front-first help, where a
    /// node whose own cells lie behind everybody else's scans the front of
    /// the volume first, so that termination information exists before the
    /// cells behind it are reached. Counted like [`NodeRenderer::give_work`].
    pub fn give_front_work(&mut self, fraction: f64) -> WorkUnit {
        let given = self.take_out(fraction, true);
        self.pack(&given)
    }
}
