//! Replicated data (`pvrsim cluster --data replicated`): every node holds
//! the whole mesh, so dynamic load balancing and front-first help move cell
//! **ids** ([`IdUnit`]) instead of cells with their vertices ([`WorkUnit`]).
//!
//! ## What it costs, and where it is charged
//!
//! - **Memory per node** ([`Replica::node_bytes`]): the whole mesh in the
//!   form a work unit carries it: per vertex a world position (3 × f64) and
//!   a normalised scalar (f32), per cell four u32 vertex ids:
//!   `V · 28 + C · 16` bytes (aorta.vtk: printed by `pvrsim cluster`). The
//!   paper's nodes (Pentium 4 PCs, 1–2 GB each) could hold it.
//! - **Distribution, once per dataset** ([`Replica::distribution_bytes`]):
//!   every node receives the whole mesh instead of its part. Like the
//!   transports' cell cache this is paid when the dataset is loaded, not per
//!   frame, so it is reported separately and not charged to `Tsc`.
//! - **Per frame, per moved cell**: the donor writes the id, the receiver
//!   reads it (`cell_ids_moved`, [`crate::node::CostProfile::cell_id_cost`]:
//!   one id through [`IdUnit::encode`] / [`IdUnit::decode`], measured against
//!   packing a cell into a work unit, `examples/id_move_cost.rs`) and the
//!   receiver builds the cell's record from its own copy of the mesh exactly
//!   as for an initial cell (`vertices_projected`, `cells_received`). On the
//!   network: the id list's bytes (varint deltas of the sorted ids, 1–3
//!   bytes per cell).
//!
//! ## Wire format of an id unit
//!
//! `varint(count)` then `count` varints: the first id, then the gaps
//! between consecutive ids (sorted ascending, unique, so every gap is at
//! least 1). [`IdUnit::decode`] never panics: the count is bounded by the
//! bytes left, every id must stay below the mesh's cell count and trailing
//! bytes are rejected.

use std::sync::Arc;

use serde::Serialize;

use super::work::{WorkError, WorkUnit};
use crate::data::TetMesh;

/// How the cells live on the nodes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, clap::ValueEnum, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum DataMode {
    /// Every node holds the whole mesh: DLB and help move cell ids.
    #[default]
    Replicated,
    /// Each node holds its part only: DLB and help move cells with their
    /// vertices (the paper).
    Partitioned,
}

/// Per pack or unpack of one id, the cost as a fraction of packing or
/// unpacking one cell into a work unit (`per_work_cell`), used when a
/// profile does not set `per_cell_id`. Measured on this machine with
/// `cargo run --release --example id_move_cost` (docs/experiments/cluster.md):
/// 0.21–0.26 over three runs on aorta.vtk (0.028 on aorta-small, where the
/// queue fits in cache); the larger, 0.25, is used.
pub const ID_COST_RATIO: f64 = 0.25;

/// The whole mesh on one node (shared, read-only).
#[derive(Debug, Clone)]
pub struct Replica {
    /// The mesh.
    pub mesh: Arc<TetMesh>,
    /// Normalised scalar per vertex.
    pub s_norm: Arc<Vec<f64>>,
}

impl Replica {
    /// A replica of `mesh` with normalised scalars `s_norm`.
    pub fn new(mesh: Arc<TetMesh>, s_norm: &[f64]) -> Replica {
        Replica {
            mesh,
            s_norm: Arc::new(s_norm.to_vec()),
        }
    }

    /// Cells in the mesh.
    pub fn cells(&self) -> usize {
        self.mesh.tets.len()
    }

    /// Bytes one node holds for the mesh: `V · (24 + 4) + C · 16`.
    pub fn node_bytes(&self) -> u64 {
        self.mesh.points.len() as u64 * 28 + self.mesh.tets.len() as u64 * 16
    }

    /// Bytes of the whole mesh as one work unit (what each node receives
    /// once per dataset), exact ([`WorkUnit`]'s size formula).
    pub fn unit_bytes(&self) -> u64 {
        32 + self.mesh.points.len() as u64 * 32 + self.mesh.tets.len() as u64 * 20
    }

    /// One-time distribution to `n` nodes: `n` whole-mesh units.
    pub fn distribution_bytes(&self, n: usize) -> u64 {
        self.unit_bytes() * n as u64
    }

    /// The work unit of `ids` built from the replica (what a receiver does
    /// with an [`IdUnit`]; no bytes travel for it).
    pub fn unit(&self, ids: &[u32]) -> WorkUnit {
        WorkUnit::from_mesh(&self.mesh, &self.s_norm, ids)
    }
}

/// Cell ids that travel with replicated data. See the module docs.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct IdUnit {
    /// Global cell ids, sorted ascending, unique.
    pub ids: Vec<u32>,
}

fn put_varint(out: &mut Vec<u8>, mut v: u64) {
    while v >= 0x80 {
        out.push((v as u8) | 0x80);
        v >>= 7;
    }
    out.push(v as u8);
}

