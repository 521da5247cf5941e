//! Cell types of the input formats and their decomposition into tetrahedra.
//!
//! Supported 3D cells: tetrahedron (VTK type 10), voxel (11), hexahedron (12),
//! wedge / prism (13) and pyramid (14), in VTK vertex order. Lower-dimensional
//! linear cells (vertex, poly-vertex, line, poly-line, triangle, triangle strip,
//! polygon, pixel, quad: VTK types 1 to 9) are skipped, and the reader logs one
//! `tracing::warn!` with how many of each it skipped. Every other cell type
//! (quadratic and higher-order cells, polyhedra, ...) is an error naming the cell.
//!
//! # Decomposition rule
//!
//! Hexahedra, wedges and pyramids are split into tetrahedra *conformingly*:
//! two cells sharing a quadrilateral face split it the same way, so the result
//! has no cracks or overlaps. The rule is the one of Dompierre, Labbé, Vallet
//! and Camarero, "How to subdivide pyramids, prisms and hexahedra into
//! tetrahedra" (IMR 1999): **every quadrilateral face is split along the
//! diagonal through its vertex with the smallest global index**. The choice
//! depends only on the face's own four global indices, so both cells sharing
//! the face make the same choice.
//!
//! Inside the cell we use the "pulling" construction that this rule makes
//! always possible: take the cell's vertex `v` with the smallest global index
//! and join it to every triangle of every face that does not contain `v`
//! (faces that do contain `v` are split through `v` by the rule itself). This
//! gives 6 tetrahedra per hexahedron, 3 per wedge and 2 per pyramid; Dompierre
//! et al.'s tables give the same face diagonals and 5 or 6 tetrahedra per
//! hexahedron. The cells are assumed convex (as any valid linear cell is).
//!
//! Each new tetrahedron with a negative signed volume has two vertices swapped
//! so that all are positively oriented. Tetrahedra with a repeated vertex index
//! (from collapsed cells, e.g. a hexahedron written with repeated vertices) are
//! dropped. Tetrahedra read as tetrahedra are kept exactly as in the file: the
//! quality report counts the inverted ones.

use std::collections::BTreeMap;

/// What a reader does with one input cell.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CellShape {
    /// Kept as is.
    Tetra,
    /// Split into 6 tetrahedra (VTK hexahedron vertex order).
    Hexahedron,
    /// A hexahedron in VTK voxel vertex order.
    Voxel,
    /// Split into 3 tetrahedra (VTK wedge order: triangle 0 1 2, then 3 4 5).
    Wedge,
    /// Split into 2 tetrahedra (VTK pyramid order: base 0 1 2 3, apex 4).
    Pyramid,
    /// A lower-dimensional cell, skipped; the name is for the warning.
    Skipped(&'static str),
}

impl CellShape {
    /// The shape of VTK cell type `code`, or `None` for a type pvrsim does not
    /// read (quadratic, higher-order, polyhedron, unknown).
    pub fn from_vtk(code: i64) -> Option<CellShape> {
        Some(match code {
            1 => CellShape::Skipped("vertex"),
            2 => CellShape::Skipped("poly-vertex"),
            3 => CellShape::Skipped("line"),
            4 => CellShape::Skipped("poly-line"),
            5 => CellShape::Skipped("triangle"),
            6 => CellShape::Skipped("triangle strip"),
            7 => CellShape::Skipped("polygon"),
            8 => CellShape::Skipped("pixel"),
            9 => CellShape::Skipped("quad"),
            10 => CellShape::Tetra,
            11 => CellShape::Voxel,
            12 => CellShape::Hexahedron,
            13 => CellShape::Wedge,
            14 => CellShape::Pyramid,
            _ => return None,
        })
    }

    /// The number of vertices the cell must list, `None` for variable-size
    /// (skipped) cells.
    pub fn vertex_count(self) -> Option<usize> {
        match self {
            CellShape::Tetra => Some(4),
            CellShape::Hexahedron | CellShape::Voxel => Some(8),
            CellShape::Wedge => Some(6),
            CellShape::Pyramid => Some(5),
            CellShape::Skipped(_) => None,
        }
    }

