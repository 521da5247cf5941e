//! World placement of a grid from a file's per-axis direction vectors.
//!
//! Formats describe where sample `(i, j, k)` sits as
//! `world = origin + i d_0 + j d_1 + k d_2` (NRRD `space directions`,
//! NIfTI's sform columns, VTI `Direction` x `Spacing`). pvrsim's
//! [`Volume`](crate::data::Volume) keeps the axis-aligned case with
//! positive spacing, so each `d_a` must be parallel to world axis `a`
//! (off-axis components at most 1e-6 of the on-axis one, which absorbs
//! rounding in written files). A negative `d_a` is turned positive by
//! reversing the samples along axis `a` and moving the origin to the old
//! last sample, `origin_a += (n_a - 1) d_a`; every sample keeps its world
//! position. Rotated or permuted axes are refused with an error naming the
//! field: resampling them would change the data behind the user's back.

use std::path::Path;

use crate::data::Voxels;
use crate::error::{Error, Result};

/// Relative size of off-axis components tolerated in a direction vector.
pub const AXIS_TOLERANCE: f64 = 1e-6;

/// The axis-aligned placement derived from direction vectors.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Placement {
    /// World position of the first sample after flips.
    pub origin: [f64; 3],
    /// Positive spacing per axis.
    pub spacing: [f64; 3],
    /// Axes whose samples must be reversed.
    pub flip: [bool; 3],
}

/// Checks `dirs` (index axis `a` runs along `dirs[a]`) and derives the
/// placement for a grid of `dims` samples. `location` names the field in
/// errors.
pub fn axis_aligned(
    path: &Path,
    location: &str,
    dims: [u64; 3],
    dirs: [[f64; 3]; 3],
    origin: [f64; 3],
) -> Result<Placement> {
    let mut out = Placement {
        origin,
        spacing: [0.0; 3],
        flip: [false; 3],
    };
    const AX: [char; 3] = ['x', 'y', 'z'];
    for a in 0..3 {
        let d = dirs[a];
        if d.iter().any(|v| !v.is_finite()) {
            return Err(Error::data(
                path,
                location,
                format!("direction of axis {a} {d:?} is not finite"),
            ));
        }
        let big = (0..3)
            .max_by(|&p, &q| d[p].abs().total_cmp(&d[q].abs()))
            .unwrap_or(a);
        if d[big] == 0.0 {
            return Err(Error::data(
                path,
                location,
                format!("direction of axis {a} is zero (a grid needs a non-zero spacing)"),
            ));
        }
        if big != a {
            return Err(Error::data(
                path,
                location,
                format!(
                    "index axis {a} runs along world {} ({d:?}): permuted axes are not supported; pvrsim needs index axes i, j, k along world x, y, z (reorient the file, e.g. with fslreorient2std or unu permute)",
                    AX[big]
                ),
            ));
        }
        if (0..3).any(|b| b != a && d[b].abs() > AXIS_TOLERANCE * d[a].abs()) {
            return Err(Error::data(
                path,
                location,
                format!(
                    "direction of axis {a} {d:?} is not axis-aligned: oblique grids are not supported (resample the file to an axis-aligned grid)"
                ),
            ));
        }
        out.spacing[a] = d[a].abs();
        if d[a] < 0.0 {
            out.flip[a] = true;
            out.origin[a] += (dims[a] - 1) as f64 * d[a];
        }
    }
    Ok(out)
}

/// Reverses the sample order along `axis` of a grid of `dims` (x fastest).
pub fn flip_axis(voxels: &mut Voxels, dims: [u64; 3], axis: usize) {
    fn flip<T>(v: &mut [T], dims: [u64; 3], axis: usize) {
        let block: usize = dims[..axis].iter().product::<u64>() as usize;
        let n = dims[axis] as usize;
        let outer = v.len() / (block * n).max(1);
        for o in 0..outer {
            let slab = &mut v[o * n * block..(o + 1) * n * block];
            for j in 0..n / 2 {
                let (lo, hi) = slab.split_at_mut((n - 1 - j) * block);
                lo[j * block..(j + 1) * block].swap_with_slice(&mut hi[..block]);
            }
        }
    }
    match voxels {
        Voxels::U8(v) => flip(v, dims, axis),
        Voxels::U16(v) => flip(v, dims, axis),
        Voxels::I16(v) => flip(v, dims, axis),
        Voxels::F32(v) => flip(v, dims, axis),
    }
}

/// Applies the flips of `p` to `voxels`.
pub fn apply_flips(voxels: &mut Voxels, dims: [u64; 3], p: &Placement) {
    for a in 0..3 {
        if p.flip[a] {
            flip_axis(voxels, dims, a);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn negative_direction_flips_and_keeps_world_positions() {
        let dims = [3, 2, 2];
        let p = axis_aligned(
            Path::new("f"),
            "dirs",
            dims,
            [[-2.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, -0.5]],
            [10.0, 0.0, 5.0],
        )
        .unwrap();
        assert_eq!(p.spacing, [2.0, 1.0, 0.5]);
        assert_eq!(p.origin, [6.0, 0.0, 4.5]);
        assert_eq!(p.flip, [true, false, true]);
        let mut v = Voxels::U8((0..12).collect());
        apply_flips(&mut v, dims, &p);
        // Old sample (i, j, k) = i + 3 j + 6 k moves to (2 - i, j, 1 - k).
        let Voxels::U8(w) = v else { unreachable!() };
        for k in 0..2usize {
            for j in 0..2usize {
                for i in 0..3usize {
                    let old = i + 3 * j + 6 * k;
                    assert_eq!(w[(2 - i) + 3 * j + 6 * (1 - k)] as usize, old);
                }
            }
        }
    }

    #[test]
    fn refuses_rotation_and_permutation() {
        let f = |d| axis_aligned(Path::new("f"), "dirs", [2; 3], d, [0.0; 3]);
        let e = f([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]).unwrap_err();
        assert!(e.to_string().contains("permuted"), "{e}");
        let e = f([[1.0, 0.1, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]).unwrap_err();
        assert!(e.to_string().contains("not axis-aligned"), "{e}");
        let e = f([[0.0; 3], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]).unwrap_err();
        assert!(e.to_string().contains("zero"), "{e}");
        assert!(f([[1.0, 1e-9, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]).is_ok());
    }
}
