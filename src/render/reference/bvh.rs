//! A bounding-volume hierarchy over axis-aligned boxes, in f64.
//!
//! Built by median split of the box centroids along the longest centroid
//! axis (deterministic: the same input always gives the same tree), with up to
//! [`LEAF_SIZE`] primitives per leaf. Every box is padded by a caller-given
//! margin so that a ray grazing a primitive exactly (an edge-on face, a ray
//! through a vertex) is never culled by round-off in the slab test: the
//! hierarchy only has to be conservative, the exact decisions are made by the
//! caller on the primitives themselves.

/// Largest number of primitives in a leaf.
const LEAF_SIZE: usize = 4;

/// Axis-aligned box `(lo, hi)`.
pub(crate) type Aabb = ([f64; 3], [f64; 3]);

#[derive(Debug, Clone, Copy)]
struct Node {
    lo: [f64; 3],
    hi: [f64; 3],
    /// Leaf: first primitive slot. Inner: index of the right child (the left
    /// child is the next node).
    a: u32,
    /// Leaf: number of primitives (> 0). Inner: 0.
    n: u32,
}

/// The hierarchy: nodes in depth-first order and the primitives' boxes.
#[derive(Debug, Clone, Default)]
pub(crate) struct Bvh {
    nodes: Vec<Node>,
    /// Padded primitive boxes in leaf order; `a` is the primitive id.
    boxes: Vec<Node>,
}

impl Bvh {
    /// Builds the hierarchy over `boxes`; primitive `k` is `boxes[k]`. Each
    /// box is grown by `pad` on every side.
    pub(crate) fn build(boxes: &[Aabb], pad: f64) -> Bvh {
        let mut prims: Vec<u32> = (0..boxes.len() as u32).collect();
        let cent: Vec<[f64; 3]> = boxes
            .iter()
            .map(|(lo, hi)| {
                [
                    0.5 * (lo[0] + hi[0]),
                    0.5 * (lo[1] + hi[1]),
                    0.5 * (lo[2] + hi[2]),
                ]
            })
            .collect();
        let mut nodes = Vec::with_capacity(2 * boxes.len() / LEAF_SIZE + 2);
        if !boxes.is_empty() {
            build_rec(&mut nodes, &mut prims, 0, boxes, &cent, pad);
        }
        let boxes = prims
            .iter()
            .map(|&p| {
                let (lo, hi) = boxes[p as usize];
                Node {
                    lo: lo.map(|v| v - pad),
                    hi: hi.map(|v| v + pad),
                    a: p,
                    n: 1,
                }
            })
            .collect();
        Bvh { nodes, boxes }
    }

    /// Calls `f` with every primitive whose (padded) box meets the ray
    /// `o + t d`, `t` in `[t_min, t_max]`. Order is deterministic.
    pub(crate) fn for_each_on_ray(
        &self,
        o: [f64; 3],
        d: [f64; 3],
        t_min: f64,
        t_max: f64,
        mut f: impl FnMut(u32),
    ) {
        if self.nodes.is_empty() {
            return;
        }
        let inv = [1.0 / d[0], 1.0 / d[1], 1.0 / d[2]];
        let hit = |n: &Node| -> bool {
            let (mut t0, mut t1) = (t_min, t_max);
            for k in 0..3 {
                if d[k] == 0.0 {
                    if o[k] < n.lo[k] || o[k] > n.hi[k] {
                        return false;
                    }
                } else {
                    let a = (n.lo[k] - o[k]) * inv[k];
                    let b = (n.hi[k] - o[k]) * inv[k];
                    t0 = t0.max(a.min(b));
                    t1 = t1.min(a.max(b));
                }
            }
            t0 <= t1
        };
        self.traverse(hit, &mut f);
    }

    /// Calls `f` with every primitive whose (padded) box contains `p`.
    pub(crate) fn for_each_containing(&self, p: [f64; 3], mut f: impl FnMut(u32)) {
        if self.nodes.is_empty() {
            return;
        }
        let hit = |n: &Node| (0..3).all(|k| p[k] >= n.lo[k] && p[k] <= n.hi[k]);
        self.traverse(hit, &mut f);
    }

