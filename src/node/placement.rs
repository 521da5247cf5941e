//! Initial placement: the cells cut into `N` parts of equal count (±1),
//! spatially coherent, like the paper's Fig. 8 where each node holds a
//! contiguous piece of the vessel (§4.1: "about equal cell counts, nearby
//! cells on the same processor").
//!
//! Two deterministic methods, both on cell centroids:
//!
//! - **Recursive coordinate bisection** ([`PlacementMethod::Rcb`]): the
//!   parts `0..N` are given target counts `floor(M / N)` or `ceil(M / N)`
//!   (the first `M mod N` get one more). A group of `n` parts is split into
//!   `floor(n / 2)` and `ceil(n / 2)` parts; its cells are split along the
//!   longest axis of their centroids' bounding box at the position that
//!   leaves the left group exactly the sum of its parts' targets (a
//!   selection, `O(M)` per level, with ties broken by cell id so the result
//!   never depends on the input order). This handles any `N`, not just
//!   powers of two: the cut is proportional to the parts on each side.
//! - **Morton curve** ([`PlacementMethod::Morton`]): centroids quantised to
//!   21 bits per axis over their bounding box, bits interleaved into a
//!   63-bit Z-order key, cells sorted by `(key, id)` and cut into `N`
//!   consecutive runs of the target counts.
//!
//! - **View-aligned bisection** ([`PlacementMethod::RcbView`]): the same
//!   bisection on the centroids' pixel positions for the frame's view, cutting
//!   only along the screen axes (the longer of X and Y). Each node then owns
//!   a screen region with all its depths, so a node's own front cells
//!   terminate its rays and little is left for ERT sharing to recover; the
//!   price is that the placement depends on the view (our Table 2 runs
//!   render one view per run, like the paper's).
//!
//! [`Placement::footprints`] reports for a view where each node's cells land
//! on screen: the bounding box in pixels and the number of pixels covered by
//! the union of its cells' pixel ranges (each visible cell's bounding
//! rectangle of pixel centres: a slight over-estimate of the exact coverage,
//! by the part of each small rectangle the tet does not cover), and how much
//! the nodes overlap: `sum of covered / union of covered` (1 = no overlap,
//! `N` = every node covers the same pixels) and the pairwise matrix of shared
//! pixels. Overlap is what makes ERT sharing pay (the paper's view A vs B).

use rayon::prelude::*;
use serde::Serialize;

use crate::base::Rect;
use crate::data::TetMesh;
use crate::render::cell::bin::cell_record;
use crate::render::cell::project::ProjectedVertices;
use crate::render::cell::PreparedTf;
use crate::render::RenderInput;
use crate::scene::View;

/// How to cut the mesh.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, serde::Deserialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum PlacementMethod {
    /// Recursive coordinate bisection of centroids.
    Rcb,
    /// Morton (Z-order) curve of centroids, cut into equal runs.
    Morton,
    /// Recursive bisection of the centroids' *screen* positions for the
    /// frame's view: cuts only across the image, never along the depth, so
    /// each node holds every depth of its part of the screen (sort-first
    /// style). View-dependent: another view needs another placement.
    RcbView,
    /// The pieces of a partitioned mesh (`.pvtu`), as its solver wrote
    /// them: each node a contiguous run of pieces ([`piece_runs`]). Without
    /// pieces (one file), as [`PlacementMethod::Rcb`].
    Pieces,
}

/// Cells per node.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Placement {
    /// Per node, its cells' global ids, ascending.
    pub parts: Vec<Vec<u32>>,
}

/// A node's piece in world space.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct NodeWorld {
    /// Cells held.
    pub cells: usize,
    /// Bounding box of its cells' vertices: min corner (`+inf` if empty).
    pub min: [f64; 3],
    /// Max corner (`-inf` if empty).
    pub max: [f64; 3],
}

impl NodeWorld {
    /// Volume of the bounding box (0 if empty).
    pub fn volume(&self) -> f64 {
        (0..3)
            .map(|a| (self.max[a] - self.min[a]).max(0.0))
            .product()
    }
}

