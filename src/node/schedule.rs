//! A global front-to-back schedule over a view-independent placement
//! (replicated data, `pvrsim cluster --schedule-waves W --schedule-leaf-cells S`).
//!
//! With the paper's RCB placement on a view that looks along the split
//! (aorta view B), whole nodes hold only cells lying behind other nodes'
//! cells; they scan them at the same time as the front nodes scan theirs,
//! before the front's opacity has reached them, and ERT loses most of what
//! the sequential renderer skips there (`examples/ert_gap.rs`). With the
//! mesh on every node no data has to move to change who scans what, so the
//! cluster can sweep the volume front to back *together*.
//!
//! ## Leaves
//!
//! Once per dataset, with the placement (view-independent, like the
//! placement itself), each node's RCB part is cut further by the same
//! bisection into **leaves** of about `S` cells ([`Leaves::new`]). Every node
//! knows every leaf's cell list: the leaves are a function of the mesh and
//! the node count, computed wherever the placement is.
//!
//! ## The schedule of a frame ([`leaf_waves`])
//!
//! * every leaf is keyed by the camera depth of its centre (the mean of its
//!   cells' centroids) and the pixel that centre lands on;
//! * the leaves, nearest first, are cut into `W` **waves** of about equal
//!   cell count (depth slabs);
//! * in every wave each node gets about `|wave| / N` cells: a node holding
//!   more of the wave (its *owner* under RCB) keeps a screen strip of its
//!   leaves there (by the centre's pixel `x`, then `y`) and the rest goes,
//!   in strips, to the nodes holding less, in rank order;
//! * each node scans its cells nearest first as always, so it scans wave 1,
//!   then wave 2, ...: a back node's first work is the front nodes' nearest
//!   leaves, its own back cells come last, and every node reaches a depth at
//!   about the same time as the others.
//!
//! ## When it is applied
//!
//! Only when the placement's parts are stacked along the view: every node
//! first keys [`PROBES_PER_NODE`] coarse leaves per part and measures
//! [`stacking`]; below the threshold ([`MIN_STACKING`] by default) each node
//! scans its placement part and only the probes were keyed.
//!
//! ## What it costs, and why nothing travels
//!
//! The schedule is a deterministic function of the view, `W` and the
//! leaves, so **every node computes it itself** and no byte travels: not
//! the cells (every node holds the mesh), not their ids (every node knows
//! every leaf's cells), not the assignment. Per frame each node keys every
//! leaf (one centre projected and compared per leaf), charged as a cell
//! record per leaf ([`crate::node::OpCounts::units_keyed`], `per_cell_receive`
//! under the cost model: a record projects four vertices, so this
//! over-charges). A node then builds the records of the cells it was dealt
//! from its own copy, exactly as it builds those of its initial part without
//! a schedule: the per-cell set-up is the same work whoever does it, done
//! once per cell by the node that renders it, and charged the same way as
//! the initial part's (see `src/node/replica.rs`). With `S = 1` every cell
//! is its own leaf and keying costs a record per cell of the mesh on every
//! node: the honest price of a per-cell global schedule.
//!
//! `W = 1` keeps the placement as it is (every node holds exactly its
//! target of the single wave).

use crate::node::placement::{rcb, targets};

/// Waves of the default schedule (`pvrsim cluster --ert T --share --dlb`).
pub const DEFAULT_WAVES: usize = 4;

/// Cells per leaf of the default schedule.
pub const DEFAULT_LEAF_CELLS: usize = 512;

/// The default schedule is applied only when the parts are stacked along
/// the view by at least this ([`stacking`] over [`PROBES_PER_NODE`]
/// coarse leaves per part). Measured at 8 nodes (docs/experiments/cluster.md):
/// aorta view B 0.85 (the schedule: 11.49 -> 9.81 s), the demo's vessel
/// 0.75 and view A 0.50 (there it makes the frame slower).
pub const MIN_STACKING: f64 = 0.8;

/// Coarse leaves per part keyed first, to measure the parts' stacking
/// before keying every leaf (a few records per node).
pub const PROBES_PER_NODE: usize = 4;

/// The default schedule runs only with at least this many cells per node
/// on average: below it a node's part is a few leaves, so waves cannot be
/// dealt evenly, and keying every leaf weighs against a short scan.
pub const MIN_CELLS_PER_NODE: usize = 2_500;

