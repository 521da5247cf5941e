//! A coarse stand-in of a tetrahedral mesh for frames drawn while the user
//! moves the view (the live viewer's level of detail, as ParaView swaps in
//! a decimated representation while interacting): the field resampled on
//! a regular lattice over the mesh's bounding box, the lattice cubes that
//! lie mostly inside the mesh cut into tetrahedra ([`kuhn_tets`]). Cell
//! projection's cost per frame grows with the cells it projects whatever
//! the image size, so a reduced image alone cannot hold a frame-time
//! target on a large mesh; this mesh has a bounded number of cells.

use std::sync::Arc;

use crate::data::lattice::kuhn_tets;
use crate::data::TetMesh;
use crate::render::RenderInput;

/// Corners of a lattice cube (of 8) that must lie inside the mesh for the
/// cube to be kept.
const KEEP_CORNERS: usize = 4;

/// Cells of the Kuhn split of one cube.
const TETS_PER_CUBE: usize = 6;

impl RenderInput {
    /// A coarse stand-in of this input of at most about `max_cells`
    /// tetrahedra (see the module docs): each lattice vertex inside a
    /// tetrahedron takes the field interpolated there (barycentric, as the
    /// cell renderers interpolate), a vertex of a kept cube outside the
    /// mesh the mean of its inside neighbours. The scene (camera, transfer
    /// function, image) and the range are this input's. `None` when the
    /// mesh has no volume or is already no larger than `max_cells`.
    pub fn coarse(&self, max_cells: usize) -> Option<RenderInput> {
        let mesh = &self.mesh;
        if mesh.tets.len() <= max_cells || max_cells < TETS_PER_CUBE {
            return None;
        }
        let (lo, hi) = mesh.bounds();
        let ext = [hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]];
        let volume: f64 = (0..mesh.tets.len()).map(|t| mesh.tet_volume(t).abs()).sum();
        if !volume.is_finite() || volume <= 0.0 || ext.iter().any(|&e| !e.is_finite() || e <= 0.0) {
            return None;
        }
        // Cubes of edge h filling the mesh's volume: about max_cells / 6.
        let h = (volume * TETS_PER_CUBE as f64 / max_cells as f64).cbrt();
        let n = ext.map(|e| ((e / h).ceil() as usize).clamp(1, 1024));
        let step = [
            ext[0] / n[0] as f64,
            ext[1] / n[1] as f64,
            ext[2] / n[2] as f64,
        ];
        let nv = [n[0] + 1, n[1] + 1, n[2] + 1];
        let id = |i: usize, j: usize, k: usize| i + nv[0] * (j + nv[1] * k);
        let mut value = vec![0.0f64; nv[0] * nv[1] * nv[2]];
        let mut inside = vec![false; value.len()];
        for tet in &mesh.tets {
            let p = tet.map(|v| mesh.points[v as usize]);
            let s = tet.map(|v| self.s_norm[v as usize]);
            let Some(bary) = Barycentric::new(&p) else {
                continue;
            };
            let mut a = [0usize; 3];
            let mut b = [0usize; 3];
            for ax in 0..3 {
                let (mn, mx) = p
                    .iter()
                    .fold((f64::INFINITY, f64::NEG_INFINITY), |(mn, mx), q| {
                        (mn.min(q[ax]), mx.max(q[ax]))
                    });
                a[ax] = (((mn - lo[ax]) / step[ax]).ceil().max(0.0) as usize).min(n[ax]);
                b[ax] = (((mx - lo[ax]) / step[ax]).floor().max(0.0) as usize).min(n[ax]);
            }
            for k in a[2]..=b[2] {
                for j in a[1]..=b[1] {
                    for i in a[0]..=b[0] {
                        let v = id(i, j, k);
                        if inside[v] {
                            continue;
                        }
                        let x = [
                            lo[0] + i as f64 * step[0],
                            lo[1] + j as f64 * step[1],
                            lo[2] + k as f64 * step[2],
                        ];
                        if let Some(w) = bary.weights(x) {
                            value[v] = w.iter().zip(s).map(|(w, s)| w * s).sum();
                            inside[v] = true;
                        }
                    }
                }
            }
        }
        let corners = |i: usize, j: usize, k: usize| {
            (0..8).map(move |c| id(i + (c & 1), j + ((c >> 1) & 1), k + (c >> 2)))
        };
        let keep = |i: usize, j: usize, k: usize| {
            corners(i, j, k).filter(|&v| inside[v]).count() >= KEEP_CORNERS
        };
        let tets = kuhn_tets(n, keep);
        if tets.is_empty() {
            return None;
        }
        // Outside vertices of kept cubes: the mean of their inside
        // neighbours (a kept cube has at least KEEP_CORNERS inside corners,
        // so each of its corners has one).
        let mut filled = value.clone();
        let used: std::collections::BTreeSet<u32> = tets.iter().flatten().copied().collect();
        for &v in &used {
            let v = v as usize;
            if inside[v] {
                continue;
            }
            let (i, j, k) = (v % nv[0], (v / nv[0]) % nv[1], v / (nv[0] * nv[1]));
            let (mut sum, mut count) = (0.0, 0usize);
            for dk in -1i64..=1 {
                for dj in -1i64..=1 {
                    for di in -1i64..=1 {
                        let (x, y, z) = (i as i64 + di, j as i64 + dj, k as i64 + dk);
                        if x < 0 || y < 0 || z < 0 {
                            continue;
                        }
                        let (x, y, z) = (x as usize, y as usize, z as usize);
                        if x >= nv[0] || y >= nv[1] || z >= nv[2] || !inside[id(x, y, z)] {
                            continue;
                        }
                        sum += value[id(x, y, z)];
                        count += 1;
                    }
                }
            }
            filled[v] = if count > 0 { sum / count as f64 } else { 0.0 };
        }
        // Only the vertices the kept cubes use, renumbered in lattice order.
        let mut new_id = vec![u32::MAX; value.len()];
        let mut points = Vec::with_capacity(used.len());
        let mut s_norm = Vec::with_capacity(used.len());
        for (m, &v) in used.iter().enumerate() {
            let v = v as usize;
            new_id[v] = m as u32;
            let (i, j, k) = (v % nv[0], (v / nv[0]) % nv[1], v / (nv[0] * nv[1]));
            points.push([
                lo[0] + i as f64 * step[0],
                lo[1] + j as f64 * step[1],
                lo[2] + k as f64 * step[2],
            ]);
            s_norm.push(filled[v]);
        }
        let tets = tets
            .into_iter()
            .map(|t| t.map(|v| new_id[v as usize]))
            .collect();
        Some(RenderInput {
            scene: self.scene.clone(),
            mesh: Arc::new(TetMesh {
                points,
                tets,
                fields: Vec::new(),
            }),
            s_norm,
            range: self.range,
            pieces: None,
            renumbering: None,
        })
    }
}