    fn name(self) -> &'static str {
        match self {
            CellShape::Tetra => "tetrahedron",
            CellShape::Hexahedron => "hexahedron",
            CellShape::Voxel => "voxel",
            CellShape::Wedge => "wedge",
            CellShape::Pyramid => "pyramid",
            CellShape::Skipped(n) => n,
        }
    }
}

/// Human-readable name of a VTK cell type code, for error messages.
pub fn vtk_type_name(code: i64) -> &'static str {
    match code {
        0 => "empty cell",
        21 => "quadratic edge",
        22 => "quadratic triangle",
        23 => "quadratic quad",
        24 => "quadratic tetrahedron",
        25 => "quadratic hexahedron",
        26 => "quadratic wedge",
        27 => "quadratic pyramid",
        28 => "biquadratic quad",
        29 => "triquadratic hexahedron",
        42 => "polyhedron",
        c if CellShape::from_vtk(c).is_some() => CellShape::from_vtk(c).map_or("", CellShape::name),
        c if (30..=80).contains(&c) => "higher-order or special cell",
        _ => "unknown cell type",
    }
}

const HEX_FACES: [&[usize]; 6] = [
    &[0, 3, 2, 1],
    &[4, 5, 6, 7],
    &[0, 1, 5, 4],
    &[1, 2, 6, 5],
    &[2, 3, 7, 6],
    &[3, 0, 4, 7],
];
const WEDGE_FACES: [&[usize]; 5] = [
    &[0, 1, 2],
    &[3, 5, 4],
    &[0, 3, 4, 1],
    &[1, 4, 5, 2],
    &[2, 5, 3, 0],
];
const PYRAMID_FACES: [&[usize]; 5] = [
    &[0, 3, 2, 1],
    &[0, 1, 4],
    &[1, 2, 4],
    &[2, 3, 4],
    &[3, 0, 4],
];
const VOXEL_TO_HEX: [usize; 8] = [0, 1, 3, 2, 4, 5, 7, 6];

/// Collects the tetrahedra of a mesh cell by cell.
#[derive(Debug)]
pub struct TetBuilder<'a> {
    points: &'a [[f64; 3]],
    tets: Vec<[u32; 4]>,
    skipped: BTreeMap<&'static str, usize>,
}

impl<'a> TetBuilder<'a> {
    /// A builder for cells over `points`.
    pub fn new(points: &'a [[f64; 3]], expected_tets: usize) -> Self {
        TetBuilder {
            points,
            tets: Vec::with_capacity(expected_tets),
            skipped: BTreeMap::new(),
        }
    }

    /// Adds one cell. The error message (wrong vertex count, index out of
    /// range) has no location: the caller adds the cell index.
    pub fn add(&mut self, shape: CellShape, verts: &[i64]) -> Result<(), String> {
        if let CellShape::Skipped(name) = shape {
            *self.skipped.entry(name).or_default() += 1;
            return Ok(());
        }
        let n = shape.vertex_count().unwrap_or(0);
        if verts.len() != n {
            return Err(format!(
                "a {} has {n} vertices, but this cell lists {}",
                shape.name(),
                verts.len()
            ));
        }
        let np = self.points.len();
        let mut g = [0u32; 8];
        for (slot, &v) in g.iter_mut().zip(verts) {
            if v < 0 || v as u64 >= np as u64 {
                return Err(format!(
                    "vertex index {v} is out of range (the mesh has {np} points)"
                ));
            }
            *slot = v as u32;
        }
        match shape {
            CellShape::Tetra => self.tets.push([g[0], g[1], g[2], g[3]]),
            CellShape::Hexahedron => self.pull(&g[..8], &HEX_FACES),
            CellShape::Voxel => {
                let h = VOXEL_TO_HEX.map(|i| g[i]);
                self.pull(&h, &HEX_FACES)
            }
            CellShape::Wedge => self.pull(&g[..6], &WEDGE_FACES),
            CellShape::Pyramid => self.pull(&g[..5], &PYRAMID_FACES),
            CellShape::Skipped(_) => {}
        }
        Ok(())
    }

