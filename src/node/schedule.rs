//! A global front-to-back schedule over a view-independent placement
//! (replicated data, `pvrsim cluster --schedule-waves W`).
//!
//! With the paper's RCB placement on a view that looks along the split
//! (aorta view B), whole nodes hold only cells lying behind other nodes'
//! cells; they scan them at the same time as the front nodes scan theirs,
//! before the front's opacity has reached them, and ERT loses most of what
//! the sequential renderer skips there (`examples/ert_gap.rs`). With the
//! mesh on every node no data has to move to change who scans what, so the
//! cluster can sweep the volume front to back *together*:
//!
//! * all cells, ordered by the camera depth of their centroid, are cut
//!   into `W` **waves** of equal cell count (depth slabs);
//! * in every wave each node gets `floor` or `ceil` of `|wave| / N` cells:
//!   a node holding more of the wave (its *owner* under RCB) keeps a
//!   contiguous screen strip of its cells there (ordered by the centroid's
//!   pixel `x`, then `y`) and gives the rest, in strips, to the nodes
//!   holding fewer, in rank order;
//! * each node scans its cells nearest first as always, so it scans wave
//!   1, then wave 2, ...: a back node's first work is the front nodes'
//!   frontmost cells, its own back cells come last, and every node reaches
//!   a depth at about the same time as the others.
//!
//! `W = 1` is the placement itself. What it costs per frame (charged at the
//! start of phase 1 by [`crate::node::NodeActor`]): the donor writes each
//! given id, the receiver reads it and builds the cell's record from its
//! copy of the mesh, as for a front-first help grant. The plan itself needs
//! per node and wave only a count of its own cells (a pass over the depth
//! keys every node sorts anyway) and is the same on every node.

/// The schedule of [`global_waves`]: new parts, and per node the cells it
/// gave and received.
#[derive(Debug, Clone, PartialEq)]
pub struct WaveSchedule {
    /// Per node, its cells (ascending ids).
    pub parts: Vec<Vec<u32>>,
    /// Per node, cells it gave to others.
    pub given: Vec<u64>,
    /// Per node, cells it received from others.
    pub received: Vec<u64>,
}

/// Rebalances `parts` wave by wave (see the module docs). `depth[c]` is
/// cell `c`'s depth key (nearer = smaller), `screen[c]` its position on the
/// screen (`[x, y]` pixels), `waves >= 1`.
pub fn global_waves(
    parts: &[Vec<u32>],
    depth: &[f64],
    screen: &[[f64; 2]],
    waves: usize,
) -> WaveSchedule {
    let n = parts.len();
    let mut owner = vec![u32::MAX; depth.len()];
    for (k, p) in parts.iter().enumerate() {
        for &c in p {
            owner[c as usize] = k as u32;
        }
    }
    let mut order: Vec<u32> = parts.iter().flatten().copied().collect();
    order.sort_unstable_by(|&a, &b| {
        depth[a as usize]
            .total_cmp(&depth[b as usize])
            .then(a.cmp(&b))
    });
    let total = order.len();
    let waves = waves.clamp(1, total.max(1));
    let mut out = vec![Vec::new(); n];
    let mut given = vec![0u64; n];
    let mut received = vec![0u64; n];
    if n == 0 {
        return WaveSchedule {
            parts: out,
            given,
            received,
        };
    }
    for w in 0..waves {
        let wave = &order[w * total / waves..(w + 1) * total / waves];
        // The wave's cells per owner, in screen order.
        let mut held: Vec<Vec<u32>> = vec![Vec::new(); n];
        for &c in wave {
            held[owner[c as usize] as usize].push(c);
        }
        for h in &mut held {
            h.sort_unstable_by(|&a, &b| {
                let (p, q) = (screen[a as usize], screen[b as usize]);
                p[0].total_cmp(&q[0])
                    .then(p[1].total_cmp(&q[1]))
                    .then(a.cmp(&b))
            });
        }
        // Targets: floor or ceil of |wave| / N, the extra ones to the
        // nodes holding the most (fewest moves).
        let base = wave.len() / n;
        let mut by_held: Vec<usize> = (0..n).collect();
        by_held.sort_by_key(|&k| (std::cmp::Reverse(held[k].len()), k));
        let mut target = vec![base; n];
        for &k in by_held.iter().take(wave.len() - base * n) {
            target[k] += 1;
        }
        // Donors keep the first `target` of their strip; the rest goes to
        // the nodes below target, in rank order.
        let mut spare: Vec<u32> = Vec::new();
        let mut spare_from: Vec<usize> = Vec::new();
        for k in 0..n {
            let keep = target[k].min(held[k].len());
            out[k].extend_from_slice(&held[k][..keep]);
            for &c in &held[k][keep..] {
                spare.push(c);
                spare_from.push(k);
            }
        }
        let mut at = 0;
        for k in 0..n {
            let need = target[k].saturating_sub(held[k].len());
            for (&c, &from) in spare[at..at + need].iter().zip(&spare_from[at..at + need]) {
                out[k].push(c);
                given[from] += 1;
                received[k] += 1;
            }
            at += need;
        }
        debug_assert_eq!(at, spare.len());
    }
    for p in &mut out {
        p.sort_unstable();
    }
    WaveSchedule {
        parts: out,
        given,
        received,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        /// Every cell ends up on exactly one node; each wave is split within
        /// one cell of evenly; moves balance (given = received); W = 1 keeps
        /// balanced parts as they are.
        #[test]
        fn waves_conserve_and_balance(
            cells in proptest::collection::vec((0.0f64..10.0, 0.0f64..100.0, 0usize..5), 1..300),
            waves in 1usize..8,
        ) {
            let n = 5;
            let depth: Vec<f64> = cells.iter().map(|c| c.0).collect();
            let screen: Vec<[f64; 2]> = cells.iter().map(|c| [c.1, 0.0]).collect();
            let mut parts = vec![Vec::new(); n];
            for (i, c) in cells.iter().enumerate() {
                parts[c.2].push(i as u32);
            }
            let s = global_waves(&parts, &depth, &screen, waves);
            let mut all: Vec<u32> = s.parts.iter().flatten().copied().collect();
            all.sort_unstable();
            prop_assert_eq!(all, (0..cells.len() as u32).collect::<Vec<_>>());
            prop_assert_eq!(s.given.iter().sum::<u64>(), s.received.iter().sum::<u64>());
            let sizes: Vec<usize> = s.parts.iter().map(|p| p.len()).collect();
            let (lo, hi) = (*sizes.iter().min().unwrap(), *sizes.iter().max().unwrap());
            prop_assert!(hi - lo <= waves.min(cells.len()), "{:?}", sizes);
        }
    }

    #[test]
    fn a_back_node_gets_front_cells_first() {
        // Node 0 holds the 4 nearest cells, node 1 the 4 farthest.
        let depth = [0.0, 1.0, 2.0, 3.0, 10.0, 11.0, 12.0, 13.0];
        let screen: Vec<[f64; 2]> = (0..8).map(|i| [i as f64, 0.0]).collect();
        let parts = vec![vec![0, 1, 2, 3], vec![4, 5, 6, 7]];
        let s = global_waves(&parts, &depth, &screen, 2);
        assert_eq!(s.parts, vec![vec![0, 1, 6, 7], vec![2, 3, 4, 5]]);
        assert_eq!(
            (s.given.clone(), s.received.clone()),
            (vec![2, 2], vec![2, 2])
        );
        assert_eq!(global_waves(&parts, &depth, &screen, 1).parts, parts);
    }
}