/// A node's piece on screen.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct Footprint {
    /// Bounding box of covered pixels `[i0, i1, j0, j1]` inclusive, if any.
    pub bbox: Option<[u32; 4]>,
    /// Pixels covered by the union of its visible cells' pixel ranges.
    pub covered: u64,
}

/// All nodes' footprints and their overlap.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FootprintReport {
    /// Per node.
    pub nodes: Vec<Footprint>,
    /// Sum over nodes of covered pixels.
    pub sum_covered: u64,
    /// Pixels covered by at least one node.
    pub union_covered: u64,
    /// `sum_covered / union_covered` (1: disjoint; N: all the same).
    pub overlap: f64,
    /// `pairwise[a][b]`: pixels covered by both `a` and `b` (diagonal: `covered`).
    pub pairwise: Vec<Vec<u64>>,
}

/// Per cell, the centroid of its vertices.
pub fn centroids(mesh: &TetMesh) -> Vec<[f64; 3]> {
    mesh.tets
        .iter()
        .map(|t| centroid(&mesh.points, t))
        .collect()
}

/// The centroid of tetrahedron `t` of `points` (the vertices summed in
/// `t`'s order: every reader of a piece gets the same bits).
pub fn centroid(points: &[[f64; 3]], t: &[u32; 4]) -> [f64; 3] {
    let mut c = [0.0; 3];
    for &v in t {
        for (a, ca) in c.iter_mut().enumerate() {
            *ca += points[v as usize][a];
        }
    }
    c.map(|x| x * 0.25)
}

/// Target counts: `m` cells over `n` parts, the first `m mod n` one larger.
pub fn targets(m: usize, n: usize) -> Vec<usize> {
    (0..n).map(|i| m / n + usize::from(i < m % n)).collect()
}

fn bbox(ids: &[u32], c: &[[f64; 3]]) -> ([f64; 3], [f64; 3]) {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for &i in ids {
        for a in 0..3 {
            lo[a] = lo[a].min(c[i as usize][a]);
            hi[a] = hi[a].max(c[i as usize][a]);
        }
    }
    (lo, hi)
}

/// Recursive bisection of `ids` by their points `c`, cutting along the
/// longest of the first `axes` coordinates; appends one part per target.
pub(crate) fn rcb(
    ids: &mut [u32],
    c: &[[f64; 3]],
    axes: usize,
    targets: &[usize],
    out: &mut Vec<Vec<u32>>,
) {
    if targets.len() <= 1 {
        let mut part = ids.to_vec();
        part.sort_unstable();
        out.push(part);
        return;
    }
    let (lo, hi) = bbox(ids, c);
    let axis = (0..axes)
        .max_by(|&a, &b| (hi[a] - lo[a]).total_cmp(&(hi[b] - lo[b])).then(b.cmp(&a)))
        .unwrap_or(0);
    let half = targets.len() / 2;
    let k: usize = targets[..half].iter().sum();
    if k > 0 && k < ids.len() {
        ids.select_nth_unstable_by(k, |&x, &y| {
            c[x as usize][axis]
                .total_cmp(&c[y as usize][axis])
                .then(x.cmp(&y))
        });
    }
    let (l, r) = ids.split_at_mut(k);
    rcb(l, c, axes, &targets[..half], out);
    rcb(r, c, axes, &targets[half..], out);
}

/// Interleaves the low 21 bits of `x`, `y`, `z` (x lowest).
fn morton3(x: u64, y: u64, z: u64) -> u64 {
    fn spread(mut v: u64) -> u64 {
        v &= 0x1f_ffff;
        v = (v | v << 32) & 0x1f00000000ffff;
        v = (v | v << 16) & 0x1f0000ff0000ff;
        v = (v | v << 8) & 0x100f00f00f00f00f;
        v = (v | v << 4) & 0x10c30c30c30c30c3;
        (v | v << 2) & 0x1249249249249249
    }
    spread(x) | spread(y) << 1 | spread(z) << 2
}

