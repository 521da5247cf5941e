//! Step 3 of the generator, worked on the lattice itself: pinch repair,
//! peeling and the largest component, read straight from the kept set
//! (`keep`, one flag a lattice tetrahedron) with lattice vertex ids. Nothing
//! is extracted until the kept set is final: extracting 20 M tetrahedra
//! (1.3 s) at every repair round was most of the generator's time.
//!
//! The results are the same as repairing an extracted mesh: extraction
//! numbers vertices and tetrahedra in lattice order, so every sorted list
//! (bad edges, bad vertices, components in order of their first
//! tetrahedron) comes out in the same order.

use super::*;

/// Which faces of template `m` in cube `ijk` lie on the boundary of the
/// kept set (bit `f`: the face opposite corner `f`, whose other side is not
/// kept or outside the lattice).
fn boundary_mask(lat: &Lattice, table: &FaceTable, keep: &[bool], ijk: [usize; 3], m: usize) -> u8 {
    (0..4)
        .filter(|&f| !lat.across(table, ijk, m, f).is_some_and(|nt| keep[nt]))
        .fold(0, |mask, f| mask | 1 << f)
}

/// The kept tetrahedra with a face on the boundary of the kept set, each
/// with its [`boundary_mask`].
fn boundary_tets(lat: &Lattice, keep: &[bool]) -> Vec<(usize, u8)> {
    let table = face_table(&lat.templates);
    per_layer(lat, keep, |t, ijk, m, out| {
        let mask = boundary_mask(lat, &table, keep, ijk, m);
        if mask != 0 {
            out.push((t, mask));
        }
    })
}

/// The boundary triangles of the kept set, in lattice vertex ids.
fn triangles(lat: &Lattice, faces: &[(usize, u8)]) -> Vec<[u32; 3]> {
    let mut out = Vec::new();
    for &(t, mask) in faces {
        let tet = lat.tet(t);
        for (f, s) in FACE_VERTICES.iter().enumerate() {
            if mask & (1 << f) != 0 {
                out.push([tet[s[0]], tet[s[1]], tet[s[2]]]);
            }
        }
    }
    out
}

/// The kept lattice tetrahedra, and which flags changed since the set was
/// last made one face-connected component (`None`: not known to be).
pub(super) struct KeptSet {
    pub(super) keep: Vec<bool>,
    since_connected: Option<Vec<usize>>,
}

impl KeptSet {
    pub(super) fn new(keep: Vec<bool>) -> KeptSet {
        KeptSet {
            keep,
            since_connected: None,
        }
    }

    fn set(&mut self, t: usize, kept: bool) {
        if self.keep[t] != kept {
            self.keep[t] = kept;
            if let Some(changed) = &mut self.since_connected {
                changed.push(t);
            }
        }
    }
}

/// Repairs boundary pinches of the kept set (all lattice tetrahedra around a
/// bad edge or vertex are added or removed, by majority) and drops all but
/// the largest face-connected component. `touched`: the tetrahedra set
/// since the kept set was last free of defects (after a [`peel`]), `None`
/// for a first look at the whole set.
pub(super) fn clean(lat: &Lattice, kept: &mut KeptSet, mut touched: Option<Vec<usize>>) {
    // After the first round, defects can only be at the vertices and edges
    // of what the previous round's groups set.
    for _ in 0..50 {
        let (bad_e, bad_v) = match &touched {
            None => boundary_defects(&triangles(lat, &boundary_tets(lat, &kept.keep))),
            Some(ts) => defects_near(lat, &kept.keep, ts),
        };
        if bad_e.is_empty() && bad_v.is_empty() {
            break;
        }
        touched = Some(repair(lat, kept, &bad_e, &bad_v));
    }
    match kept.since_connected.take() {
        Some(changed) if still_connected(lat, &kept.keep, &changed) => {}
        _ => keep_largest_component(lat, &mut kept.keep),
    }
    kept.since_connected = Some(Vec::new());
}