    /// Pulling triangulation from the smallest vertex; see the module doc.
    fn pull(&mut self, g: &[u32], faces: &[&[usize]]) {
        let apex = (0..g.len()).min_by_key(|&i| g[i]).unwrap_or(0);
        for face in faces {
            if face.contains(&apex) {
                continue;
            }
            let gf: Vec<u32> = face.iter().map(|&i| g[i]).collect();
            if gf.len() == 3 {
                self.push_oriented([g[apex], gf[0], gf[1], gf[2]]);
            } else {
                let k = (0..4).min_by_key(|&i| gf[i]).unwrap_or(0);
                let q = |i: usize| gf[(k + i) % 4];
                self.push_oriented([g[apex], q(0), q(1), q(2)]);
                self.push_oriented([g[apex], q(0), q(2), q(3)]);
            }
        }
    }

    fn push_oriented(&mut self, mut t: [u32; 4]) {
        let distinct = (0..4).all(|i| (i + 1..4).all(|j| t[i] != t[j]));
        if !distinct {
            return;
        }
        let [a, b, c, d] = t.map(|v| self.points[v as usize]);
        let u = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
        let v = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
        let w = [d[0] - a[0], d[1] - a[1], d[2] - a[2]];
        let det = u[0] * (v[1] * w[2] - v[2] * w[1]) - u[1] * (v[0] * w[2] - v[2] * w[0])
            + u[2] * (v[0] * w[1] - v[1] * w[0]);
        if det < 0.0 {
            t.swap(2, 3);
        }
        self.tets.push(t);
    }