/// The schedule of [`leaf_waves`]: new parts, and per node the cells it
/// gave and received (counted in cells) against the placement.
#[derive(Debug, Clone, PartialEq)]
pub struct WaveSchedule {
    /// Per node, its cells (ascending ids).
    pub parts: Vec<Vec<u32>>,
    /// Per node, cells of its part the schedule deals to others.
    pub given: Vec<u64>,
    /// Per node, cells of others' parts the schedule deals to it.
    pub received: Vec<u64>,
    /// Leaves every node keys per frame (the schedule's compute).
    pub keyed: u64,
    /// How far the placement's parts are stacked along the view
    /// ([`stacking`]).
    pub stacking: f64,
}

/// View-independent leaves: every node's part cut by recursive bisection
/// into pieces of about `leaf_cells` cells. See the module docs.
#[derive(Debug, Clone, PartialEq)]
pub struct Leaves {
    /// Cell ids, leaf after leaf (each leaf's ascending).
    pub cells: Vec<u32>,
    /// Leaf `l` is `cells[start[l]..start[l + 1]]`.
    pub start: Vec<usize>,
    /// Per leaf, the node whose part it is.
    pub owner: Vec<u32>,
    /// Per leaf, the mean of its cells' centroids (world space).
    pub centre: Vec<[f64; 3]>,
}

impl Leaves {
    /// Cuts each of `parts` (cell ids; `centroids[c]` is cell `c`'s) into
    /// `ceil(len / leaf_cells)` leaves of equal count (±1) by the
    /// placement's bisection. `leaf_cells` of 0 counts as 1.
    pub fn new(parts: &[Vec<u32>], centroids: &[[f64; 3]], leaf_cells: usize) -> Leaves {
        let leaf_cells = leaf_cells.max(1);
        let mut out = Leaves {
            cells: Vec::new(),
            start: vec![0],
            owner: Vec::new(),
            centre: Vec::new(),
        };
        for (k, part) in parts.iter().enumerate() {
            if part.is_empty() {
                continue;
            }
            let mut ids = part.clone();
            let mut pieces = Vec::new();
            let t = targets(ids.len(), ids.len().div_ceil(leaf_cells));
            rcb(&mut ids, centroids, 3, &t, &mut pieces);
            for p in pieces.into_iter().filter(|p| !p.is_empty()) {
                let mut c = [0.0; 3];
                for &i in &p {
                    for (a, ca) in c.iter_mut().enumerate() {
                        *ca += centroids[i as usize][a];
                    }
                }
                out.centre.push(c.map(|x| x / p.len() as f64));
                out.cells.extend_from_slice(&p);
                out.start.push(out.cells.len());
                out.owner.push(k as u32);
            }
        }
        out
    }

    /// Number of leaves.
    pub fn len(&self) -> usize {
        self.owner.len()
    }

    /// Whether there is no leaf.
    pub fn is_empty(&self) -> bool {
        self.owner.is_empty()
    }

    /// The cells of leaf `l`.
    pub fn cells_of(&self, l: usize) -> &[u32] {
        &self.cells[self.start[l]..self.start[l + 1]]
    }
}

