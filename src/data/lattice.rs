//! The Kuhn (Freudenthal) split of a grid of cubes into tetrahedra: every
//! cube cut into 6 tets along its main diagonal `(0,0,0) -> (1,1,1)`; the
//! tet of axis order `(a, b, c)` is `c0, c0 + e_a, c0 + e_a + e_b,
//! c0 + (1,1,1)`. Every cube uses the same split, so the mesh is conforming
//! (neighbours share whole faces). The built-in demo and the tests' synthetic
//! meshes are built from it.

/// The six axis orders, one per tet of a cube.
pub const KUHN_AXIS_ORDERS: [[usize; 3]; 6] = [
    [0, 1, 2],
    [0, 2, 1],
    [1, 0, 2],
    [1, 2, 0],
    [2, 0, 1],
    [2, 1, 0],
];

/// The tets of the cubes `(i, j, k)` of an `n[0] x n[1] x n[2]` grid for
/// which `keep(i, j, k)` holds, 6 per cube in the order of
/// [`KUHN_AXIS_ORDERS`], cubes with `i` fastest. Vertex `(i, j, k)` of the
/// `(n + 1)` lattice has index `i + (n[0] + 1) * (j + (n[1] + 1) * k)`. The
/// tets walk the axes in order, so half of them are negatively oriented.
pub fn kuhn_tets(n: [usize; 3], keep: impl Fn(usize, usize, usize) -> bool) -> Vec<[u32; 4]> {
    let id = |c: [usize; 3]| (c[0] + (n[0] + 1) * (c[1] + (n[1] + 1) * c[2])) as u32;
    let mut tets = Vec::with_capacity(6 * n[0] * n[1] * n[2]);
    for k in 0..n[2] {
        for j in 0..n[1] {
            for i in 0..n[0] {
                if !keep(i, j, k) {
                    continue;
                }
                for order in KUHN_AXIS_ORDERS {
                    let mut c = [i, j, k];
                    let mut tet = [id(c); 4];
                    for (s, &axis) in order.iter().enumerate() {
                        c[axis] += 1;
                        tet[s + 1] = id(c);
                    }
                    tets.push(tet);
                }
            }
        }
    }
    tets
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_cube_is_six_tets_sharing_the_diagonal() {
        let t = kuhn_tets([1, 1, 1], |_, _, _| true);
        assert_eq!(t.len(), 6);
        assert!(t.iter().all(|t| t[0] == 0 && t[3] == 7));
        assert_eq!(t[0], [0, 1, 3, 7]);
        assert!(kuhn_tets([2, 1, 1], |i, _, _| i == 1)
            .iter()
            .all(|t| t[0] == 1));
    }
}
