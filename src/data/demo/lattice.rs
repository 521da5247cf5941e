//! The Freudenthal (Kuhn) lattice over the solid and the extraction of the
//! kept tetrahedra into a mesh.

use super::*;

/// The 6 Freudenthal tetrahedra of a unit cube, as corner offsets, positively
/// oriented: for axis order `(a, b, c)`: 0, e_a, e_a + e_b, 1 (odd orders
/// have their middle two corners swapped).
pub(super) fn kuhn_templates() -> [[[usize; 3]; 4]; 6] {
    let mut out = [[[0usize; 3]; 4]; 6];
    for (m, p) in crate::data::lattice::KUHN_AXIS_ORDERS.iter().enumerate() {
        let mut c1 = [0usize; 3];
        c1[p[0]] = 1;
        let mut c2 = c1;
        c2[p[1]] = 1;
        let odd = matches!(m, 1 | 2 | 5);
        out[m] = if odd {
            [[0; 3], c2, c1, [1; 3]]
        } else {
            [[0; 3], c1, c2, [1; 3]]
        };
    }
    out
}

pub(super) struct Lattice {
    pub(super) origin: V3,
    pub(super) h: f64,
    pub(super) n: [usize; 3],
    pub(super) templates: [[[usize; 3]; 4]; 6],
}

impl Lattice {
    pub(super) fn vid(&self, i: usize, j: usize, k: usize) -> usize {
        i + self.n[0] * (j + self.n[1] * k)
    }
    pub(super) fn vijk(&self, v: usize) -> [usize; 3] {
        [
            v % self.n[0],
            (v / self.n[0]) % self.n[1],
            v / (self.n[0] * self.n[1]),
        ]
    }
    pub(super) fn pos(&self, v: usize) -> V3 {
        let [i, j, k] = self.vijk(v);
        [
            self.origin[0] + i as f64 * self.h,
            self.origin[1] + j as f64 * self.h,
            self.origin[2] + k as f64 * self.h,
        ]
    }
    pub(super) fn cubes(&self) -> [usize; 3] {
        [self.n[0] - 1, self.n[1] - 1, self.n[2] - 1]
    }
    /// Lattice vertex ids of lattice tetrahedron `t` (cube `t / 6`, template `t % 6`).
    pub(super) fn tet(&self, t: usize) -> [u32; 4] {
        let c = self.cubes();
        let cube = t / 6;
        let (i, j, k) = (cube % c[0], (cube / c[0]) % c[1], cube / (c[0] * c[1]));
        self.templates[t % 6].map(|o| self.vid(i + o[0], j + o[1], k + o[2]) as u32)
    }
    /// Lattice tetrahedra that have lattice vertex `v` as a corner.
    pub(super) fn tets_around(&self, v: usize) -> Vec<usize> {
        let [i, j, k] = self.vijk(v);
        let c = self.cubes();
        let mut out = Vec::new();
        for dk in 0..2 {
            for dj in 0..2 {
                for di in 0..2 {
                    if i < di
                        || j < dj
                        || k < dk
                        || i - di >= c[0]
                        || j - dj >= c[1]
                        || k - dk >= c[2]
                    {
                        continue;
                    }
                    let cube = (i - di) + c[0] * ((j - dj) + c[1] * (k - dk));
                    for (m, tpl) in self.templates.iter().enumerate() {
                        if tpl.contains(&[di, dj, dk]) {
                            out.push(cube * 6 + m);
                        }
                    }
                }
            }
        }
        out
    }
}

/// A mesh cut out of the lattice, with each mesh vertex's lattice id.
pub(super) struct Extracted {
    pub(super) mesh: TetMesh,
    pub(super) lattice_vertex: Vec<usize>,
    pub(super) lattice_tet: Vec<usize>,
}

pub(super) fn extract(lat: &Lattice, keep: &[bool]) -> Extracted {
    let nv = lat.n[0] * lat.n[1] * lat.n[2];
    let lattice_tet: Vec<usize> = (0..keep.len()).filter(|&t| keep[t]).collect();
    let mut used = vec![false; nv];
    for &t in &lattice_tet {
        for v in lat.tet(t) {
            used[v as usize] = true;
        }
    }
    let mut map = vec![u32::MAX; nv];
    let mut lattice_vertex = Vec::new();
    for v in 0..nv {
        if used[v] {
            map[v] = lattice_vertex.len() as u32;
            lattice_vertex.push(v);
        }
    }
    let tets = lattice_tet
        .iter()
        .map(|&t| lat.tet(t).map(|v| map[v as usize]))
        .collect();
    let points = lattice_vertex.iter().map(|&v| lat.pos(v)).collect();
    Extracted {
        mesh: TetMesh {
            points,
            tets,
            fields: Vec::new(),
        },
        lattice_vertex,
        lattice_tet,
    }
}