/// Barycentric coordinates in one tetrahedron.
struct Barycentric {
    origin: [f64; 3],
    /// Rows: the inverse of the matrix whose columns are `p1 - p0`,
    /// `p2 - p0`, `p3 - p0`.
    inv: [[f64; 3]; 3],
}

impl Barycentric {
    /// `None` for a tetrahedron without volume.
    fn new(p: &[[f64; 3]; 4]) -> Option<Barycentric> {
        let e = |k: usize| [p[k][0] - p[0][0], p[k][1] - p[0][1], p[k][2] - p[0][2]];
        let m = glam::DMat3::from_cols(e(1).into(), e(2).into(), e(3).into());
        let det = m.determinant();
        if !det.is_finite() || det.abs() <= 1e-300 {
            return None;
        }
        let inv = m.inverse();
        let r = inv.transpose();
        Some(Barycentric {
            origin: p[0],
            inv: [r.x_axis.into(), r.y_axis.into(), r.z_axis.into()],
        })
    }

    /// The four weights of `x` when it lies in the tetrahedron (with a
    /// small tolerance for points on a face), else `None`.
    fn weights(&self, x: [f64; 3]) -> Option<[f64; 4]> {
        const EPS: f64 = 1e-9;
        let d = [
            x[0] - self.origin[0],
            x[1] - self.origin[1],
            x[2] - self.origin[2],
        ];
        let l = self.inv.map(|r| r[0] * d[0] + r[1] * d[1] + r[2] * d[2]);
        let w0 = 1.0 - l[0] - l[1] - l[2];
        if w0 < -EPS || l.iter().any(|&v| v < -EPS) {
            return None;
        }
        Some([w0, l[0], l[1], l[2]])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A linear field on a fine lattice mesh: the coarse mesh has at most
    /// about the cells asked for, covers the same box, and its vertices
    /// inside carry the field's values exactly (barycentric interpolation
    /// of a linear field is exact).
    #[test]
    fn a_linear_field_is_resampled_exactly_on_fewer_cells() {
        let n = [12usize, 10, 8];
        let tets = kuhn_tets(n, |_, _, _| true);
        let mut points = Vec::new();
        for k in 0..=n[2] {
            for j in 0..=n[1] {
                for i in 0..=n[0] {
                    points.push([i as f64, j as f64 * 0.5, k as f64 * 2.0]);
                }
            }
        }
        let s_norm: Vec<f64> = points
            .iter()
            .map(|p| 0.01 * p[0] + 0.02 * p[1] + 0.03 * p[2])
            .collect();
        let scene = crate::scene::Scene::parse(
            include_str!("../../tests/data/aorta-small-view-b.toml"),
            std::path::Path::new("tests/data/aorta-small-view-b.toml"),
        )
        .unwrap();
        let input = RenderInput {
            scene,
            mesh: Arc::new(TetMesh {
                points,
                tets,
                fields: Vec::new(),
            }),
            s_norm,
            range: [0.0, 1.0],
            pieces: None,
            renumbering: None,
        };
        assert!(input.coarse(10_000).is_none(), "already small enough");
        let c = input.coarse(600).expect("a coarse mesh");
        assert!(c.mesh.tets.len() <= 900, "{} cells", c.mesh.tets.len());
        assert!(c.mesh.tets.len() >= 100, "{} cells", c.mesh.tets.len());
        assert_eq!(c.mesh.bounds(), input.mesh.bounds());
        for (p, s) in c.mesh.points.iter().zip(&c.s_norm) {
            let want = 0.01 * p[0] + 0.02 * p[1] + 0.03 * p[2];
            assert!((s - want).abs() < 1e-12, "{p:?}: {s} != {want}");
        }
        let v: f64 = (0..c.mesh.tets.len())
            .map(|t| c.mesh.tet_volume(t).abs())
            .sum();
        assert!((v - 12.0 * 5.0 * 16.0).abs() < 1e-6, "volume {v}");
    }
}
