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
    /// The cube (lattice indices of its first corner) of lattice
    /// tetrahedron `t`.
    pub(super) fn cube_of(&self, t: usize) -> [usize; 3] {
        let c = self.cubes();
        let cube = t / 6;
        [cube % c[0], (cube / c[0]) % c[1], cube / (c[0] * c[1])]
    }
    /// The lattice tetrahedron across face `f` of template `m` in cube
    /// `ijk`, or `None` outside the lattice.
    pub(super) fn across(
        &self,
        table: &FaceTable,
        ijk: [usize; 3],
        m: usize,
        f: usize,
    ) -> Option<usize> {
        let c = self.cubes();
        let (d, m2) = table[m][f];
        let mut n = [0usize; 3];
        for k in 0..3 {
            let v = ijk[k] as i64 + d[k];
            if v < 0 || v >= c[k] as i64 {
                return None;
            }
            n[k] = v as usize;
        }
        Some((n[0] + c[0] * (n[1] + c[1] * n[2])) * 6 + m2)
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

/// The lattice tetrahedra whose four vertices are inside, one flag each:
/// per cube, from its eight corners, layer by layer.
pub(super) fn select(lat: &Lattice, inside: &[bool]) -> Vec<bool> {
    let c = lat.cubes();
    // Corner bit of each template corner.
    let bits = lat.templates.map(|tpl| {
        tpl.iter()
            .fold(0u8, |m, o| m | 1 << (o[0] + 2 * o[1] + 4 * o[2]))
    });
    let mut keep = vec![false; c[0] * c[1] * c[2] * 6];
    keep.par_chunks_mut(c[0] * c[1] * 6)
        .enumerate()
        .for_each(|(k, layer)| {
            for j in 0..c[1] {
                for i in 0..c[0] {
                    let mut corners = 0u8;
                    for corner in 0..8 {
                        let v = lat.vid(i + (corner & 1), j + (corner >> 1 & 1), k + (corner >> 2));
                        corners |= (inside[v] as u8) << corner;
                    }
                    let cube = &mut layer[(i + c[0] * j) * 6..][..6];
                    for (flag, &b) in cube.iter_mut().zip(&bits) {
                        *flag = corners & b == b;
                    }
                }
            }
        });
    keep
}

/// Cube-ordered walk over the kept tetrahedra: `visit(t, ijk, m)` for each
/// kept lattice tetrahedron `t` (cube `ijk`, template `m`), the cube layers
/// split over the pool; the per-layer results are concatenated in order.
pub(super) fn per_layer<T: Send>(
    lat: &Lattice,
    keep: &[bool],
    visit: impl Fn(usize, [usize; 3], usize, &mut Vec<T>) + Sync,
) -> Vec<T> {
    let c = lat.cubes();
    let layers: Vec<Vec<T>> = (0..c[2])
        .into_par_iter()
        .map(|k| {
            let mut out = Vec::new();
            for j in 0..c[1] {
                for i in 0..c[0] {
                    let cube = i + c[0] * (j + c[1] * k);
                    for m in 0..6 {
                        let t = cube * 6 + m;
                        if keep[t] {
                            visit(t, [i, j, k], m, &mut out);
                        }
                    }
                }
            }
            out
        })
        .collect();
    let mut all = Vec::with_capacity(layers.iter().map(Vec::len).sum());
    for mut layer in layers {
        all.append(&mut layer);
    }
    all
}

/// Index of each kept lattice tetrahedron among the kept ones, in lattice
/// order (its index in the extracted mesh): a bitset of `keep` and the count
/// of kept ones before each 64-bit word.
pub(super) struct Ranks {
    words: Vec<u64>,
    before: Vec<u32>,
}

impl Ranks {
    pub(super) fn new(keep: &[bool]) -> Ranks {
        let words: Vec<u64> = keep
            .par_chunks(64)
            .map(|c| {
                c.iter()
                    .enumerate()
                    .fold(0u64, |w, (i, &k)| w | (k as u64) << i)
            })
            .collect();
        let mut before = Vec::with_capacity(words.len());
        let mut acc = 0u32;
        for w in &words {
            before.push(acc);
            acc += w.count_ones();
        }
        Ranks { words, before }
    }

    /// Kept tetrahedra in all.
    pub(super) fn count(&self) -> u32 {
        self.before.last().copied().unwrap_or(0) + self.words.last().map_or(0, |w| w.count_ones())
    }

    /// Kept tetrahedra before lattice tetrahedron `t`.
    pub(super) fn of(&self, t: usize) -> u32 {
        let (w, b) = (t / 64, t % 64);
        self.before[w] + (self.words[w] & ((1u64 << b) - 1)).count_ones()
    }
}

/// A mesh cut out of the lattice, with each mesh vertex's lattice id.
pub(super) struct Extracted {
    pub(super) mesh: TetMesh,
    pub(super) lattice_vertex: Vec<usize>,
    pub(super) lattice_tet: Vec<usize>,
}

pub(super) fn extract(lat: &Lattice, keep: &[bool]) -> Extracted {
    let c = lat.cubes();
    let lattice_tet: Vec<usize> = per_layer(lat, keep, |t, _, _, out| out.push(t));
    // Used vertices, one lattice layer at a time: vertex layer k is touched
    // by the cube layers k - 1 and k.
    let layer = lat.n[0] * lat.n[1];
    let mut used = vec![false; layer * lat.n[2]];
    used.par_chunks_mut(layer)
        .enumerate()
        .for_each(|(k, flags)| {
            for ck in [k.wrapping_sub(1), k] {
                if ck >= c[2] {
                    continue;
                }
                for j in 0..c[1] {
                    for i in 0..c[0] {
                        let cube = i + c[0] * (j + c[1] * ck);
                        for (m, tpl) in lat.templates.iter().enumerate() {
                            if !keep[cube * 6 + m] {
                                continue;
                            }
                            for o in tpl {
                                if ck + o[2] == k {
                                    flags[i + o[0] + lat.n[0] * (j + o[1])] = true;
                                }
                            }
                        }
                    }
                }
            }
        });
    // Mesh vertex ids in lattice order: per-layer counts, then a prefix.
    let counts: Vec<u32> = used
        .par_chunks(layer)
        .map(|f| f.iter().filter(|&&u| u).count() as u32)
        .collect();
    let mut first = Vec::with_capacity(counts.len());
    let mut acc = 0u32;
    for n in &counts {
        first.push(acc);
        acc += n;
    }
    let mut map = vec![u32::MAX; used.len()];
    map.par_chunks_mut(layer)
        .zip(used.par_chunks(layer))
        .zip(&first)
        .for_each(|((ids, flags), &start)| {
            let mut next = start;
            for (id, &u) in ids.iter_mut().zip(flags) {
                if u {
                    *id = next;
                    next += 1;
                }
            }
        });
    let lattice_vertex: Vec<usize> = (0..used.len())
        .into_par_iter()
        .filter(|&v| used[v])
        .collect();
    drop(used);
    let tets = lattice_tet
        .par_iter()
        .map(|&t| lat.tet(t).map(|v| map[v as usize]))
        .collect();
    let points = lattice_vertex.par_iter().map(|&v| lat.pos(v)).collect();
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

/// Per template and face: the other tetrahedron's cube offset and template.
pub(super) type FaceTable = [[([i64; 3], usize); 4]; 6];

/// For lattice template `m` and its face `f` (opposite corner `f`): the
/// cube offset and template of the other lattice tetrahedron with that face.
pub(super) fn face_table(templates: &[[[usize; 3]; 4]; 6]) -> FaceTable {
    let mut out = [[([0i64; 3], 0usize); 4]; 6];
    for (m, tpl) in templates.iter().enumerate() {
        for (f, slot) in out[m].iter_mut().enumerate() {
            let face: Vec<[i64; 3]> = (0..4)
                .filter(|&i| i != f)
                .map(|i| tpl[i].map(|c| c as i64))
                .collect();
            let mut found = None;
            'search: for dz in -1..=1i64 {
                for dy in -1..=1i64 {
                    for dx in -1..=1i64 {
                        for (m2, t2) in templates.iter().enumerate() {
                            if [dx, dy, dz] == [0; 3] && m2 == m {
                                continue;
                            }
                            let corners =
                                t2.map(|c| [c[0] as i64 + dx, c[1] as i64 + dy, c[2] as i64 + dz]);
                            if face.iter().all(|p| corners.contains(p)) {
                                found = Some(([dx, dy, dz], m2));
                                break 'search;
                            }
                        }
                    }
                }
            }
            // The Kuhn subdivision is conforming: every face has a partner.
            *slot = found.unwrap_or(([i64::MAX; 3], 0));
        }
    }
    out
}

/// The face adjacency of an extracted mesh, from the lattice (the same as
/// [`TetMesh::adjacency`], which sorts all faces, but in linear time): the
/// neighbour across a face is the lattice tetrahedron on its other side if
/// it is kept. A subset of a conforming lattice has no face shared by more
/// than two tetrahedra.
pub(super) fn lattice_adjacency(lat: &Lattice, keep: &[bool], ex: &Extracted) -> Adjacency {
    // Rank of a kept lattice tetrahedron = its mesh index.
    let ranks = Ranks::new(keep);
    let table = face_table(&lat.templates);
    let neighbors = ex
        .lattice_tet
        .par_iter()
        .map(|&t| {
            let ijk = lat.cube_of(t);
            std::array::from_fn(|f| match lat.across(&table, ijk, t % 6, f) {
                Some(nt) if keep[nt] => ranks.of(nt),
                _ => NO_NEIGHBOR,
            })
        })
        .collect();
    Adjacency {
        neighbors,
        nonmanifold_faces: 0,
    }
}