fn get_varint(b: &[u8], at: &mut usize) -> Result<u64, WorkError> {
    let mut v = 0u64;
    for shift in (0..64).step_by(7) {
        let Some(&x) = b.get(*at) else {
            return Err(WorkError::Encoding("id unit: truncated varint".into()));
        };
        *at += 1;
        v |= ((x & 0x7f) as u64) << shift;
        if x & 0x80 == 0 {
            return Ok(v);
        }
    }
    Err(WorkError::Encoding("id unit: varint too long".into()))
}

impl IdUnit {
    /// The unit of `ids` (any order; sorted and deduplicated here).
    pub fn new(mut ids: Vec<u32>) -> IdUnit {
        ids.sort_unstable();
        ids.dedup();
        IdUnit { ids }
    }

    /// Number of cells.
    pub fn len(&self) -> usize {
        self.ids.len()
    }

    /// Whether it holds no cell.
    pub fn is_empty(&self) -> bool {
        self.ids.is_empty()
    }

    /// The wire form (see the module docs).
    pub fn encode(&self) -> Vec<u8> {
        let mut out = Vec::with_capacity(2 + self.ids.len() * 2);
        put_varint(&mut out, self.ids.len() as u64);
        let mut prev = 0u32;
        for (k, &id) in self.ids.iter().enumerate() {
            put_varint(&mut out, if k == 0 { id } else { id - prev } as u64);
            prev = id;
        }
        out
    }

    /// Decodes and validates against a mesh of `cells` cells: ids strictly
    /// ascending and below `cells`, no trailing bytes.
    pub fn decode(b: &[u8], cells: usize) -> Result<IdUnit, WorkError> {
        let mut at = 0;
        let n = get_varint(b, &mut at)?;
        // Every id takes at least one byte.
        if n > (b.len() - at) as u64 {
            return Err(WorkError::Encoding(format!(
                "id unit: {n} ids announced in {} bytes",
                b.len() - at
            )));
        }
        let mut ids = Vec::with_capacity(n as usize);
        let mut prev = 0u64;
        for k in 0..n {
            let d = get_varint(b, &mut at)?;
            if k > 0 && d == 0 {
                return Err(WorkError::DuplicateCell(prev as u32));
            }
            let id = if k == 0 { d } else { prev.saturating_add(d) };
            if id >= cells as u64 {
                return Err(WorkError::OutOfRange {
                    id: id.min(u32::MAX as u64) as u32,
                    limit: cells,
                });
            }
            ids.push(id as u32);
            prev = id;
        }
        if at != b.len() {
            return Err(WorkError::Encoding(format!(
                "id unit: {} trailing bytes",
                b.len() - at
            )));
        }
        Ok(IdUnit { ids })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #[test]
        fn roundtrip(ids in proptest::collection::vec(0u32..100_000, 0..300)) {
            let u = IdUnit::new(ids.clone());
            let back = IdUnit::decode(&u.encode(), 100_000).unwrap();
            prop_assert_eq!(&back, &u);
            let mut want = ids;
            want.sort_unstable();
            want.dedup();
            prop_assert_eq!(back.ids, want);
        }

        #[test]
        fn hostile_bytes_never_panic(b in proptest::collection::vec(any::<u8>(), 0..64)) {
            if let Ok(u) = IdUnit::decode(&b, 1000) {
                prop_assert!(u.ids.windows(2).all(|w| w[0] < w[1]));
                prop_assert!(u.ids.iter().all(|&i| i < 1000));
            }
        }
    }

    #[test]
    fn rejects_out_of_range_duplicates_and_trailing() {
        let u = IdUnit::new(vec![3, 9, 10]);
        let b = u.encode();
        assert_eq!(b, vec![3, 3, 6, 1]);
        assert!(matches!(
            IdUnit::decode(&b, 10),
            Err(WorkError::OutOfRange { id: 10, .. })
        ));
        assert!(matches!(
            IdUnit::decode(&[2, 5, 0], 10),
            Err(WorkError::DuplicateCell(5))
        ));
        assert!(IdUnit::decode(&[1, 5, 7], 10).is_err());
        assert!(IdUnit::decode(&[200], 10).is_err());
        assert_eq!(IdUnit::decode(&[0], 10).unwrap(), IdUnit::default());
    }

    #[test]
    fn replica_sizes() {
        let mesh = TetMesh {
            points: vec![[0.0; 3]; 5],
            tets: vec![[0, 1, 2, 3], [1, 2, 3, 4]],
            fields: Vec::new(),
        };
        let r = Replica::new(Arc::new(mesh), &[0.0; 5]);
        assert_eq!(r.node_bytes(), 5 * 28 + 2 * 16);
        let u = r.unit(&[0, 1]);
        assert_eq!(u.encode().len() as u64, r.unit_bytes());
        assert_eq!(r.distribution_bytes(3), 3 * r.unit_bytes());
    }
}