/// One repair round: the lattice tetrahedra around each bad edge, then
/// around each bad vertex, all added or all removed by majority, in that
/// order; returns every tetrahedron of those groups.
fn repair(lat: &Lattice, kept: &mut KeptSet, bad_e: &[[u32; 2]], bad_v: &[u32]) -> Vec<usize> {
    let mut groups: Vec<Vec<usize>> = Vec::new();
    for e in bad_e {
        let a = lat.tets_around(e[0] as usize);
        let b = lat.tets_around(e[1] as usize);
        groups.push(a.into_iter().filter(|t| b.contains(t)).collect());
    }
    for &v in bad_v {
        groups.push(lat.tets_around(v as usize));
    }
    let mut round = Vec::new();
    for g in groups {
        let n = g.iter().filter(|&&t| kept.keep[t]).count();
        let fill = 2 * n >= g.len();
        for &t in &g {
            kept.set(t, fill);
        }
        round.extend(g);
    }
    round
}

/// The boundary defects (as [`boundary_defects`] finds them on the whole
/// kept set) at the vertices and edges of the lattice tetrahedra `touched`,
/// from the boundary triangles around those vertices. A vertex's or edge's
/// triangles are faces of the tetrahedra around it, so where none of those
/// changed since a defect-free check (every earlier defect's own group is
/// among `touched`), nothing changed: the lists equal the global ones.
fn defects_near(lat: &Lattice, keep: &[bool], touched: &[usize]) -> (Vec<[u32; 2]>, Vec<u32>) {
    let mut verts: Vec<u32> = Vec::new();
    let mut edges: Vec<[u32; 2]> = Vec::new();
    for &t in touched {
        let v = lat.tet(t);
        verts.extend(v);
        for (a, b) in [(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)] {
            edges.push([v[a].min(v[b]), v[a].max(v[b])]);
        }
    }
    verts.sort_unstable();
    verts.dedup();
    edges.sort_unstable();
    edges.dedup();
    let table = face_table(&lat.templates);
    // Every kept tetrahedron with a boundary face around a candidate
    // vertex, once.
    let mut faces: Vec<(usize, u8)> = Vec::new();
    for &v in &verts {
        for t in lat.tets_around(v as usize) {
            if keep[t] {
                let mask = boundary_mask(lat, &table, keep, lat.cube_of(t), t % 6);
                if mask != 0 {
                    faces.push((t, mask));
                }
            }
        }
    }
    faces.sort_unstable();
    faces.dedup();
    let (bad_e, bad_v) = boundary_defects(&triangles(lat, &faces));
    (
        bad_e
            .into_iter()
            .filter(|e| edges.binary_search(e).is_ok())
            .collect(),
        bad_v
            .into_iter()
            .filter(|v| verts.binary_search(v).is_ok())
            .collect(),
    )
}

/// Removes the kept tetrahedra whose four vertices all lie on the boundary
/// and that have a boundary face (snapping would flatten them); which.
pub(super) fn peel(lat: &Lattice, kept: &mut KeptSet) -> Vec<usize> {
    let faces = boundary_tets(lat, &kept.keep);
    let mut on_boundary = vec![false; lat.n[0] * lat.n[1] * lat.n[2]];
    for tri in triangles(lat, &faces) {
        for v in tri {
            on_boundary[v as usize] = true;
        }
    }
    let mut peeled = Vec::new();
    for &(t, _) in &faces {
        if lat.tet(t).iter().all(|&v| on_boundary[v as usize]) {
            kept.set(t, false);
            peeled.push(t);
        }
    }
    peeled
}

/// Union-find whose roots are the smallest members.
struct UnionFind(Vec<u32>);