    fn traverse(&self, hit: impl Fn(&Node) -> bool, f: &mut impl FnMut(u32)) {
        let mut stack: Vec<u32> = Vec::with_capacity(64);
        stack.push(0);
        while let Some(i) = stack.pop() {
            let node = &self.nodes[i as usize];
            if !hit(node) {
                continue;
            }
            if node.n > 0 {
                for b in &self.boxes[node.a as usize..(node.a + node.n) as usize] {
                    if hit(b) {
                        f(b.a);
                    }
                }
            } else {
                // Push right first so the left subtree is visited first.
                stack.push(node.a);
                stack.push(i + 1);
            }
        }
    }
}

fn build_rec(
    nodes: &mut Vec<Node>,
    idx: &mut [u32],
    offset: usize,
    boxes: &[Aabb],
    cent: &[[f64; 3]],
    pad: f64,
) -> u32 {
    let me = nodes.len();
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    let mut clo = [f64::INFINITY; 3];
    let mut chi = [f64::NEG_INFINITY; 3];
    for &p in idx.iter() {
        let (bl, bh) = boxes[p as usize];
        let c = cent[p as usize];
        for k in 0..3 {
            lo[k] = lo[k].min(bl[k] - pad);
            hi[k] = hi[k].max(bh[k] + pad);
            clo[k] = clo[k].min(c[k]);
            chi[k] = chi[k].max(c[k]);
        }
    }
    nodes.push(Node {
        lo,
        hi,
        a: offset as u32,
        n: idx.len() as u32,
    });
    let ext = [chi[0] - clo[0], chi[1] - clo[1], chi[2] - clo[2]];
    let axis = if ext[0] >= ext[1] && ext[0] >= ext[2] {
        0
    } else if ext[1] >= ext[2] {
        1
    } else {
        2
    };
    // Leaf when small, or when every centroid coincides (cannot be split
    // meaningfully; a NaN extent also ends here).
    if idx.len() <= LEAF_SIZE || ext[axis].is_nan() || ext[axis] <= 0.0 {
        return me as u32;
    }
    let mid = idx.len() / 2;
    idx.select_nth_unstable_by(mid, |&a, &b| {
        cent[a as usize][axis]
            .total_cmp(&cent[b as usize][axis])
            .then(a.cmp(&b))
    });
    let (l, r) = idx.split_at_mut(mid);
    build_rec(nodes, l, offset, boxes, cent, pad);
    let right = build_rec(nodes, r, offset + mid, boxes, cent, pad);
    nodes[me].a = right;
    nodes[me].n = 0;
    me as u32
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ray_and_point_queries_find_exactly_the_overlapping_boxes() {
        // A 10 x 10 row of unit boxes along x.
        let boxes: Vec<Aabb> = (0..100)
            .map(|k| ([k as f64, 0.0, 0.0], [k as f64 + 1.0, 1.0, 1.0]))
            .collect();
        let bvh = Bvh::build(&boxes, 0.0);
        let mut hits = Vec::new();
        bvh.for_each_on_ray([-5.0, 0.5, 0.5], [1.0, 0.0, 0.0], 0.0, 10.0, |p| {
            hits.push(p)
        });
        hits.sort_unstable();
        assert_eq!(hits, (0..6).collect::<Vec<_>>());
        let mut hits = Vec::new();
        bvh.for_each_containing([42.5, 0.5, 0.5], |p| hits.push(p));
        assert_eq!(hits, vec![42]);
        // On the shared face of two boxes: both.
        let mut hits = Vec::new();
        bvh.for_each_containing([42.0, 0.5, 0.5], |p| hits.push(p));
        hits.sort_unstable();
        assert_eq!(hits, vec![41, 42]);
        // Axis-parallel ray exactly on the boxes' top face: all of them.
        let mut n = 0;
        bvh.for_each_on_ray(
            [-1.0, 1.0, 1.0],
            [1.0, 0.0, 0.0],
            0.0,
            f64::INFINITY,
            |_| n += 1,
        );
        assert_eq!(n, 100);
    }
}