/// Deals weighted units wave by wave (see the module docs): `owner[u]` is
/// unit `u`'s node under the placement (`< n`), `weight[u]` its cells,
/// `depth[u]` its depth key (nearer = smaller), `screen[u]` its pixel.
/// Returns the new owner of every unit. Deterministic (ties by unit id).
pub fn deal_waves(
    owner: &[u32],
    weight: &[u64],
    depth: &[f64],
    screen: &[[f64; 2]],
    n: usize,
    waves: usize,
) -> Vec<u32> {
    let mut out = owner.to_vec();
    if n == 0 || owner.is_empty() {
        return out;
    }
    let mut order: Vec<u32> = (0..owner.len() as u32).collect();
    order.sort_unstable_by(|&a, &b| {
        depth[a as usize]
            .total_cmp(&depth[b as usize])
            .then(a.cmp(&b))
    });
    let total: u64 = weight.iter().sum();
    let waves = waves.max(1) as u64;
    // Wave of each unit: by the midpoint of its cells in the cumulative
    // count, so waves hold about total / W cells each.
    let mut by_wave: Vec<Vec<u32>> = vec![Vec::new(); waves as usize];
    let mut cum = 0u64;
    for &u in &order {
        let w = weight[u as usize];
        let mid2 = 2 * cum + w; // twice the midpoint
        let k = if total == 0 {
            0
        } else {
            ((waves * mid2) / (2 * total)).min(waves - 1)
        };
        by_wave[k as usize].push(u);
        cum += w;
    }
    for wave in &by_wave {
        // The wave's units per owner, in screen order.
        let mut held: Vec<Vec<u32>> = vec![Vec::new(); n];
        for &u in wave {
            held[owner[u as usize] as usize].push(u);
        }
        for h in &mut held {
            h.sort_unstable_by(|&a, &b| {
                let (p, q) = (screen[a as usize], screen[b as usize]);
                p[0].total_cmp(&q[0])
                    .then(p[1].total_cmp(&q[1]))
                    .then(a.cmp(&b))
            });
        }
        let sum: u64 = wave.iter().map(|&u| weight[u as usize]).sum();
        // Twice the target, in cells, to stay in integers.
        let target2 = |k: usize| -> u64 {
            (2 * sum) / n as u64 + u64::from(k < ((2 * sum) % n as u64) as usize)
        };
        // Owners keep a prefix of their strip while its midpoint fits the
        // target; the rest is spare.
        let mut kept2 = vec![0u64; n];
        let mut spare: Vec<u32> = Vec::new();
        for k in 0..n {
            let t2 = target2(k);
            let mut keeping = true;
            for &u in &held[k] {
                let w = weight[u as usize];
                if keeping && kept2[k] + w <= t2 {
                    kept2[k] += 2 * w;
                } else {
                    keeping = false;
                    spare.push(u);
                }
            }
        }
        // Spare units go to the nodes below target, by the midpoint of
        // each unit in the spare run mapped onto the needs' run.
        let need2: Vec<u64> = (0..n)
            .map(|k| target2(k).saturating_sub(kept2[k]))
            .collect();
        let need_total: u64 = need2.iter().sum();
        let spare_total: u64 = spare.iter().map(|&u| 2 * weight[u as usize]).sum();
        if spare_total == 0 || need_total == 0 {
            continue;
        }
        let mut at = 0usize; // needy node
        let mut need_end = need2[0];
        let mut cum2 = 0u64;
        for &u in &spare {
            let w2 = 2 * weight[u as usize];
            // Midpoint on the needs' scale (u128: no overflow).
            let m =
                ((2 * cum2 + w2) as u128 * need_total as u128 / (2 * spare_total) as u128) as u64;
            while at + 1 < n && m >= need_end {
                at += 1;
                need_end += need2[at];
            }
            out[u as usize] = at as u32;
            cum2 += w2;
        }
    }
    out
}

/// The frame's schedule over `leaves` for `n` nodes and `waves` waves:
/// `depth[l]` and `screen[l]` are leaf `l`'s keys (its centre's camera
/// depth and pixel).
pub fn leaf_waves(
    leaves: &Leaves,
    depth: &[f64],
    screen: &[[f64; 2]],
    n: usize,
    waves: usize,
) -> WaveSchedule {
    let weight: Vec<u64> = (0..leaves.len())
        .map(|l| leaves.cells_of(l).len() as u64)
        .collect();
    let owner = deal_waves(&leaves.owner, &weight, depth, screen, n, waves);
    let mut parts = vec![Vec::new(); n];
    let mut given = vec![0u64; n];
    let mut received = vec![0u64; n];
    for (l, &k) in owner.iter().enumerate() {
        parts[k as usize].extend_from_slice(leaves.cells_of(l));
        let from = leaves.owner[l] as usize;
        if from != k as usize {
            given[from] += weight[l];
            received[k as usize] += weight[l];
        }
    }
    for p in &mut parts {
        p.sort_unstable();
    }
    WaveSchedule {
        parts,
        given,
        received,
        keyed: leaves.len() as u64,
        stacking: stacking(&leaves.owner, depth, n),
    }
}

