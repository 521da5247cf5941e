//! Tetrahedron quality (smallest dihedral angle) and the vertex incidence
//! the relaxation uses.

use super::*;

/// Quality of a tetrahedron: `-cos` of its smallest dihedral angle (so it
/// grows with the angle, from -1 to 1), or -2 when its signed volume (VTK
/// orientation) is not positive.
pub(super) fn tet_quality(p: [V3; 4]) -> f64 {
    let vol6 = dot(sub(p[1], p[0]), cross(sub(p[2], p[0]), sub(p[3], p[0])));
    let l = norm(sub(p[1], p[0])).max(norm(sub(p[3], p[2])));
    if vol6.is_nan() || vol6 <= 1e-9 * l * l * l {
        return -2.0;
    }
    let mut n = [[0.0; 3]; 4];
    for (f, slots) in FACE_VERTICES.iter().enumerate() {
        let (a, b, c) = (p[slots[0]], p[slots[1]], p[slots[2]]);
        let mut nf = cross(sub(b, a), sub(c, a));
        if dot(nf, sub(p[f], a)) > 0.0 {
            nf = scale(nf, -1.0);
        }
        n[f] = normalize(nf);
    }
    let mut max_cos = -1.0f64;
    for i in 0..4 {
        for j in i + 1..4 {
            max_cos = max_cos.max(-dot(n[i], n[j]));
        }
    }
    -max_cos.clamp(-1.0, 1.0)
}

/// Smallest dihedral angle of a tetrahedron in degrees, or -1 when its signed
/// volume is not positive.
#[cfg(test)]
pub(super) fn min_dihedral_deg(p: [V3; 4]) -> f64 {
    let q = tet_quality(p);
    if q < -1.5 {
        -1.0
    } else {
        (-q).acos().to_degrees()
    }
}

/// Vertex → incident tetrahedra, compressed.
pub(super) struct Incidence {
    pub(super) start: Vec<u32>,
    pub(super) tets: Vec<u32>,
}

impl Incidence {
    /// The incidence of the vertices `wanted` marks (the others' lists
    /// are empty), each list in increasing tetrahedron order.
    pub(super) fn new(mesh: &TetMesh, wanted: impl Fn(usize) -> bool + Sync) -> Incidence {
        let mut count = vec![0u32; mesh.points.len() + 1];
        let mut marked = vec![false; mesh.points.len()];
        marked
            .par_iter_mut()
            .enumerate()
            .for_each(|(v, m)| *m = wanted(v));
        for t in &mesh.tets {
            for &v in t {
                if marked[v as usize] {
                    count[v as usize + 1] += 1;
                }
            }
        }
        for i in 1..count.len() {
            count[i] += count[i - 1];
        }
        let mut fill = count.clone();
        let mut tets = vec![0u32; count[mesh.points.len()] as usize];
        for (t, tet) in mesh.tets.iter().enumerate() {
            for &v in tet {
                if marked[v as usize] {
                    tets[fill[v as usize] as usize] = t as u32;
                    fill[v as usize] += 1;
                }
            }
        }
        Incidence { start: count, tets }
    }
    pub(super) fn of(&self, v: usize) -> &[u32] {
        &self.tets[self.start[v] as usize..self.start[v + 1] as usize]
    }
}

/// The qualities of the tetrahedra around `v` (in [`Incidence::of`] order)
/// if `v` were at `q`, when `ok` accepts every one (NaN qualities pass, as
/// `f64::min` skips them when the worst is taken); `None` at the first
/// that fails.
pub(super) fn qualities_around(
    mesh: &TetMesh,
    inc: &Incidence,
    v: usize,
    q: V3,
    ok: impl Fn(f64) -> bool,
) -> Option<Vec<f64>> {
    // Filled on the stack and copied out only when every one passes (most
    // vertices have at most 24 tetrahedra: the lattice's star).
    let ts = inc.of(v);
    let mut stack = [0.0f64; 32];
    let mut heap = Vec::new();
    for (i, &t) in ts.iter().enumerate() {
        let p = mesh.tets[t as usize].map(|w| {
            if w as usize == v {
                q
            } else {
                mesh.points[w as usize]
            }
        });
        let x = tet_quality(p);
        if !(x.is_nan() || ok(x)) {
            return None;
        }
        match stack.get_mut(i) {
            Some(slot) => *slot = x,
            None => heap.push(x),
        }
    }
    let head = &stack[..ts.len().min(stack.len())];
    Some(head.iter().copied().chain(heap).collect())
}
