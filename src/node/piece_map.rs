//! The piece map of a partitioned mesh (`.pvtu`) on `n` nodes, computed
//! alike wherever pieces are placed (in this process, by worker processes,
//! TCP workers or MPI ranks that read their own pieces), so every node
//! knows its share without asking.
//!
//! With at least as many pieces as nodes, the units are the pieces and a
//! node holds a contiguous run of them ([`crate::node::placement::piece_runs`],
//! cut where the running cell count crosses equal shares). With fewer
//! pieces than nodes, pieces are **split** so that every node works: piece
//! `i` gets `g_i >= 1` nodes in proportion to its cells ([`shares`]), and
//! each of those nodes reads the piece and keeps one of `g_i` parts of about
//! equal cell counts, cut by recursive bisection of the cells' centroids
//! ([`split`]). The cut is a function of the piece's own cells, so the
//! nodes that read one piece agree on it without a message between them:
//! the redistribution costs a read of the piece per node that shares it,
//! never an exchange of cells.

use serde::{Deserialize, Serialize};

use crate::data::TetMesh;
use crate::node::placement::{centroid, piece_runs, rcb, targets, Placement};

/// Most nodes one piece is split over (a share's part is 32-bit, but a
/// piece of a few cells over thousands of nodes helps nobody).
pub const MAX_SPLIT: u32 = 1 << 16;

/// One unit of the piece map: part `part` of `of` of piece `piece` (the
/// whole piece when `of == 1`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct Share {
    /// The piece's index in the `.pvtu`.
    pub piece: u32,
    /// Which part of the piece (`0..of`).
    pub part: u32,
    /// How many parts the piece is cut into.
    pub of: u32,
}

impl Share {
    /// The whole of piece `piece`.
    pub fn whole(piece: u32) -> Share {
        Share {
            piece,
            part: 0,
            of: 1,
        }
    }
}

/// The units of `w.len()` pieces of `w[i]` cells on `n` nodes: the pieces
/// themselves when there are at least `n` (or no cells at all), else every
/// piece split over `g_i >= 1` nodes, `sum g_i = n`, each further node
/// going to the piece with the most cells per part (lowest index on ties),
/// in piece order.
pub fn shares(w: &[u64], n: usize) -> Vec<Share> {
    let n = n.max(1);
    let total: u128 = w.iter().map(|&c| c as u128).sum();
    if w.len() >= n || total == 0 {
        return (0..w.len() as u32).map(Share::whole).collect();
    }
    let mut g = vec![1u64; w.len()];
    for _ in w.len()..n {
        // Most cells per part: w_i / g_i > w_j / g_j  <=>  w_i g_j > w_j g_i.
        let best = (0..w.len())
            .filter(|&i| (g[i] as u32) < MAX_SPLIT)
            .max_by(|&i, &j| {
                let a = w[i] as u128 * g[j] as u128;
                let b = w[j] as u128 * g[i] as u128;
                a.cmp(&b).then(j.cmp(&i))
            });
        match best {
            Some(i) => g[i] += 1,
            None => break,
        }
    }
    let mut out = Vec::with_capacity(n);
    for (i, &gi) in g.iter().enumerate() {
        for part in 0..gi as u32 {
            out.push(Share {
                piece: i as u32,
                part,
                of: gi as u32,
            });
        }
    }
    out
}

/// The cells each unit of `units` weighs (its piece's `w` over its parts).
pub fn unit_weights(w: &[u64], units: &[Share]) -> Vec<u64> {
    units
        .iter()
        .map(|s| {
            let c = w[s.piece as usize];
            let of = s.of.max(1) as u64;
            c / of + u64::from((s.part as u64) < c % of)
        })
        .collect()
}

/// The cells (indices into `centroids`, ascending) of each of `of` parts
/// of a piece whose cells have these centroids: recursive bisection along
/// the longest axis, the part sizes as equal as counts allow (ties in a
/// coordinate broken by index, so every reader of the piece cuts it alike).
pub fn split(centroids: &[[f64; 3]], of: u32) -> Vec<Vec<u32>> {
    let of = of.max(1) as usize;
    let mut ids: Vec<u32> = (0..centroids.len() as u32).collect();
    let mut out = Vec::with_capacity(of);
    let t = targets(ids.len(), of);
    rcb(&mut ids, centroids, 3, &t, &mut out);
    out
}

