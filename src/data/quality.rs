//! Mesh quality report for `pvrsim info`: sizes, bounds, field ranges, tet
//! volumes and dihedral angles, orientation and topology counts.
//!
//! Rules:
//! - a tetrahedron is **degenerate** if |signed volume| ≤ 1e-12 × d³, where d
//!   is the bounding-box diagonal (a scale-free "zero volume" test);
//! - it is **inverted** (negatively oriented) if its signed volume is below
//!   that threshold's negative, i.e. negative and not degenerate;
//! - the **minimum dihedral angle** of a tet is the smallest of its six
//!   interior angles between two faces (0° for a degenerate tet); the report
//!   gives the minimum over the mesh, the 1st percentile and the median
//!   (nearest-rank), and how many tets have one below 15°;
//! - **boundary faces** are tet faces without a neighbour in the
//!   [`Adjacency`] (this includes the faces of non-manifold groups, which the
//!   adjacency leaves unpaired); **non-manifold faces** are faces shared by
//!   more than two tets.
//!
//! Volume statistics use |volume|, so an inverted mesh still reports sizes.

use rayon::prelude::*;
use serde::Serialize;

use crate::data::mesh::FACE_VERTICES;
use crate::data::{Adjacency, TetMesh, NO_NEIGHBOR};

/// Summary of one point-data field.
#[derive(Debug, Clone, Serialize)]
pub struct FieldSummary {
    /// Field name.
    pub name: String,
    /// Values per vertex.
    pub components: usize,
    /// Smallest value over all components.
    pub min: f64,
    /// Largest value over all components.
    pub max: f64,
    /// Smallest vector magnitude (fields with more than one component).
    pub magnitude_min: Option<f64>,
    /// Largest vector magnitude (fields with more than one component).
    pub magnitude_max: Option<f64>,
}

/// Min / median / max of a per-tet quantity.
#[derive(Debug, Clone, Copy, Serialize, PartialEq)]
pub struct Spread {
    /// Smallest value.
    pub min: f64,
    /// Median (nearest rank).
    pub median: f64,
    /// Largest value.
    pub max: f64,
}

/// The quality report of a tetrahedral mesh. Per-tet statistics are `None`
/// for a mesh without tetrahedra.
#[derive(Debug, Clone, Serialize)]
pub struct MeshReport {
    /// Number of vertices.
    pub points: usize,
    /// Number of tetrahedra.
    pub tets: usize,
    /// Bounding box minimum corner.
    pub bounds_min: [f64; 3],
    /// Bounding box maximum corner.
    pub bounds_max: [f64; 3],
    /// Per-field ranges, in file order.
    pub fields: Vec<FieldSummary>,
    /// |volume| statistics.
    pub volume: Option<Spread>,
    /// Sum of the signed volumes.
    pub volume_total: f64,
    /// Tets with |volume| ≤ 1e-12 × (bounding-box diagonal)³.
    pub degenerate: usize,
    /// Non-degenerate tets with negative signed volume.
    pub inverted: usize,
    /// Minimum dihedral angle per tet, degrees: min / median / max over tets.
    pub min_dihedral_deg: Option<Spread>,
    /// 1st percentile of the per-tet minimum dihedral angle, degrees.
    pub min_dihedral_p1_deg: Option<f64>,
    /// Tets whose minimum dihedral angle is below 15°.
    pub dihedral_below_15: usize,
    /// Tet faces without a neighbour.
    pub boundary_faces: usize,
    /// Faces shared by more than two tets.
    pub nonmanifold_faces: usize,
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Signed volume and minimum dihedral angle (degrees) of a tetrahedron.
pub fn tet_metrics(p: [[f64; 3]; 4]) -> (f64, f64) {
    let vol = dot(sub(p[1], p[0]), cross(sub(p[2], p[0]), sub(p[3], p[0]))) / 6.0;
    // Outward normals of the faces opposite each vertex.
    let mut n = [[0.0; 3]; 4];
    for (f, s) in FACE_VERTICES.iter().enumerate() {
        let [a, b, c] = s.map(|i| p[i]);
        let mut v = cross(sub(b, a), sub(c, a));
        if dot(v, sub(p[f], a)) > 0.0 {
            v = [-v[0], -v[1], -v[2]];
        }
        let len = dot(v, v).sqrt();
        n[f] = if len > 0.0 {
            [v[0] / len, v[1] / len, v[2] / len]
        } else {
            [0.0; 3]
        };
    }
    // Interior angle between faces i and j: pi minus the normals' angle; the
    // smallest angle has the largest cosine.
    let mut max_cos = -1.0f64;
    for i in 0..4 {
        for j in i + 1..4 {
            max_cos = max_cos.max(-dot(n[i], n[j]));
        }
    }
    if n.contains(&[0.0; 3]) {
        return (vol, 0.0);
    }
    (vol, max_cos.clamp(-1.0, 1.0).acos().to_degrees())
}

/// Min, nearest-rank median and max; reorders `v`.
fn spread(v: &mut [f64]) -> Option<Spread> {
    if v.is_empty() {
        return None;
    }
    let (min, max) = v
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| {
            (a.min(x), b.max(x))
        });
    let mid = (v.len() - 1) / 2;
    let median = *v.select_nth_unstable_by(mid, f64::total_cmp).1;
    Some(Spread { min, median, max })
}

