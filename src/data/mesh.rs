//! The tetrahedral mesh every cell renderer works on: vertex positions (f64),
//! tetrahedra as four vertex indices, and named point-data arrays.

use crate::error::{Error, Result};

/// Sentinel in [`Adjacency`] for a face on the mesh boundary.
pub const NO_NEIGHBOR: u32 = u32::MAX;

/// A named point-data array with `components` values per vertex.
#[derive(Debug, Clone, PartialEq)]
pub struct Field {
    /// Array name as in the file.
    pub name: String,
    /// Values per vertex (1 for scalars, 3 for vectors).
    pub components: usize,
    /// `components * vertex count` values, vertex-major.
    pub values: Vec<f64>,
}

/// An unstructured mesh of tetrahedra.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct TetMesh {
    /// Vertex positions, world units.
    pub points: Vec<[f64; 3]>,
    /// Each tetrahedron's four vertex indices.
    pub tets: Vec<[u32; 4]>,
    /// Point-data arrays.
    pub fields: Vec<Field>,
}

/// For each tetrahedron and each face `f` (the face opposite vertex `f`), the
/// neighbouring tetrahedron across it, or [`NO_NEIGHBOR`].
#[derive(Debug, Clone, PartialEq)]
pub struct Adjacency {
    /// `neighbors[t][f]`.
    pub neighbors: Vec<[u32; 4]>,
    /// Faces shared by more than two tetrahedra (a non-manifold mesh); such
    /// faces are left as boundary faces.
    pub nonmanifold_faces: usize,
}

/// The three vertex slots of face `f` (the face opposite vertex `f`).
pub const FACE_VERTICES: [[usize; 3]; 4] = [[1, 2, 3], [0, 2, 3], [0, 1, 3], [0, 1, 2]];

impl TetMesh {
    /// Checks that every index is in range and every coordinate and field
    /// value is finite; `source` names the file for the error message.
    pub fn validate(&self, source: &std::path::Path) -> Result<()> {
        use rayon::prelude::*;
        let n = self.points.len();
        if let Some(i) = self
            .points
            .par_iter()
            .position_first(|p| p.iter().any(|v| !v.is_finite()))
        {
            return Err(Error::data(
                source,
                format!("point {i}"),
                format!("coordinate is not finite: {:?}", self.points[i]),
            ));
        }
        if let Some(t) = self
            .tets
            .par_iter()
            .position_first(|tet| tet.iter().any(|&v| v as usize >= n))
        {
            let v = self.tets[t]
                .iter()
                .find(|&&v| v as usize >= n)
                .copied()
                .unwrap_or(0);
            return Err(Error::data(
                source,
                format!("cell {t}"),
                format!("vertex index {v} is out of range (the mesh has {n} points)"),
            ));
        }
        for f in &self.fields {
            if f.values.len() != f.components * n {
                return Err(Error::data(
                    source,
                    format!("field \"{}\"", f.name),
                    format!(
                        "has {} values, expected {} ({} points x {} components)",
                        f.values.len(),
                        f.components * n,
                        n,
                        f.components
                    ),
                ));
            }
            if let Some(i) = f.values.par_iter().position_first(|v| !v.is_finite()) {
                return Err(Error::data(
                    source,
                    format!("field \"{}\"", f.name),
                    format!(
                        "value of point {} is not finite ({})",
                        i / f.components,
                        f.values[i]
                    ),
                ));
            }
        }
        Ok(())
    }

    /// Bytes the mesh's arrays hold on the heap (allocated capacity of the
    /// points, tetrahedra and field values; names and headers not counted).
    pub fn heap_bytes(&self) -> usize {
        self.points.capacity() * std::mem::size_of::<[f64; 3]>()
            + self.tets.capacity() * std::mem::size_of::<[u32; 4]>()
            + self
                .fields
                .iter()
                .map(|f| f.values.capacity() * std::mem::size_of::<f64>())
                .sum::<usize>()
    }

    /// The per-vertex scalar to render: a 1-component field by name, or the
    /// magnitude of a vector field (an extension: `field = "velocity"`).
    pub fn scalar(&self, name: &str) -> Result<Vec<f64>> {
        let f = self.fields.iter().find(|f| f.name == name).ok_or_else(|| {
            let names: Vec<_> = self.fields.iter().map(|f| f.name.as_str()).collect();
            Error::Invalid(format!(
                "the mesh has no point-data field \"{name}\"; it has: {}",
                if names.is_empty() {
                    "none".into()
                } else {
                    names
                        .iter()
                        .map(|n| format!("\"{n}\""))
                        .collect::<Vec<_>>()
                        .join(", ")
                }
            ))
        })?;
        Ok(scalar_of(&f.values, f.components))
    }