/// How far the parts `owner` describes are stacked along the view: the
/// largest gap between a node's nearest unit and the nearest unit of all,
/// as a fraction of the units' depth range,
///
/// `max_k (min_{u in k} depth_u - min_u depth_u) / (max_u depth_u - min_u depth_u)`
///
/// (0 with fewer than two distinct depths). The same measure as front-first
/// help's gap, on leaves at the start: with the parts side by side on the
/// screen (aorta view A) every node starts near the front and a schedule
/// only moves cells; with parts behind parts (view B) back nodes start far
/// behind.
pub fn stacking(owner: &[u32], depth: &[f64], n: usize) -> f64 {
    let mut near = vec![f64::INFINITY; n];
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for (&k, &d) in owner.iter().zip(depth) {
        near[k as usize] = near[k as usize].min(d);
        lo = lo.min(d);
        hi = hi.max(d);
    }
    if hi <= lo {
        return 0.0;
    }
    near.iter()
        .filter(|d| d.is_finite())
        .map(|&d| (d - lo) / (hi - lo))
        .fold(0.0, f64::max)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        /// Every unit ends up on exactly one node; each wave is split within
        /// one unit of evenly; one wave over balanced unit-weight parts keeps
        /// them as they are.
        #[test]
        fn waves_conserve_and_balance(
            units in proptest::collection::vec((0.0f64..10.0, 0.0f64..100.0, 0u32..5, 1u64..4), 1..300),
            waves in 1usize..8,
        ) {
            let n = 5;
            let owner: Vec<u32> = units.iter().map(|u| u.2).collect();
            let weight: Vec<u64> = units.iter().map(|u| u.3).collect();
            let depth: Vec<f64> = units.iter().map(|u| u.0).collect();
            let screen: Vec<[f64; 2]> = units.iter().map(|u| [u.1, 0.0]).collect();
            let new = deal_waves(&owner, &weight, &depth, &screen, n, waves);
            prop_assert_eq!(new.len(), units.len());
            prop_assert!(new.iter().all(|&k| (k as usize) < n));
            let mut load = vec![0u64; n];
            for (u, &k) in new.iter().enumerate() {
                load[k as usize] += weight[u];
            }
            let total: u64 = weight.iter().sum();
            // Within a wave each node is off its target by less than one
            // unit (weight <= 3) on each side, plus the rounding.
            for &l in &load {
                let dev = (l as f64 - total as f64 / n as f64).abs();
                prop_assert!(dev <= (2 * 3 * waves) as f64 + 1.0, "{:?}", load);
            }
        }
    }

    #[test]
    fn a_back_node_gets_front_leaves_first() {
        // Node 0 holds the 4 nearest units, node 1 the 4 farthest.
        let depth = [0.0, 1.0, 2.0, 3.0, 10.0, 11.0, 12.0, 13.0];
        let screen: Vec<[f64; 2]> = (0..8).map(|i| [i as f64, 0.0]).collect();
        let owner = [0, 0, 0, 0, 1, 1, 1, 1];
        let w = [1; 8];
        assert_eq!(
            deal_waves(&owner, &w, &depth, &screen, 2, 2),
            // Wave 1 (units 0-3, node 0's): node 0 keeps its first two in
            // screen order, node 1 gets 2 and 3; wave 2 the other way.
            vec![0, 0, 1, 1, 1, 1, 0, 0]
        );
        assert_eq!(
            deal_waves(&owner, &w, &depth, &screen, 2, 1),
            owner.to_vec()
        );
    }

    #[test]
    fn leaves_cover_parts_and_schedule_counts_moves() {
        // 40 cells on a line, two parts of 20; leaves of 5.
        let c: Vec<[f64; 3]> = (0..40).map(|i| [i as f64, 0.0, 0.0]).collect();
        let parts = vec![(0..20).collect::<Vec<u32>>(), (20..40).collect()];
        let leaves = Leaves::new(&parts, &c, 5);
        assert_eq!(leaves.len(), 8);
        let mut all = leaves.cells.clone();
        all.sort_unstable();
        assert_eq!(all, (0..40).collect::<Vec<u32>>());
        for l in 0..leaves.len() {
            assert_eq!(leaves.cells_of(l).len(), 5);
            let o = leaves.owner[l];
            assert!(leaves.cells_of(l).iter().all(|&x| (x / 20) == o));
        }
        // Depth = x: part 0 in front. Two waves: each node scans half of
        // the front half first.
        let depth: Vec<f64> = leaves.centre.iter().map(|p| p[0]).collect();
        let screen: Vec<[f64; 2]> = leaves.centre.iter().map(|p| [p[0], 0.0]).collect();
        let s = leaf_waves(&leaves, &depth, &screen, 2, 2);
        assert_eq!(s.keyed, 8);
        assert_eq!(s.parts[0].len() + s.parts[1].len(), 40);
        assert_eq!(s.given, vec![10, 10]);
        assert_eq!(s.received, vec![10, 10]);
        assert!(s.parts[1].iter().filter(|&&x| x < 20).count() == 10);
        let one = leaf_waves(&leaves, &depth, &screen, 2, 1);
        assert_eq!(one.parts, parts);
        assert_eq!(one.given, vec![0, 0]);
    }
}
