//! Per-tetrahedron set-up for scan conversion: its four face planes and the
//! gradient of its linear scalar.
//!
//! **Watertightness by construction.** Two tetrahedra that share a face must
//! agree exactly on where a ray crosses it, or the ray would see a crack (or
//! a sliver of double coverage) between them and partial composition could not
//! merge their segments. So each face's plane `n · p = h` is computed from its
//! three vertices *sorted by position* (lexicographic `x, y, z`, then the
//! global vertex id for coincident vertices), never from the tet's own
//! vertex order: both neighbours get bit-identical `n` and `h`, and only the
//! orientation sign `sigma` (which side is inside) differs. Every later
//! formula is odd in `(n, h)` so the crossing depth is bit-identical too.
//!
//! The order is the vertices' own, not their numbering's: the copies of a
//! vertex that two pieces of a partitioned mesh both hold (solvers duplicate
//! the vertices on piece boundaries, each piece numbering its own) sort the
//! same in both, so the two cells that meet across the boundary agree on
//! their face wherever they are read and whatever ids they were given.

/// One face plane of a tet: `n · p = h`, outward normal `sigma * n`.
#[derive(Debug, Clone, Copy, Default)]
pub struct FacePlane {
    /// Normal from the sorted vertex triple (not unit length).
    pub n: [f32; 3],
    /// Plane offset, `n · a` for the face's first vertex `a` in the order.
    pub h: f32,
    /// `+1` if `n` points out of the tet, `-1` if in.
    pub sigma: f32,
}

/// A tet ready for scan conversion (in whichever space its vertices are given).
#[derive(Debug, Clone, Copy)]
pub struct TetSetup {
    /// Face `f` is opposite vertex slot `f`.
    pub faces: [FacePlane; 4],
    /// Gradient of the scalar.
    pub grad: [f32; 3],
    /// Position of vertex slot 0 (the gradient's origin).
    pub v0: [f32; 3],
    /// Scalar at vertex slot 0.
    pub s0: f32,
    /// Smallest vertex scalar (interpolated scalars are clamped to `[s_min, s_max]`
    /// so a sliver's ill-conditioned gradient cannot leave the tet's range).
    pub s_min: f32,
    /// Largest vertex scalar.
    pub s_max: f32,
}

#[inline(always)]
fn sub(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
#[inline(always)]
fn cross(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
#[inline(always)]
fn dot(a: [f32; 3], b: [f32; 3]) -> f32 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Whether slot `a` sorts after slot `b` in the vertex order: by position
/// (`x`, then `y`, then `z`, compared as numbers: the positions are finite),
/// then by global id (see the module docs). Only the two vertices' own
/// values decide, so every cell holding both orders them alike.
#[inline(always)]
fn after(ids: &[u32; 4], p: &[[f32; 3]; 4], a: usize, b: usize) -> bool {
    let (pa, pb) = (p[a], p[b]);
    if pa[0] != pb[0] {
        return pa[0] > pb[0];
    }
    if pa[1] != pb[1] {
        return pa[1] > pb[1];
    }
    if pa[2] != pb[2] {
        return pa[2] > pb[2];
    }
    ids[a] > ids[b]
}

/// Sets up the tet with global vertex ids `ids`, vertex positions `p` and
/// scalars `sv`. `None` for a tet with no volume (in f32): it covers no ray
/// stretch of positive length.
#[inline]
pub fn setup_tet(ids: [u32; 4], p: &[[f32; 3]; 4], sv: &[f32; 4]) -> Option<TetSetup> {
    // The slots in increasing vertex order (a sorting network): every
    // face's vertex triple is then this order with one vertex left out, so
    // it is sorted without sorting it again, and the edges from the lowest
    // vertex are shared by the three faces that hold it.
    // The swaps are selects, not branches: on a mesh's cells in depth
    // order each comparison goes either way at random.
    let mut o = [0usize, 1, 2, 3];
    for (a, b) in [(0, 1), (2, 3), (0, 2), (1, 3), (1, 2)] {
        let (x, y) = (o[a], o[b]);
        let m = (after(&ids, p, x, y) as usize).wrapping_neg() & (x ^ y);
        o[a] = x ^ m;
        o[b] = y ^ m;
    }
    let q = [p[o[0]], p[o[1]], p[o[2]], p[o[3]]];
    let (e01, e02, e03) = (sub(q[1], q[0]), sub(q[2], q[0]), sub(q[3], q[0]));
    // Face k (in sorted order) leaves out q[k]: `(a, normal)` with `a` its
    // lowest vertex, the normal `(b - a) x (c - a)` of its sorted triple.
    let sorted_faces = [
        (q[1], cross(sub(q[2], q[1]), sub(q[3], q[1]))),
        (q[0], cross(e02, e03)),
        (q[0], cross(e01, e03)),
        (q[0], cross(e01, e02)),
    ];
    let mut faces = [FacePlane::default(); 4];
    for (k, (a, n)) in sorted_faces.into_iter().enumerate() {
        let h = dot(n, a);
        let side = dot(n, q[k]) - h;
        if side == 0.0 || !side.is_finite() {
            return None;
        }
        faces[o[k]] = FacePlane {
            n,
            h,
            sigma: if side > 0.0 { -1.0 } else { 1.0 },
        };
    }
    let (e1, e2, e3) = (sub(p[1], p[0]), sub(p[2], p[0]), sub(p[3], p[0]));
    let (c23, c31, c12) = (cross(e2, e3), cross(e3, e1), cross(e1, e2));
    let det = dot(e1, c23);
    // Six times the volume. Rounding to f32 leaves a flat tet (e.g. four
    // collinear points) a volume of a few ulps of |e1||e2||e3| with face
    // normals that are pure noise; such a tet is treated as what it is,
    // degenerate. Its true thickness is below ~1e-6 of its edges, so nothing
    // visible is lost, and no neighbour depends on it to close a crack.
    let scale = (dot(e1, e1) * dot(e2, e2) * dot(e3, e3)).sqrt();
    if !(det.abs() > 1e-6 * scale) || !det.is_finite() {
        return None;
    }
    let (d1, d2, d3) = (sv[1] - sv[0], sv[2] - sv[0], sv[3] - sv[0]);
    let inv = 1.0 / det;
    let grad = [
        (d1 * c23[0] + d2 * c31[0] + d3 * c12[0]) * inv,
        (d1 * c23[1] + d2 * c31[1] + d3 * c12[1]) * inv,
        (d1 * c23[2] + d2 * c31[2] + d3 * c12[2]) * inv,
    ];
    let grad = if grad.iter().all(|g| g.is_finite()) {
        grad
    } else {
        [0.0; 3]
    };
    Some(TetSetup {
        faces,
        grad,
        v0: p[0],
        s0: sv[0],
        s_min: sv.iter().cloned().fold(f32::INFINITY, f32::min),
        s_max: sv.iter().cloned().fold(f32::NEG_INFINITY, f32::max),
    })
}

impl TetSetup {
    /// The scalar at point `q` (same space as the vertices), clamped to the tet's range.
    #[inline(always)]
    pub fn scalar_at(&self, q: [f32; 3]) -> f32 {
        let d = sub(q, self.v0);
        (self.s0 + dot(self.grad, d)).clamp(self.s_min, self.s_max)
    }
}