impl MeshReport {
    /// Computes the report; `adjacency` must be `mesh.adjacency()`.
    pub fn compute(mesh: &TetMesh, adjacency: &Adjacency) -> MeshReport {
        let (lo, hi) = mesh.bounds();
        let (lo, hi) = if mesh.points.is_empty() {
            ([0.0; 3], [0.0; 3])
        } else {
            (lo, hi)
        };
        let diag = dot(sub(hi, lo), sub(hi, lo)).sqrt();
        let eps = 1e-12 * diag.powi(3);

        let metrics: Vec<(f64, f64)> = mesh
            .tets
            .par_iter()
            .map(|t| tet_metrics(t.map(|v| mesh.points[v as usize])))
            .collect();
        let degenerate = metrics.iter().filter(|m| m.0.abs() <= eps).count();
        let inverted = metrics.iter().filter(|m| m.0 < -eps).count();
        let volume_total = metrics.iter().map(|m| m.0).sum();
        let mut vols: Vec<f64> = metrics.iter().map(|m| m.0.abs()).collect();
        let mut angles: Vec<f64> = metrics.iter().map(|m| m.1).collect();
        let below_15 = angles.iter().filter(|&&a| a < 15.0).count();
        let p1 = (!angles.is_empty()).then(|| {
            let k = ((angles.len() as f64 * 0.01).ceil() as usize).saturating_sub(1);
            *angles.select_nth_unstable_by(k, f64::total_cmp).1
        });

        let fields = mesh
            .fields
            .iter()
            .map(|f| {
                let (min, max) = f
                    .values
                    .iter()
                    .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
                        (a.min(v), b.max(v))
                    });
                let (mut mmin, mut mmax) = (None, None);
                if f.components > 1 {
                    let (a, b) = f
                        .values
                        .chunks_exact(f.components)
                        .map(|c| c.iter().map(|x| x * x).sum::<f64>().sqrt())
                        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
                            (a.min(v), b.max(v))
                        });
                    (mmin, mmax) = (Some(a), Some(b));
                }
                FieldSummary {
                    name: f.name.clone(),
                    components: f.components,
                    min,
                    max,
                    magnitude_min: mmin,
                    magnitude_max: mmax,
                }
            })
            .collect();

        MeshReport {
            points: mesh.points.len(),
            tets: mesh.tets.len(),
            bounds_min: lo,
            bounds_max: hi,
            fields,
            volume: spread(&mut vols),
            volume_total,
            degenerate,
            inverted,
            min_dihedral_deg: spread(&mut angles),
            min_dihedral_p1_deg: p1,
            dihedral_below_15: below_15,
            boundary_faces: adjacency
                .neighbors
                .iter()
                .flatten()
                .filter(|&&n| n == NO_NEIGHBOR)
                .count(),
            nonmanifold_faces: adjacency.nonmanifold_faces,
        }
    }
}

/// A number in at most 4 significant digits (plain notation when readable).
fn g(v: f64) -> String {
    if v == 0.0 || !v.is_finite() {
        return format!("{v}");
    }
    let a = v.abs();
    if (1e-3..1e6).contains(&a) {
        let decimals = (3 - a.log10().floor() as i32).max(0) as usize;
        let s = format!("{v:.decimals$}");
        if s.contains('.') {
            s.trim_end_matches('0').trim_end_matches('.').to_string()
        } else {
            s
        }
    } else {
        format!("{v:.3e}")
    }
}

