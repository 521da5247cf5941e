//! A tetrahedral mesh's point field sampled on a regular grid, so that the
//! cell renderer and the grid renderers can be compared on the same physical
//! field (`pvrsim generate mesh-field`).
//!
//! The grid spans the mesh's bounding box: sample `(i, j, k)` sits at
//! `x = bmin + (i, j, k) * h` with `h = (bmax - bmin) / (dims - 1)` per axis,
//! so the first and last samples lie on the box's faces. A sample inside a
//! tetrahedron takes the tet's linear (barycentric) field,
//!
//! `s(x) = sum_v lambda_v(x) s_v`, with `lambda = M^-1 (x - p_0)` for the
//! 3x3 edge matrix `M = [p_1 - p_0, p_2 - p_0, p_3 - p_0]` and
//! `lambda_0 = 1 - lambda_1 - lambda_2 - lambda_3`,
//!
//! computed in f64 (the edge matrix of a thin tet is badly conditioned; f32
//! would lose the field's last digits at the wall). A sample is inside when
//! every `lambda >= -1e-9` (a sample on a face shared by two tets gets the
//! same value from either: the field is continuous). Degenerate tets (zero
//! volume) hold no sample and are skipped. Samples outside every tet take the
//! caller's `outside` value (the generator uses the range minimum, i.e.
//! `s_norm = 0`).
//!
//! The trilinear field of the grid is not the mesh's piecewise-linear field:
//! it agrees at the samples and converges as `h -> 0` (second order where
//! the mesh field is smooth; at the mesh boundary, where inside meets
//! `outside`, the transition is smeared over one spacing).

use std::path::Path;

use rayon::prelude::*;

use super::{checked_count, Volume, Voxels};
use crate::data::mesh::TetMesh;
use crate::error::{Error, Result};

/// Barycentric tolerance: a sample this far outside a face still counts as
/// inside (absorbs the rounding of points lying exactly on a face).
const INSIDE_EPS: f64 = 1e-9;

/// Samples `values` (one per mesh point; the volume's scalar is named
/// `field`) on a `dims` grid over the mesh's bounding box; f32 voxels;
/// `outside` where no tet covers a sample. `source` names the mesh in errors.
pub fn sample_mesh_field(
    mesh: &TetMesh,
    field: &str,
    values: &[f64],
    dims: [u64; 3],
    outside: f64,
    source: &Path,
) -> Result<Volume> {
    if values.len() != mesh.points.len() {
        return Err(Error::data(
            source,
            "field",
            format!("{} values for {} points", values.len(), mesh.points.len()),
        ));
    }
    if dims.iter().any(|&d| d < 2) {
        return Err(Error::data(
            source,
            "size",
            format!("{dims:?}: every axis needs at least 2 samples"),
        ));
    }
    let count = checked_count(dims)
        .filter(|&c| c <= isize::MAX as u64 / 4)
        .ok_or_else(|| Error::data(source, "size", format!("{dims:?} is too large")))?;
    let (bmin, bmax) = mesh.bounds();
    let mut h = [0.0; 3];
    for a in 0..3 {
        let ext = bmax[a] - bmin[a];
        if ext.is_nan() || ext <= 0.0 || ext.is_infinite() {
            return Err(Error::data(
                source,
                "points",
                format!("the mesh is flat along axis {a} (extent {ext}): no grid spans it"),
            ));
        }
        h[a] = ext / (dims[a] - 1) as f64;
    }

    // Bucket the tets by the z slabs their samples may lie in.
    let [nx, ny, nz] = dims;
    let index_range = |lo: f64, hi: f64, a: usize| -> Option<(u64, u64)> {
        let n = dims[a];
        let first = ((lo - bmin[a]) / h[a] - 1e-9).ceil().max(0.0);
        let last = ((hi - bmin[a]) / h[a] + 1e-9).floor().min((n - 1) as f64);
        (first <= last).then_some((first as u64, last as u64))
    };
    let mut buckets: Vec<Vec<u32>> = vec![Vec::new(); nz as usize];
    for (t, tet) in mesh.tets.iter().enumerate() {
        let zs = tet.map(|v| mesh.points[v as usize][2]);
        let lo = zs.iter().cloned().fold(f64::INFINITY, f64::min);
        let hi = zs.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
        if let Some((k0, k1)) = index_range(lo, hi, 2) {
            for k in k0..=k1 {
                buckets[k as usize].push(t as u32);
            }
        }
    }

    let slab = (nx * ny) as usize;
    let mut out = vec![outside as f32; count as usize];
    out.par_chunks_mut(slab)
        .zip(buckets.par_iter())
        .enumerate()
        .for_each(|(k, (plane, tets))| {
            let z = bmin[2] + k as f64 * h[2];
            for &t in tets {
                let tet = mesh.tets[t as usize];
                let p = tet.map(|v| mesh.points[v as usize]);
                let Some(inv) = inverse_edges(&p) else {
                    continue;
                };
                let lo = |a: usize| p.iter().map(|q| q[a]).fold(f64::INFINITY, f64::min);
                let hi = |a: usize| p.iter().map(|q| q[a]).fold(f64::NEG_INFINITY, f64::max);
                let (Some((i0, i1)), Some((j0, j1))) =
                    (index_range(lo(0), hi(0), 0), index_range(lo(1), hi(1), 1))
                else {
                    continue;
                };
                let s = tet.map(|v| values[v as usize]);
                for j in j0..=j1 {
                    let y = bmin[1] + j as f64 * h[1];
                    for i in i0..=i1 {
                        let x = bmin[0] + i as f64 * h[0];
                        let d = [x - p[0][0], y - p[0][1], z - p[0][2]];
                        let l1 = dot(inv[0], d);
                        let l2 = dot(inv[1], d);
                        let l3 = dot(inv[2], d);
                        let l0 = 1.0 - l1 - l2 - l3;
                        if l0 >= -INSIDE_EPS
                            && l1 >= -INSIDE_EPS
                            && l2 >= -INSIDE_EPS
                            && l3 >= -INSIDE_EPS
                        {
                            let v = l0 * s[0] + l1 * s[1] + l2 * s[2] + l3 * s[3];
                            plane[(i + j * nx) as usize] = v as f32;
                        }
                    }
                }
            }
        });
    Volume::new(source, dims, h, bmin, field, Voxels::F32(out))
}

