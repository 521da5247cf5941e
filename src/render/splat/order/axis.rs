//! Westover's axis-aligned order: slices perpendicular to the grid axis most
//! parallel to the view (largest weight `|w_a|`, the first on a tie), drawn
//! far to near; inside a slice, rows and voxels also go far to near (a
//! raster from the far corner), the lower-numbered axis innermost.
//!
//! A raster from the far corner puts every voxel after its farther face
//! neighbours, so this order is back-to-front-correct for cubes. What it gets
//! wrong is the *sheet* order: a whole slice is drawn before the next, so
//! overlapping footprints of voxels of different slices composite in slice
//! order rather than depth order, and near 45° the chosen axis flips (the
//! popping the paper's Fig. 2 shows).

use super::{strides, Octant};

/// The dominant axis (largest weight; the lowest index on a tie) and the
/// other two, lower index first.
pub fn axes(o: &Octant) -> [usize; 3] {
    let mut a0 = 0;
    for a in 1..3 {
        if o.weight[a] > o.weight[a0] {
            a0 = a;
        }
    }
    let (a1, a2) = match a0 {
        0 => (1, 2),
        1 => (0, 2),
        _ => (0, 1),
    };
    [a0, a1, a2]
}

/// Walks box `o` of a `dims` grid slice by slice, far to near.
#[inline]
pub fn walk(o: &Octant, dims: [u64; 3], f: &mut impl FnMut(u64)) {
    walk_coords(o, dims, &mut |idx, _| f(idx));
}

/// [`walk`], also handing over each voxel's grid coordinates `(i, j, k)`.
#[inline]
pub fn walk_coords(o: &Octant, dims: [u64; 3], f: &mut impl FnMut(u64, [u64; 3])) {
    if o.is_empty() {
        return;
    }
    let st = strides(dims);
    let [a0, inner, mid] = axes(o);
    let (d0, dm, di) = (
        o.near_stride(a0, st),
        o.near_stride(mid, st),
        o.near_stride(inner, st),
    );
    let (n0, nm, ni) = (o.len(a0), o.len(mid), o.len(inner));
    let mut slice = o.far_corner(st);
    let mut g = [0u64; 3];
    for t0 in 0..n0 {
        g[a0] = o.far_index(a0, t0);
        let mut row = slice;
        for tm in 0..nm {
            g[mid] = o.far_index(mid, tm);
            let mut idx = row;
            for ti in 0..ni {
                g[inner] = o.far_index(inner, ti);
                f(idx as u64, g);
                idx += di;
            }
            row += dm;
        }
        slice += d0;
    }
}