impl std::fmt::Display for MeshReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let (lo, hi) = (self.bounds_min, self.bounds_max);
        writeln!(f, "{:<16}{}", "points", self.points)?;
        writeln!(f, "{:<16}{}", "tetrahedra", self.tets)?;
        writeln!(
            f,
            "{:<16}x [{}, {}]  y [{}, {}]  z [{}, {}]",
            "bounds",
            g(lo[0]),
            g(hi[0]),
            g(lo[1]),
            g(hi[1]),
            g(lo[2]),
            g(hi[2])
        )?;
        let w = self.fields.iter().map(|x| x.name.len()).max().unwrap_or(0);
        for (i, fs) in self.fields.iter().enumerate() {
            let label = if i == 0 { "fields" } else { "" };
            write!(
                f,
                "{label:<16}{:<w$}  {}  min {}  max {}",
                fs.name,
                fs.components,
                g(fs.min),
                g(fs.max)
            )?;
            if let (Some(a), Some(b)) = (fs.magnitude_min, fs.magnitude_max) {
                write!(f, "  |v| {} .. {}", g(a), g(b))?;
            }
            writeln!(f)?;
        }
        if self.fields.is_empty() {
            writeln!(f, "{:<16}none", "fields")?;
        }
        if let Some(v) = self.volume {
            writeln!(
                f,
                "{:<16}min {}  median {}  max {}  total {}",
                "tet volume",
                g(v.min),
                g(v.median),
                g(v.max),
                g(self.volume_total)
            )?;
        }
        writeln!(
            f,
            "{:<16}{}  (|V| <= 1e-12 x bbox diagonal^3)",
            "degenerate", self.degenerate
        )?;
        writeln!(f, "{:<16}{}", "inverted", self.inverted)?;
        if let (Some(a), Some(p1)) = (self.min_dihedral_deg, self.min_dihedral_p1_deg) {
            writeln!(
                f,
                "{:<16}min {}°  p1 {}°  median {}°  below 15°: {}",
                "min dihedral",
                g(a.min),
                g(p1),
                g(a.median),
                self.dihedral_below_15
            )?;
        }
        writeln!(f, "{:<16}{}", "boundary faces", self.boundary_faces)?;
        write!(f, "{:<16}{}", "non-manifold", self.nonmanifold_faces)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn regular_tet_dihedral_is_70_5_degrees() {
        let s = 1.0 / 2f64.sqrt();
        let p = [
            [1.0, 0.0, -s],
            [-1.0, 0.0, -s],
            [0.0, 1.0, s],
            [0.0, -1.0, s],
        ];
        let (v, a) = tet_metrics(p);
        assert!((a - 70.528779).abs() < 1e-5, "{a}");
        assert!(v.abs() > 0.0);
        let (_, a) = tet_metrics([[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]);
        assert!((a - 54.7356).abs() < 1e-3, "{a}");
    }

    #[test]
    fn report_counts_inverted_and_degenerate() {
        let mut m = TetMesh {
            points: vec![
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [0.0, 1.0, 0.0],
                [0.0, 0.0, 1.0],
                [1.0, 1.0, 0.0],
            ],
            tets: vec![[0, 1, 2, 3], [0, 2, 1, 3], [0, 1, 2, 4]],
            fields: vec![crate::data::Field {
                name: "v".into(),
                components: 3,
                values: vec![
                    3.0, 4.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
                ],
            }],
        };
        let r = MeshReport::compute(&m, &m.adjacency());
        assert_eq!((r.inverted, r.degenerate, r.tets), (1, 1, 3));
        assert_eq!(r.fields[0].magnitude_max, Some(5.0));
        assert_eq!(r.dihedral_below_15, 1);
        let text = r.to_string();
        assert!(
            text.contains("inverted") && text.contains("|v| 0 .. 5"),
            "{text}"
        );
        m.tets.clear();
        let r = MeshReport::compute(&m, &m.adjacency());
        assert!(r.volume.is_none());
        let _ = r.to_string();
    }
}