/// Pieces per node: `n` contiguous runs of the pieces (weights `w`, e.g.
/// their cells) of about equal weight, every node a piece when there are at
/// least `n`; with fewer pieces than nodes, the last nodes get none (the
/// piece map then splits pieces: [`crate::node::piece_map`]). The same
/// runs wherever pieces are placed (in this process, or by workers that
/// read their own).
pub fn piece_runs(w: &[u64], n: usize) -> Vec<Vec<u32>> {
    let n = n.max(1);
    let mut parts = vec![Vec::new(); n];
    if w.len() <= n {
        // One piece a node, first nodes first.
        for (i, p) in parts.iter_mut().enumerate().take(w.len()) {
            p.push(i as u32);
        }
        return parts;
    }
    let total: u128 = w.iter().map(|&c| c as u128).sum();
    let equal = |parts: &mut Vec<Vec<u32>>| {
        for (k, p) in parts.iter_mut().enumerate() {
            p.clear();
            let (a, b) = (k * w.len() / n, (k + 1) * w.len() / n);
            p.extend(a as u32..b as u32);
        }
    };
    if total == 0 {
        equal(&mut parts);
        return parts;
    }
    // Each piece to the node whose share its middle falls in; a node left
    // empty (a heavy neighbour) takes equal counts of pieces instead.
    let mut acc = 0u128;
    for (i, &c) in w.iter().enumerate() {
        let mid = acc * 2 + c as u128;
        let k = (mid * n as u128 / (2 * total)) as usize;
        parts[k.min(n - 1)].push(i as u32);
        acc += c as u128;
    }
    if parts.iter().any(Vec::is_empty) {
        equal(&mut parts);
    }
    parts
}

impl Placement {
    /// Places the cells of `mesh` on `n >= 1` nodes. `view` is needed by
    /// [`PlacementMethod::RcbView`] only (without one it falls back to
    /// [`PlacementMethod::Rcb`]).
    pub fn new(
        mesh: &TetMesh,
        n: usize,
        method: PlacementMethod,
        view: Option<&View>,
    ) -> Placement {
        let n = n.max(1);
        let mut c = centroids(mesh);
        let t = targets(c.len(), n);
        let mut ids: Vec<u32> = (0..c.len() as u32).collect();
        let mut parts = Vec::with_capacity(n);
        match method {
            PlacementMethod::RcbView if view.is_some() => {
                let view = view.expect("checked");
                // Screen position of each centroid (camera x, y for one
                // behind a perspective eye: it is off screen anyway).
                for p in &mut c {
                    let cam = view.to_camera(*p);
                    *p = match view.camera_to_pixel(cam) {
                        Some([x, y]) => [x, y, cam[2]],
                        None => [cam[0], -cam[1], cam[2]],
                    };
                }
                rcb(&mut ids, &c, 2, &t, &mut parts)
            }
            PlacementMethod::Rcb | PlacementMethod::RcbView | PlacementMethod::Pieces => {
                rcb(&mut ids, &c, 3, &t, &mut parts)
            }
            PlacementMethod::Morton => {
                let (lo, hi) = bbox(&ids, &c);
                let q = |v: f64, a: usize| {
                    let span = hi[a] - lo[a];
                    if span > 0.0 {
                        (((v - lo[a]) / span) * ((1u64 << 21) - 1) as f64).round() as u64
                    } else {
                        0
                    }
                };
                let mut keyed: Vec<(u64, u32)> = ids
                    .iter()
                    .map(|&i| {
                        let p = c[i as usize];
                        (morton3(q(p[0], 0), q(p[1], 1), q(p[2], 2)), i)
                    })
                    .collect();
                keyed.sort_unstable();
                let mut start = 0;
                for len in t {
                    let mut part: Vec<u32> =
                        keyed[start..start + len].iter().map(|&(_, i)| i).collect();
                    part.sort_unstable();
                    parts.push(part);
                    start += len;
                }
            }
        }
        Placement { parts }
    }

    /// A placement from explicit parts (e.g. random, for comparison).
    pub fn from_parts(parts: Vec<Vec<u32>>) -> Placement {
        Placement { parts }
    }

    /// Number of nodes.
    pub fn nodes(&self) -> usize {
        self.parts.len()
    }

    /// Per node: how many distinct vertices its cells use (what the node
    /// holds of the mesh's vertices).
    pub fn vertex_counts(&self, mesh: &TetMesh) -> Vec<u64> {
        let mut seen = vec![u32::MAX; mesh.points.len()];
        self.parts
            .iter()
            .enumerate()
            .map(|(k, p)| {
                let mut count = 0u64;
                for &cell in p {
                    for &v in &mesh.tets[cell as usize] {
                        let s = &mut seen[v as usize];
                        if *s != k as u32 {
                            *s = k as u32;
                            count += 1;
                        }
                    }
                }
                count
            })
            .collect()
    }