impl UnionFind {
    fn new(n: usize) -> UnionFind {
        UnionFind((0..n as u32).collect())
    }
    fn find(&mut self, mut a: u32) -> u32 {
        let p = &mut self.0;
        while p[a as usize] != a {
            let up = p[p[a as usize] as usize];
            p[a as usize] = up;
            a = up;
        }
        a
    }
    fn union(&mut self, a: u32, b: u32) {
        let (a, b) = (self.find(a), self.find(b));
        let (lo, hi) = (a.min(b), a.max(b));
        self.0[hi as usize] = lo;
    }
}

/// How far (in cubes) around a cluster of changed tetrahedra
/// [`still_connected`] looks for paths between its seeds.
const REACH: usize = 2;
/// Clusters whose box would hold more lattice tetrahedra than this are not
/// checked locally.
const MAX_BOX_TETS: usize = 1 << 21;

/// Whether a kept set that was one face-connected component is still one
/// after the flags of `changed` flipped, shown locally (`false` when it
/// cannot be shown, not necessarily split). Clusters are the face-connected
/// groups of changed tetrahedra; a cluster's seeds are the kept tetrahedra
/// among or next to it. Any old path between two surviving tetrahedra
/// leaves and re-enters the kept set only through seeds of one cluster, so
/// it suffices that each cluster's seeds are connected (here: inside the
/// cluster's box grown by [`REACH`] cubes) and that at least one of them is
/// unchanged (added tetrahedra then join the old set).
fn still_connected(lat: &Lattice, keep: &[bool], changed: &[usize]) -> bool {
    let mut sorted = changed.to_vec();
    sorted.sort_unstable();
    sorted.dedup();
    let c = lat.cubes();
    let table = face_table(&lat.templates);
    let neighbours = |t: usize| {
        let ijk = lat.cube_of(t);
        (0..4).filter_map(move |f| lat.across(&table, ijk, t % 6, f))
    };
    let mut clusters = UnionFind::new(sorted.len());
    for (a, &t) in sorted.iter().enumerate() {
        for nt in neighbours(t) {
            if let Ok(b) = sorted.binary_search(&nt) {
                clusters.union(a as u32, b as u32);
            }
        }
    }
    let mut members: Vec<Vec<usize>> = vec![Vec::new(); sorted.len()];
    for (a, &t) in sorted.iter().enumerate() {
        members[clusters.find(a as u32) as usize].push(t);
    }
    members.par_iter().filter(|m| !m.is_empty()).all(|cluster| {
        // The cluster's box, grown by REACH cubes and clipped to the lattice.
        let mut lo = [usize::MAX; 3];
        let mut hi = [0usize; 3];
        for &t in cluster {
            let ijk = lat.cube_of(t);
            for k in 0..3 {
                lo[k] = lo[k].min(ijk[k].saturating_sub(REACH));
                hi[k] = hi[k].max((ijk[k] + REACH).min(c[k] - 1));
            }
        }
        let size = [0, 1, 2].map(|k| hi[k] - lo[k] + 1);
        if size[0] * size[1] * size[2] * 6 > MAX_BOX_TETS {
            return false;
        }
        let local = |t: usize| {
            let ijk = lat.cube_of(t);
            if (0..3).any(|k| ijk[k] < lo[k] || ijk[k] > hi[k]) {
                return None;
            }
            let [i, j, k] = [0, 1, 2].map(|a| ijk[a] - lo[a]);
            Some(((k * size[1] + j) * size[0] + i) * 6 + t % 6)
        };
        let mut seeds = Vec::new();
        let mut unchanged = false;
        for &t in cluster {
            for s in std::iter::once(t).chain(neighbours(t)) {
                if keep[s] {
                    seeds.push(s);
                    unchanged |= sorted.binary_search(&s).is_err();
                }
            }
        }
        if seeds.is_empty() {
            return true;
        }
        if !unchanged {
            return false;
        }
        // Flood the kept tetrahedra of the box from the first seed.
        let mut reached = vec![false; size[0] * size[1] * size[2] * 6];
        let mut stack = vec![seeds[0]];
        if let Some(l) = local(seeds[0]) {
            reached[l] = true;
        }
        while let Some(t) = stack.pop() {
            for nt in neighbours(t) {
                if let (true, Some(l)) = (keep[nt], local(nt)) {
                    if !reached[l] {
                        reached[l] = true;
                        stack.push(nt);
                    }
                }
            }
        }
        seeds.iter().all(|&s| local(s).is_some_and(|l| reached[l]))
    })
}