/// Grid size with `n` samples along the longest axis of the box
/// `(lo, hi)` and the other axes in proportion (near-isotropic spacing, at
/// least 2 samples each); `None` when the box is empty or not finite.
pub fn dims_along_longest(lo: [f64; 3], hi: [f64; 3], n: u64) -> Option<[u64; 3]> {
    let ext: [f64; 3] = std::array::from_fn(|a| hi[a] - lo[a]);
    let longest = ext.iter().cloned().fold(0.0, f64::max);
    if longest.is_nan() || longest <= 0.0 || longest.is_infinite() || n < 2 {
        return None;
    }
    Some(ext.map(|e| (((n - 1) as f64 * e / longest).round() as u64 + 1).max(2)))
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Rows of `M^-1` for the edge matrix `M = [p1-p0, p2-p0, p3-p0]` (as
/// columns), so that `lambda_{1,2,3} = rows . (x - p0)`; `None` for a
/// degenerate tet (|det| below 1e-12 of the edge lengths cubed).
fn inverse_edges(p: &[[f64; 3]; 4]) -> Option<[[f64; 3]; 3]> {
    let e = |v: usize| [p[v][0] - p[0][0], p[v][1] - p[0][1], p[v][2] - p[0][2]];
    let (a, b, c) = (e(1), e(2), e(3));
    let cross = |u: [f64; 3], v: [f64; 3]| {
        [
            u[1] * v[2] - u[2] * v[1],
            u[2] * v[0] - u[0] * v[2],
            u[0] * v[1] - u[1] * v[0],
        ]
    };
    // Rows of the inverse are the cross products of the other two columns
    // over the determinant.
    let bc = cross(b, c);
    let ca = cross(c, a);
    let ab = cross(a, b);
    let det = dot(a, bc);
    let scale = [a, b, c]
        .iter()
        .map(|v| dot(*v, *v).sqrt())
        .fold(0.0, f64::max);
    // `<=` is false for a NaN det too: written so NaN counts as degenerate.
    if det.is_nan() || det.abs() <= 1e-12 * scale * scale * scale {
        return None;
    }
    Some([bc, ca, ab].map(|r| r.map(|x| x / det)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::data::lattice::kuhn_tets;
    use crate::data::mesh::Field;

    /// A `n^3`-cube lattice over `[0, n]^3`, Kuhn-split; `keep` picks cubes.
    fn lattice(n: usize, keep: impl Fn(usize, usize, usize) -> bool) -> TetMesh {
        let mut points = Vec::new();
        for k in 0..=n {
            for j in 0..=n {
                for i in 0..=n {
                    points.push([i as f64, j as f64, k as f64]);
                }
            }
        }
        let f = |p: &[f64; 3]| 1.0 + 2.0 * p[0] - 0.5 * p[1] + 3.0 * p[2];
        let values: Vec<f64> = points.iter().map(f).collect();
        TetMesh {
            tets: kuhn_tets([n; 3], keep),
            fields: vec![Field {
                name: "lin".into(),
                components: 1,
                values,
            }],
            points,
        }
    }

    #[test]
    fn a_linear_field_is_sampled_exactly_everywhere_inside() {
        let m = lattice(3, |_, _, _| true);
        let vals = m.scalar("lin").unwrap();
        let v = sample_mesh_field(&m, "lin", &vals, [7, 5, 9], -100.0, Path::new("t")).unwrap();
        assert_eq!(v.dims, [7, 5, 9]);
        for k in 0..9 {
            for j in 0..5 {
                for i in 0..7 {
                    let p = v.grid_to_world([i as f64, j as f64, k as f64]);
                    let want = 1.0 + 2.0 * p[0] - 0.5 * p[1] + 3.0 * p[2];
                    let got = v.get(i, j, k) as f64;
                    assert!((got - want).abs() < 1e-4, "({i},{j},{k}): {got} vs {want}");
                }
            }
        }
    }

    #[test]
    fn samples_outside_every_tet_take_the_outside_value() {
        // Only the cube at the origin of a 2^3 lattice; the grid spans the
        // bounds of all points, [0,2]^3, spacing 0.5.
        let m = lattice(2, |i, j, k| i + j + k == 0);
        let vals = m.scalar("lin").unwrap();
        let v = sample_mesh_field(&m, "lin", &vals, [5, 5, 5], -7.0, Path::new("t")).unwrap();
        // Sample (4,4,4) = (2,2,2): outside the kept cube.
        assert_eq!(v.get(4, 4, 4), -7.0);
        // Sample (1,1,1) = (0.5,0.5,0.5): inside, on the main diagonal.
        let want = 1.0 + 1.0 - 0.25 + 1.5;
        assert!((v.get(1, 1, 1) as f64 - want).abs() < 1e-5);
        // Sample (3,1,1) = (1.5,0.5,0.5): outside.
        assert_eq!(v.get(3, 1, 1), -7.0);
    }

    #[test]
    fn a_degenerate_tet_holds_no_sample_and_flat_meshes_are_refused() {
        let mut m = lattice(1, |_, _, _| true);
        // Collapse one tet onto a plane: its samples must come from the others.
        m.tets.push([0, 1, 2, 3]);
        let vals = m.scalar("lin").unwrap();
        let v = sample_mesh_field(&m, "lin", &vals, [3, 3, 3], 0.0, Path::new("t")).unwrap();
        assert!((v.get(1, 1, 1) as f64 - (1.0 + 1.0 - 0.25 + 1.5)).abs() < 1e-5);
        let flat = TetMesh {
            points: vec![
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [0.0, 1.0, 0.0],
                [1.0, 1.0, 0.0],
            ],
            tets: vec![[0, 1, 2, 3]],
            fields: vec![],
        };
        let e = sample_mesh_field(&flat, "f", &[0.0; 4], [3, 3, 3], 0.0, Path::new("flat.vtk"))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("flat.vtk") && e.contains("flat along axis 2"),
            "{e}"
        );
        let e = sample_mesh_field(&m, "f", &[0.0; 3], [3, 3, 3], 0.0, Path::new("m.vtk"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("3 values for 8 points"), "{e}");
    }
}