    /// Per node: cell count and world bounding box.
    pub fn world(&self, mesh: &TetMesh) -> Vec<NodeWorld> {
        self.parts
            .iter()
            .map(|p| {
                let mut w = NodeWorld {
                    cells: p.len(),
                    min: [f64::INFINITY; 3],
                    max: [f64::NEG_INFINITY; 3],
                };
                for &cell in p {
                    for &v in &mesh.tets[cell as usize] {
                        let q = mesh.points[v as usize];
                        for (a, &qa) in q.iter().enumerate() {
                            w.min[a] = w.min[a].min(qa);
                            w.max[a] = w.max[a].max(qa);
                        }
                    }
                }
                w
            })
            .collect()
    }

    /// Screen footprints and overlap for the view of `input` (see the module docs).
    pub fn footprints(&self, input: &RenderInput) -> FootprintReport {
        let view = input.scene.view();
        let (w, h) = (view.width, view.height);
        let tf = PreparedTf::new(&input.scene.transfer);
        let pv = ProjectedVertices::new(&view, &input.mesh.points, &input.s_norm);
        let full = Rect {
            x0: 0,
            y0: 0,
            x1: w,
            y1: h,
        };
        let masks: Vec<Vec<bool>> = self
            .parts
            .par_iter()
            .map(|part| {
                let mut m = vec![false; (w * h) as usize];
                for &cell in part {
                    let ids = input.mesh.tets[cell as usize];
                    if let Ok(rec) = cell_record(cell, ids, &pv, &tf, full) {
                        let [i0, i1, j0, j1] = rec.range;
                        for j in j0..=j1 {
                            m[(j * w + i0) as usize..=(j * w + i1) as usize].fill(true);
                        }
                    }
                }
                m
            })
            .collect();
        let n = masks.len();
        let mut pairwise = vec![vec![0u64; n]; n];
        let mut union = 0u64;
        let mut bboxes: Vec<Option<[u32; 4]>> = vec![None; n];
        let mut on = Vec::with_capacity(n);
        for p in 0..(w * h) as usize {
            on.clear();
            on.extend(
                masks
                    .iter()
                    .enumerate()
                    .filter(|(_, m)| m[p])
                    .map(|(k, _)| k),
            );
            if on.is_empty() {
                continue;
            }
            union += 1;
            let (i, j) = (p as u32 % w, p as u32 / w);
            for &a in &on {
                let b = bboxes[a].get_or_insert([i, i, j, j]);
                *b = [b[0].min(i), b[1].max(i), b[2].min(j), b[3].max(j)];
                for &c in &on {
                    pairwise[a][c] += 1;
                }
            }
        }
        let nodes: Vec<Footprint> = (0..n)
            .map(|k| Footprint {
                bbox: bboxes[k],
                covered: pairwise[k][k],
            })
            .collect();
        let sum: u64 = nodes.iter().map(|f| f.covered).sum();
        FootprintReport {
            overlap: if union > 0 {
                sum as f64 / union as f64
            } else {
                0.0
            },
            nodes,
            sum_covered: sum,
            union_covered: union,
            pairwise,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn morton_interleaves() {
        assert_eq!(morton3(1, 0, 0), 1);
        assert_eq!(morton3(0, 1, 0), 2);
        assert_eq!(morton3(0, 0, 1), 4);
        assert_eq!(morton3(3, 0, 0), 0b1001);
        assert_eq!(morton3(0x1f_ffff, 0x1f_ffff, 0x1f_ffff), (1u64 << 63) - 1);
    }

    #[test]
    fn targets_sum_and_differ_by_at_most_one() {
        for (m, n) in [(10, 3), (7, 7), (3, 5), (100, 8)] {
            let t = targets(m, n);
            assert_eq!(t.iter().sum::<usize>(), m);
            assert!(t.iter().max().unwrap() - t.iter().min().unwrap() <= 1);
        }
    }
}
