//! Spatially coherent pieces of a mesh, as a solver's ranks hold them:
//! recursive coordinate bisection of the cell centroids. The cells are
//! split along the longest side of their centroids' bounding box at the
//! quantile that gives each side its share of the pieces (`P / 2` and
//! `P - P / 2` pieces), recursively, so piece sizes differ by at most one
//! cell. Ties along the axis are broken by cell index, so the result is
//! deterministic (and independent of the thread count).

/// Cell indices of each of `pieces` pieces (each in ascending order);
/// every cell of `mesh` is in exactly one. `pieces` is at least 1.
pub fn partition(mesh: &crate::data::TetMesh, pieces: usize) -> Vec<Vec<u32>> {
    use rayon::prelude::*;
    let cent: Vec<[f64; 3]> = mesh
        .tets
        .par_iter()
        .map(|t| {
            let mut c = [0.0; 3];
            for &v in t {
                let p = mesh.points[v as usize];
                for k in 0..3 {
                    c[k] += 0.25 * p[k];
                }
            }
            c
        })
        .collect();
    partition_points(&cent, pieces)
}

/// [`partition`] of bare points (the cell centroids).
pub fn partition_points(points: &[[f64; 3]], pieces: usize) -> Vec<Vec<u32>> {
    let mut ids: Vec<u32> = (0..points.len() as u32).collect();
    let mut out = Vec::with_capacity(pieces.max(1));
    bisect(points, &mut ids, pieces.max(1), &mut out);
    for p in &mut out {
        p.sort_unstable();
    }
    out
}

fn bisect(points: &[[f64; 3]], ids: &mut [u32], pieces: usize, out: &mut Vec<Vec<u32>>) {
    if pieces == 1 {
        out.push(ids.to_vec());
        return;
    }
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for &i in ids.iter() {
        let p = points[i as usize];
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    let axis = (0..3)
        .max_by(|&a, &b| (hi[a] - lo[a]).total_cmp(&(hi[b] - lo[b])))
        .unwrap_or(0);
    let left = pieces / 2;
    let split = ids.len() * left / pieces;
    if split > 0 && split < ids.len() {
        ids.select_nth_unstable_by(split, |&a, &b| {
            points[a as usize][axis]
                .total_cmp(&points[b as usize][axis])
                .then(a.cmp(&b))
        });
    }
    let (a, b) = ids.split_at_mut(split);
    let (mut oa, mut ob) = (Vec::new(), Vec::new());
    rayon::join(
        || bisect(points, a, left, &mut oa),
        || bisect(points, b, pieces - left, &mut ob),
    );
    out.extend(oa);
    out.extend(ob);
}