    /// Axis-aligned bounds `(min, max)` of the points.
    pub fn bounds(&self) -> ([f64; 3], [f64; 3]) {
        use rayon::prelude::*;
        let empty = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
        self.points
            .par_chunks(1 << 16)
            .map(|c| {
                let (mut lo, mut hi) = empty;
                for p in c {
                    for k in 0..3 {
                        lo[k] = lo[k].min(p[k]);
                        hi[k] = hi[k].max(p[k]);
                    }
                }
                (lo, hi)
            })
            .reduce(
                || empty,
                |a, b| {
                    (
                        [0, 1, 2].map(|k| a.0[k].min(b.0[k])),
                        [0, 1, 2].map(|k| a.1[k].max(b.1[k])),
                    )
                },
            )
    }

    /// Signed volume of tetrahedron `t` (positive for the VTK orientation).
    pub fn tet_volume(&self, t: usize) -> f64 {
        let [a, b, c, d] = self.tets[t].map(|v| self.points[v as usize]);
        let u = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
        let v = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
        let w = [d[0] - a[0], d[1] - a[1], d[2] - a[2]];
        (u[0] * (v[1] * w[2] - v[2] * w[1]) - u[1] * (v[0] * w[2] - v[2] * w[0])
            + u[2] * (v[0] * w[1] - v[1] * w[0]))
            / 6.0
    }

    /// Face adjacency, built by sorting the `4 n` faces by their sorted vertex
    /// triples: O(n log n), no hashing.
    pub fn adjacency(&self) -> Adjacency {
        use rayon::prelude::*;
        // Every (key, slot) pair is distinct, so the parallel unstable sort
        // gives one order whatever the thread count.
        let mut faces: Vec<([u32; 3], u32)> = vec![([0; 3], 0); self.tets.len() * 4];
        faces
            .par_chunks_mut(4)
            .zip(self.tets.par_iter())
            .enumerate()
            .for_each(|(t, (out, tet))| {
                for (f, slots) in FACE_VERTICES.iter().enumerate() {
                    let mut key = [tet[slots[0]], tet[slots[1]], tet[slots[2]]];
                    key.sort_unstable();
                    out[f] = (key, (t as u32) << 2 | f as u32);
                }
            });
        faces.par_sort_unstable();
        let mut neighbors = vec![[NO_NEIGHBOR; 4]; self.tets.len()];
        let mut nonmanifold_faces = 0;
        let mut i = 0;
        while i < faces.len() {
            let mut j = i + 1;
            while j < faces.len() && faces[j].0 == faces[i].0 {
                j += 1;
            }
            if j - i == 2 {
                let (a, b) = (faces[i].1, faces[i + 1].1);
                neighbors[(a >> 2) as usize][(a & 3) as usize] = b >> 2;
                neighbors[(b >> 2) as usize][(b & 3) as usize] = a >> 2;
            } else if j - i > 2 {
                nonmanifold_faces += 1;
            }
            i = j;
        }
        Adjacency {
            neighbors,
            nonmanifold_faces,
        }
    }
}

/// The scalar of a field with `components` values per vertex: the value
/// itself, or the magnitude of a vector (as [`TetMesh::scalar`] gives it).
pub fn scalar_of(values: &[f64], components: usize) -> Vec<f64> {
    match components {
        1 => values.to_vec(),
        c => values
            .chunks_exact(c.max(1))
            .map(|v| v.iter().map(|x| x * x).sum::<f64>().sqrt())
            .collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn two_tets() -> TetMesh {
        TetMesh {
            points: vec![
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [0.0, 1.0, 0.0],
                [0.0, 0.0, 1.0],
                [1.0, 1.0, 1.0],
            ],
            tets: vec![[0, 1, 2, 3], [1, 2, 3, 4]],
            fields: vec![Field {
                name: "s".into(),
                components: 1,
                values: vec![0.0, 1.0, 2.0, 3.0, 4.0],
            }],
        }
    }

    #[test]
    fn adjacency_pairs_shared_face() {
        let a = two_tets().adjacency();
        assert_eq!(a.neighbors[0], [1, NO_NEIGHBOR, NO_NEIGHBOR, NO_NEIGHBOR]);
        assert_eq!(a.neighbors[1], [NO_NEIGHBOR, NO_NEIGHBOR, NO_NEIGHBOR, 0]);
    }

    #[test]
    fn validate_catches_bad_index_and_nan() {
        let mut m = two_tets();
        m.tets[1][3] = 9;
        assert!(m
            .validate(std::path::Path::new("m"))
            .unwrap_err()
            .to_string()
            .contains("out of range"));
        let mut m = two_tets();
        m.fields[0].values[2] = f64::NAN;
        assert!(m
            .validate(std::path::Path::new("m"))
            .unwrap_err()
            .to_string()
            .contains("not finite"));
    }

    #[test]
    fn missing_field_lists_the_ones_there() {
        let e = two_tets().scalar("speed").unwrap_err().to_string();
        assert!(e.contains("\"s\""), "{e}");
    }
}