/// Places `mesh`, made of pieces of `cells[i]` cells each, one piece
/// after the other, on `n >= 1` nodes by the piece map
/// ([`crate::node::piece_map`]): node `k` the cells of its run of
/// pieces, or with fewer pieces than nodes its part of a split piece.
pub fn place(mesh: &TetMesh, cells: &[u64], n: usize) -> Placement {
    let mut first = Vec::with_capacity(cells.len());
    let mut acc = 0u64;
    for &c in cells {
        first.push(acc);
        acc += c;
    }
    let units = shares(cells, n.max(1));
    let runs = piece_runs(&unit_weights(cells, &units), n.max(1));
    // The parts of each split piece, cut once.
    let mut cut: std::collections::HashMap<u32, Vec<Vec<u32>>> = Default::default();
    let mut unit_cells = |u: usize| -> Vec<u32> {
        let s = units[u];
        let a = first[s.piece as usize] as u32;
        let len = cells[s.piece as usize] as u32;
        if s.of <= 1 {
            return (a..a + len).collect();
        }
        let parts = cut.entry(s.piece).or_insert_with(|| {
            let c: Vec<[f64; 3]> = mesh.tets[a as usize..(a + len) as usize]
                .iter()
                .map(|t| centroid(&mesh.points, t))
                .collect();
            split(&c, s.of)
        });
        parts[s.part as usize].iter().map(|&i| a + i).collect()
    };
    let parts = runs
        .into_iter()
        .map(|run| run.iter().flat_map(|&u| unit_cells(u as usize)).collect())
        .collect();
    Placement::from_parts(parts)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn enough_pieces_are_the_units() {
        assert_eq!(
            shares(&[5, 6, 7], 3),
            (0..3).map(Share::whole).collect::<Vec<_>>()
        );
        assert_eq!(shares(&[5, 6, 7, 8], 2).len(), 4);
        assert_eq!(shares(&[0, 0], 8), vec![Share::whole(0), Share::whole(1)]);
    }

    #[test]
    fn fewer_pieces_are_split_by_cells() {
        // 3 pieces on 8 nodes: each further node to the most cells per
        // part (ties to the lower index): 300 / 4, 200 / 3, 100 / 1.
        let s = shares(&[300, 200, 100], 8);
        assert_eq!(s.len(), 8);
        let of: Vec<u32> = [0u32, 1, 2]
            .iter()
            .map(|&p| s.iter().find(|x| x.piece == p).unwrap().of)
            .collect();
        assert_eq!(of.iter().sum::<u32>(), 8);
        assert_eq!(of, vec![4, 3, 1]);
        let w = unit_weights(&[300, 200, 100], &s);
        assert_eq!(w.iter().sum::<u64>(), 600);
        // A piece with no cells keeps its one node.
        let s = shares(&[0, 10], 4);
        assert_eq!(s.iter().filter(|x| x.piece == 0).count(), 1);
        assert_eq!(s.iter().filter(|x| x.piece == 1).count(), 3);
    }

    #[test]
    fn a_split_covers_the_piece_once_in_equal_parts() {
        let c: Vec<[f64; 3]> = (0..101)
            .map(|i| {
                let f = i as f64;
                [(f * 7.3) % 11.0, (f * 3.1) % 5.0, f * 0.01]
            })
            .collect();
        let parts = split(&c, 4);
        assert_eq!(parts.len(), 4);
        let mut all: Vec<u32> = parts.concat();
        all.sort_unstable();
        assert_eq!(all, (0..101).collect::<Vec<u32>>());
        for p in &parts {
            assert!(p.len() == 25 || p.len() == 26, "{}", p.len());
            assert!(p.windows(2).all(|x| x[0] < x[1]));
        }
        assert_eq!(split(&c, 4), parts, "the same cut every time");
        assert_eq!(split(&c, 1), vec![(0..101).collect::<Vec<u32>>()]);
    }
}