/// Calls `visit(t, cube_on_border)` for each kept lattice tetrahedron in
/// lattice order, without divisions; `cube_on_border[axis]` says whether
/// the cube is first (bit 0) or last (bit 1) along that axis.
fn for_each_kept(lat: &Lattice, keep: &[bool], mut visit: impl FnMut(usize, [u8; 3])) {
    let c = lat.cubes();
    let edge = |i: usize, n: usize| (i == 0) as u8 | ((i + 1 == n) as u8) << 1;
    let mut t = 0;
    for k in 0..c[2] {
        for j in 0..c[1] {
            for i in 0..c[0] {
                let border = [edge(i, c[0]), edge(j, c[1]), edge(k, c[2])];
                for (m, &kept) in keep[t..t + 6].iter().enumerate() {
                    if kept {
                        visit(t + m, border);
                    }
                }
                t += 6;
            }
        }
    }
}

/// Keeps only the largest face-connected component of the kept set (ties:
/// the one whose first tetrahedron comes first), by union-find in lattice
/// order over mesh indices (ranks): each face joins a tetrahedron to the
/// earlier one across it, and every set's root is its first tetrahedron.
fn keep_largest_component(lat: &Lattice, keep: &mut [bool]) {
    let ranks = Ranks::new(keep);
    let table = face_table(&lat.templates);
    let c = lat.cubes();
    // Per template: the faces whose other side comes earlier in lattice
    // order, with its offset in lattice tetrahedra and the border bits that
    // put it outside the lattice.
    let stride = [6i64, 6 * c[0] as i64, 6 * (c[0] * c[1]) as i64];
    let earlier: [Vec<(i64, [u8; 3])>; 6] = std::array::from_fn(|m| {
        table[m]
            .iter()
            .map(|&(d, m2)| {
                let delta = (0..3).map(|k| d[k] * stride[k]).sum::<i64>() + m2 as i64 - m as i64;
                let out = d.map(|x| {
                    if x < 0 {
                        1u8
                    } else if x > 0 {
                        2
                    } else {
                        0
                    }
                });
                (delta, out)
            })
            .filter(|&(delta, _)| delta < 0)
            .collect()
    });
    let n = ranks.count() as usize;
    let mut sets = UnionFind::new(n);
    let mut r = 0u32;
    for_each_kept(lat, keep, |t, border| {
        for &(delta, out) in &earlier[t % 6] {
            if (0..3).any(|k| border[k] & out[k] != 0) {
                continue;
            }
            let nt = (t as i64 + delta) as usize;
            if keep[nt] {
                sets.union(r, ranks.of(nt));
            }
        }
        r += 1;
    });
    // Every set's root is its smallest member: in increasing order, each
    // element's parent already points at its root after one step.
    let parent = &mut sets.0;
    let mut size = vec![0u32; n];
    let mut roots = 0usize;
    for r in 0..n {
        let root = parent[parent[r] as usize];
        parent[r] = root;
        roots += (root as usize == r) as usize;
        size[root as usize] += 1;
    }
    if roots <= 1 {
        return;
    }
    // Largest, and among equals the first: roots are first tetrahedra.
    let largest = (0..n)
        .max_by_key(|&r| (size[r], std::cmp::Reverse(r)))
        .unwrap_or(0) as u32;
    let mut drop = Vec::new();
    let mut r = 0usize;
    for_each_kept(lat, keep, |t, _| {
        if parent[r] != largest {
            drop.push(t);
        }
        r += 1;
    });
    for t in drop {
        keep[t] = false;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lattice(n: [usize; 3]) -> Lattice {
        Lattice {
            origin: [0.0; 3],
            h: 1.0,
            n,
            templates: kuhn_templates(),
        }
    }

    /// A ball of lattice tetrahedra with a ragged boundary (pinches and
    /// loose pieces), from a hash of each tetrahedron's index.
    fn ragged_ball(lat: &Lattice, seed: usize) -> Vec<bool> {
        let c = lat.cubes();
        let mid = c.map(|x| x as f64 / 2.0);
        (0..c[0] * c[1] * c[2] * 6)
            .map(|t| {
                let ijk = lat.cube_of(t);
                let r2: f64 = (0..3).map(|k| (ijk[k] as f64 + 0.5 - mid[k]).powi(2)).sum();
                let noise = ((t + seed) * 2_654_435_761 % 1000) as f64 / 1000.0;
                r2 < 9.0 + 8.0 * noise
            })
            .collect()
    }

    fn global_defects(lat: &Lattice, keep: &[bool]) -> (Vec<[u32; 2]>, Vec<u32>) {
        boundary_defects(&triangles(lat, &boundary_tets(lat, keep)))
    }

    fn pieces(lat: &Lattice, keep: &[bool]) -> usize {
        let ex = extract(lat, keep);
        components(&lattice_adjacency(lat, keep, &ex)).1
    }

    #[test]
    fn defects_near_a_repair_round_equal_the_global_ones() {
        let lat = lattice([12, 11, 10]);
        let mut rounds_with_defects = 0;
        for seed in 0..6 {
            let mut kept = KeptSet::new(ragged_ball(&lat, seed));
            for _ in 0..20 {
                let (bad_e, bad_v) = global_defects(&lat, &kept.keep);
                if bad_e.is_empty() && bad_v.is_empty() {
                    break;
                }
                rounds_with_defects += 1;
                let touched = repair(&lat, &mut kept, &bad_e, &bad_v);
                assert_eq!(
                    defects_near(&lat, &kept.keep, &touched),
                    global_defects(&lat, &kept.keep)
                );
            }
        }
        assert!(rounds_with_defects >= 6, "the ragged balls have defects");
    }

    #[test]
    fn the_local_proof_of_one_piece_holds_and_sees_a_cut() {
        let lat = lattice([12, 11, 10]);
        let mut keep = ragged_ball(&lat, 1);
        keep_largest_component(&lat, &mut keep);
        assert_eq!(pieces(&lat, &keep), 1);
        // One tetrahedron deep inside: still one piece, and shown so.
        let inner = (0..keep.len())
            .find(|&t| keep[t] && lat.cube_of(t) == [5, 5, 4])
            .unwrap();
        let mut one = keep.clone();
        one[inner] = false;
        assert!(still_connected(&lat, &one, &[inner]));
        // A whole layer of cubes removed: two pieces, never called one.
        let layer: Vec<usize> = (0..keep.len())
            .filter(|&t| keep[t] && lat.cube_of(t)[2] == 4)
            .collect();
        let mut cut = keep.clone();
        for &t in &layer {
            cut[t] = false;
        }
        assert!(pieces(&lat, &cut) > 1);
        assert!(!still_connected(&lat, &cut, &layer));
        // Random removals: whenever the proof says one piece, it is one.
        let mut shown = 0;
        for seed in 0..40usize {
            let removed: Vec<usize> = (0..keep.len())
                .filter(|&t| keep[t] && (t + seed) * 2_654_435_761 % 97 == 0)
                .collect();
            let mut k = keep.clone();
            for &t in &removed {
                k[t] = false;
            }
            if still_connected(&lat, &k, &removed) {
                shown += 1;
                assert_eq!(pieces(&lat, &k), 1, "seed {seed}");
            }
        }
        assert!(shown > 0);
    }
}
