//! Step 4 of the generator: boundary vertices snapped onto the surface and
//! interior vertices smoothed, in parallel colour classes.

use super::*;

pub(super) fn relax(
    mesh: &mut TetMesh,
    geo: &Geometry,
    lattice_vertex: &[usize],
    lat: &Lattice,
    on_boundary: &[bool],
    tris: &[[u32; 3]],
    p: &DemoParams,
) {
    let nv = mesh.points.len();
    // Interior vertices that share a tetrahedron with a boundary vertex.
    let mut band = vec![false; nv];
    for t in &mesh.tets {
        if t.iter().any(|&v| on_boundary[v as usize]) {
            for &v in t {
                band[v as usize] = !on_boundary[v as usize];
            }
        }
    }
    // Only boundary and band vertices move or are looked around.
    let moving = |v: usize| on_boundary[v] || band[v];
    let inc = Incidence::new(mesh, moving);
    let colour = |v: usize| {
        let [i, j, k] = lat.vijk(lattice_vertex[v]);
        (i & 1) | (j & 1) << 1 | (k & 1) << 2
    };
    let mut boundary_by_colour: Vec<Vec<usize>> = vec![Vec::new(); 8];
    let mut band_by_colour: Vec<Vec<usize>> = vec![Vec::new(); 8];
    for v in 0..nv {
        if on_boundary[v] {
            boundary_by_colour[colour(v)].push(v);
        } else if band[v] {
            band_by_colour[colour(v)].push(v);
        }
    }
    // Boundary neighbours, from the boundary triangles.
    let mut bnb: Vec<Vec<u32>> = vec![Vec::new(); nv];
    for t in tris {
        for (a, b) in [
            (t[0], t[1]),
            (t[1], t[2]),
            (t[2], t[0]),
            (t[1], t[0]),
            (t[2], t[1]),
            (t[0], t[2]),
        ] {
            if !bnb[a as usize].contains(&b) {
                bnb[a as usize].push(b);
            }
        }
    }
    let bverts: Vec<usize> = (0..nv).filter(|&v| on_boundary[v]).collect();
    let mut target = vec![[0.0; 3]; nv];
    // Qualities are read only around boundary and band vertices: the other
    // tetrahedra (most of a large mesh) are never evaluated.
    let mut quality: Vec<f64> = mesh
        .tets
        .par_iter()
        .map(|t| {
            if t.iter().any(|&v| moving(v as usize)) {
                tet_quality(t.map(|v| mesh.points[v as usize]))
            } else {
                f64::NAN
            }
        })
        .collect();
    let floor = -p.quality_floor_deg.to_radians().cos();
    let smooth_below = -35f64.to_radians().cos();

    // Applies one colour class's moves with the qualities computed when
    // each was accepted. Two vertices of one class never share a
    // tetrahedron, so those are the qualities after the whole class moved.
    let apply = |mesh: &mut TetMesh, quality: &mut Vec<f64>, moves: Vec<(usize, V3, Vec<f64>)>| {
        for (v, q, fresh) in moves {
            mesh.points[v] = q;
            for (&t, x) in inc.of(v).iter().zip(fresh) {
                quality[t as usize] = x;
            }
        }
    };
    let worst_cached = |quality: &[f64], v: usize| {
        inc.of(v)
            .iter()
            .map(|&t| quality[t as usize])
            .fold(1.0, f64::min)
    };

    for pass in 0..p.relax_passes {
        // Targets: the projection of the vertex itself (first pass), then of
        // the point halfway to the mean of its boundary neighbours: snapping
        // plus tangential smoothing.
        let m: &TetMesh = mesh;
        let targets: Vec<V3> = bverts
            .par_iter()
            .map(|&v| {
                if pass == 0 {
                    return geo.project(m.points[v], lat.h);
                }
                let mut c = [0.0; 3];
                for &w in &bnb[v] {
                    c = add(c, m.points[w as usize]);
                }
                let c = scale(c, 1.0 / bnb[v].len() as f64);
                geo.project(lerp3(m.points[v], c, 0.5), lat.h)
            })
            .collect();
        for (&v, q) in bverts.iter().zip(targets) {
            target[v] = q;
        }
        for class in &boundary_by_colour {
            let m: &TetMesh = mesh;
            let moves: Vec<(usize, V3, Vec<f64>)> = class
                .par_iter()
                .filter_map(|&v| {
                    let cur = m.points[v];
                    let step = sub(target[v], cur);
                    if dot(step, step) < 1e-20 {
                        return None;
                    }
                    // Accepted when the worst quality around is at least
                    // the floor (or the old worst) and the volumes positive
                    // (quality -2 otherwise).
                    let at_least = floor.min(worst_cached(&quality, v)).max(-1.5);
                    [1.0, 0.5, 0.25, 0.125].iter().find_map(|&a| {
                        let q = add(cur, scale(step, a));
                        qualities_around(m, &inc, v, q, |x| x >= at_least).map(|f| (v, q, f))
                    })
                })
                .collect();
            apply(mesh, &mut quality, moves);
        }
        for class in &band_by_colour {
            let m: &TetMesh = mesh;
            let moves: Vec<(usize, V3, Vec<f64>)> = class
                .par_iter()
                .filter_map(|&v| {
                    let old = worst_cached(&quality, v);
                    if old >= smooth_below {
                        return None;
                    }
                    let ts = inc.of(v);
                    let mut c = [0.0; 3];
                    for &t in ts {
                        for w in m.tets[t as usize] {
                            c = add(c, m.points[w as usize]);
                        }
                    }
                    let q = scale(c, 1.0 / (4 * ts.len()) as f64);
                    qualities_around(m, &inc, v, q, |x| x > old).map(|f| (v, q, f))
                })
                .collect();
            apply(mesh, &mut quality, moves);
        }
    }
}