    /// The tetrahedra; logs a warning naming the skipped cells of `file`.
    pub fn finish(self, file: &std::path::Path) -> Vec<[u32; 4]> {
        if !self.skipped.is_empty() {
            let total: usize = self.skipped.values().sum();
            let list: Vec<String> = self
                .skipped
                .iter()
                .map(|(k, v)| format!("{v} {k}"))
                .collect();
            tracing::warn!(
                "{}: skipped {total} lower-dimensional cells ({})",
                file.display(),
                list.join(", ")
            );
        }
        self.tets
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::data::{TetMesh, NO_NEIGHBOR};

    /// A 3x3x3 grid of points (2x2x2 unit cubes) numbered by `perm`.
    fn grid(perm: &[u32]) -> (Vec<[f64; 3]>, impl Fn(usize, usize, usize) -> i64 + '_) {
        let mut pts = vec![[0.0; 3]; 27];
        for k in 0..3 {
            for j in 0..3 {
                for i in 0..3 {
                    pts[perm[i + 3 * j + 9 * k] as usize] = [i as f64, j as f64, k as f64];
                }
            }
        }
        (pts, move |i, j, k| perm[i + 3 * j + 9 * k] as i64)
    }

    fn permutation(seed: u64) -> Vec<u32> {
        let mut p: Vec<u32> = (0..27).collect();
        let mut s = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        for i in (1..27).rev() {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            p.swap(i, (s >> 33) as usize % (i + 1));
        }
        p
    }

    fn check(mesh: &TetMesh, n_tets: usize, boundary_triangles: usize) {
        assert_eq!(mesh.tets.len(), n_tets);
        let adj = mesh.adjacency();
        assert_eq!(adj.nonmanifold_faces, 0);
        let boundary = adj
            .neighbors
            .iter()
            .flatten()
            .filter(|&&n| n == NO_NEIGHBOR)
            .count();
        assert_eq!(
            boundary, boundary_triangles,
            "interior faces not all shared by two tets"
        );
        let vols: Vec<f64> = (0..mesh.tets.len()).map(|t| mesh.tet_volume(t)).collect();
        assert!(vols.iter().all(|&v| v > 0.0), "{vols:?}");
        assert!((vols.iter().sum::<f64>() - 8.0).abs() < 1e-12);
    }

    #[test]
    fn hex_block_is_conforming_for_any_numbering() {
        for seed in 0..50 {
            let perm = if seed == 0 {
                (0..27).collect()
            } else {
                permutation(seed)
            };
            let (pts, id) = grid(&perm);
            let mut b = TetBuilder::new(&pts, 48);
            for (i, j, k) in (0..8).map(|c| (c & 1, (c >> 1) & 1, c >> 2)) {
                let h = [
                    id(i, j, k),
                    id(i + 1, j, k),
                    id(i + 1, j + 1, k),
                    id(i, j + 1, k),
                    id(i, j, k + 1),
                    id(i + 1, j, k + 1),
                    id(i + 1, j + 1, k + 1),
                    id(i, j + 1, k + 1),
                ];
                b.add(CellShape::Hexahedron, &h).unwrap();
            }
            let tets = b.finish(std::path::Path::new("test"));
            check(
                &TetMesh {
                    points: pts,
                    tets,
                    fields: vec![],
                },
                48,
                48,
            );
        }
    }

    #[test]
    fn wedge_and_pyramid_blocks_are_conforming() {
        for seed in 0..30 {
            let perm = permutation(seed);
            let (pts, id) = grid(&perm);
            // Each unit cube as two wedges (split along the x-y diagonal)...
            let mut b = TetBuilder::new(&pts, 48);
            for (i, j, k) in (0..8).map(|c| (c & 1, (c >> 1) & 1, c >> 2)) {
                let (a, bb, c, d) = (
                    id(i, j, k),
                    id(i + 1, j, k),
                    id(i + 1, j + 1, k),
                    id(i, j + 1, k),
                );
                let (e, f, g, h) = (
                    id(i, j, k + 1),
                    id(i + 1, j, k + 1),
                    id(i + 1, j + 1, k + 1),
                    id(i, j + 1, k + 1),
                );
                b.add(CellShape::Wedge, &[a, bb, c, e, f, g]).unwrap();
                b.add(CellShape::Wedge, &[a, c, d, e, g, h]).unwrap();
            }
            let tets = b.finish(std::path::Path::new("test"));
            check(
                &TetMesh {
                    points: pts.clone(),
                    tets,
                    fields: vec![],
                },
                48,
                48,
            );
        }
        // ...and one cube of side 2 as six pyramids around its centre.
        let perm = permutation(7);
        let (pts, id) = grid(&perm);
        let c = id(1, 1, 1);
        let corner = |i: usize, j: usize, k: usize| id(2 * i, 2 * j, 2 * k);
        let faces = [
            [
                corner(0, 0, 0),
                corner(0, 1, 0),
                corner(1, 1, 0),
                corner(1, 0, 0),
            ],
            [
                corner(0, 0, 1),
                corner(1, 0, 1),
                corner(1, 1, 1),
                corner(0, 1, 1),
            ],
            [
                corner(0, 0, 0),
                corner(1, 0, 0),
                corner(1, 0, 1),
                corner(0, 0, 1),
            ],
            [
                corner(1, 0, 0),
                corner(1, 1, 0),
                corner(1, 1, 1),
                corner(1, 0, 1),
            ],
            [
                corner(1, 1, 0),
                corner(0, 1, 0),
                corner(0, 1, 1),
                corner(1, 1, 1),
            ],
            [
                corner(0, 1, 0),
                corner(0, 0, 0),
                corner(0, 0, 1),
                corner(0, 1, 1),
            ],
        ];
        let mut b = TetBuilder::new(&pts, 12);
        for f in faces {
            b.add(CellShape::Pyramid, &[f[0], f[1], f[2], f[3], c])
                .unwrap();
        }
        let tets = b.finish(std::path::Path::new("test"));
        check(
            &TetMesh {
                points: pts,
                tets,
                fields: vec![],
            },
            12,
            12,
        );
    }

    #[test]
    fn bad_cells_are_errors() {
        let pts = [[0.0; 3]; 4];
        let mut b = TetBuilder::new(&pts, 1);
        assert!(b
            .add(CellShape::Tetra, &[0, 1, 2])
            .unwrap_err()
            .contains("4 vertices"));
        assert!(b
            .add(CellShape::Tetra, &[0, 1, 2, 4])
            .unwrap_err()
            .contains("out of range"));
        assert!(b
            .add(CellShape::Tetra, &[0, 1, 2, -1])
            .unwrap_err()
            .contains("out of range"));
        assert!(b.add(CellShape::Skipped("line"), &[0, 1]).is_ok());
        assert_eq!(CellShape::from_vtk(24), None);
        assert_eq!(vtk_type_name(24), "quadratic tetrahedron");
    }
}
