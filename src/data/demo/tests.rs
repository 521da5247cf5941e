use super::scene::*;
use super::*;
use crate::scene::Scene;
use std::sync::OnceLock;

/// The default mesh, generated once for all tests.
fn mesh() -> &'static TetMesh {
    static MESH: OnceLock<TetMesh> = OnceLock::new();
    MESH.get_or_init(|| generate(&DemoParams::default()))
}

fn boundary_flags(m: &TetMesh) -> Vec<bool> {
    let mut b = vec![false; m.points.len()];
    for t in boundary_triangles(m, &m.adjacency()) {
        for v in t {
            b[v as usize] = true;
        }
    }
    b
}

fn field<'a>(m: &'a TetMesh, name: &str) -> &'a Field {
    m.fields.iter().find(|f| f.name == name).unwrap()
}

/// Unique edges of the mesh.
fn edges(m: &TetMesh) -> Vec<[u32; 2]> {
    let mut e: Vec<[u32; 2]> = m
        .tets
        .iter()
        .flat_map(|t| {
            [(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)]
                .map(|(a, b)| [t[a].min(t[b]), t[a].max(t[b])])
        })
        .collect();
    e.sort_unstable();
    e.dedup();
    e
}

#[test]
fn deterministic_across_runs_and_thread_counts() {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    let again = pool.install(|| generate(&DemoParams::default()));
    let a = mesh();
    assert_eq!(a.tets, again.tets);
    let bits = |m: &TetMesh| {
        m.points
            .iter()
            .flatten()
            .map(|x| x.to_bits())
            .collect::<Vec<_>>()
    };
    assert_eq!(bits(a), bits(&again));
    for (f, g) in a.fields.iter().zip(&again.fields) {
        assert_eq!(f.name, g.name);
        assert!(
            f.values
                .iter()
                .zip(&g.values)
                .all(|(x, y)| x.to_bits() == y.to_bits()),
            "field {}",
            f.name
        );
    }
}

#[test]
fn valid_conforming_mesh() {
    let m = mesh();
    m.validate(std::path::Path::new("demo")).unwrap();
    let adj = m.adjacency();
    assert_eq!(adj.nonmanifold_faces, 0);
    let (bad_edges, bad_vertices) = boundary_defects(&boundary_triangles(m, &adj));
    assert!(
        bad_edges.is_empty() && bad_vertices.is_empty(),
        "boundary not a closed manifold: {} edges, {} vertices",
        bad_edges.len(),
        bad_vertices.len()
    );
    assert_eq!(components(&adj).1, 1, "one connected component");
    // Every point is used.
    let mut used = vec![false; m.points.len()];
    m.tets
        .iter()
        .flatten()
        .for_each(|&v| used[v as usize] = true);
    assert!(used.iter().all(|&u| u));
    // Orientation and shape.
    let h = spacing_for(
        &Geometry::new(K_JUNCTION),
        DemoParams::default().cells_target,
    );
    let vmin = (0..m.tets.len())
        .map(|t| m.tet_volume(t))
        .fold(f64::INFINITY, f64::min);
    assert!(vmin > 0.01 * h * h * h, "min volume {vmin} (h = {h})");
    let dmin = m
        .tets
        .iter()
        .map(|t| min_dihedral_deg(t.map(|v| m.points[v as usize])))
        .fold(180.0, f64::min);
    assert!(
        dmin >= DemoParams::default().quality_floor_deg - 1e-6,
        "min dihedral {dmin}"
    );
}

#[test]
fn cell_count_scales_with_the_target() {
    let n = mesh().tets.len();
    assert!((100_000..=300_000).contains(&n), "{n} tetrahedra");
    assert!(
        (n as f64 / 150_000.0 - 1.0).abs() < 0.1,
        "{n} tetrahedra for a target of 150000"
    );
    let small = generate(&DemoParams {
        cells_target: 20_000,
        ..Default::default()
    });
    let r = small.tets.len() as f64 / 20_000.0;
    assert!(
        (0.75..1.25).contains(&r),
        "{} tetrahedra for a target of 20000",
        small.tets.len()
    );
    assert_eq!(small.adjacency().nonmanifold_faces, 0);
    assert_eq!(components(&small.adjacency()).1, 1);
}

#[test]
fn boundary_lies_on_the_surface() {
    let m = mesh();
    let geo = Geometry::new(BIG);
    let h = spacing_for(&geo, DemoParams::default().cells_target);
    let b = boundary_flags(m);
    let err: Vec<f64> = (0..m.points.len())
        .filter(|&v| b[v])
        .map(|v| geo.phi(m.points[v]).abs())
        .collect();
    let off = err.iter().filter(|&&e| e > 0.1 * h).count();
    let max = err.iter().cloned().fold(0.0, f64::max);
    assert!(
        off * 100 < err.len(),
        "{off} of {} boundary vertices more than 0.1 h off the surface",
        err.len()
    );
    assert!(max < 0.6 * h, "max distance {max}");
}

#[test]
fn fields_are_flow_like() {
    let m = mesh();
    let b = boundary_flags(m);
    let speed = &field(m, "speed").values;
    let vel = &field(m, "velocity").values;
    let pres = &field(m, "pressure").values;
    assert_eq!(field(m, "velocity").components, 3);
    for v in 0..m.points.len() {
        if b[v] {
            assert_eq!(speed[v], 0.0, "wall vertex {v}");
        } else {
            assert!(speed[v] > 0.0, "interior vertex {v}");
        }
    }
    let smax = speed.iter().cloned().fold(0.0, f64::max);
    assert!((0.5..3.0).contains(&smax), "max speed {smax}");
    // Smooth: no jump between neighbours beyond the steepest analytic slope
    // (the wall shear of the side branch, about 0.4 m/s per mm).
    for [a, c] in edges(m) {
        let (a, c) = (a as usize, c as usize);
        let len = norm(sub(m.points[a], m.points[c]));
        assert!(
            (speed[a] - speed[c]).abs() <= 0.6 * len,
            "speed jump on edge {a}-{c}"
        );
        let dv = norm(sub(
            [vel[3 * a], vel[3 * a + 1], vel[3 * a + 2]],
            [vel[3 * c], vel[3 * c + 1], vel[3 * c + 2]],
        ));
        assert!(dv <= 0.2 * len, "velocity jump {dv} on edge {a}-{c}");
    }
    // Flow follows the centrelines, and pressure falls along it.
    let geo = Geometry::new(BIG);
    for (k, tube) in geo.tubes.iter().enumerate() {
        // Branch starts lie inside the parent, where the flows blend.
        let first = if k == PARENT {
            2
        } else {
            CENTRELINE_POINTS / 2
        };
        for i in [first, CENTRELINE_POINTS / 2, CENTRELINE_POINTS - 6] {
            let (v, s, _) = geo.flow_at(tube.pts[i], 0.0);
            assert!(
                dot(v, tube.tan[i]) > 0.9 * norm(v),
                "velocity along the centreline"
            );
            assert!(s > 0.2);
        }
        assert!(
            tube.pres.windows(2).all(|w| w[1] < w[0]),
            "pressure falls along each tube"
        );
    }
    let pmin = pres.iter().cloned().fold(f64::INFINITY, f64::min);
    let pmax = pres.iter().cloned().fold(0.0, f64::max);
    assert!(
        pmin > -1e-9 && pmax > 1.0,
        "pressure range [{pmin}, {pmax}]"
    );
    // The inlet (z lowest) has the highest pressure.
    let inlet = (0..m.points.len())
        .min_by(|&a, &c| m.points[a][2].total_cmp(&m.points[c][2]))
        .unwrap();
    assert!(pres[inlet] > 0.95 * pmax);
}

#[test]
fn scene_parses_and_sees_the_whole_mesh() {
    let m = mesh();
    let text = demo_scene_toml("demo.vtk", m);
    let scene = Scene::parse(&text, std::path::Path::new("data/demo.toml")).unwrap();
    assert_eq!(scene.data.field, "speed");
    assert_eq!(scene.data.path, std::path::Path::new("data/demo.vtk"));
    assert!(text.starts_with("# "));
    let view = scene.view();
    let (lo, hi) = m.bounds();
    let (mut xmin, mut xmax, mut ymin, mut ymax) = (
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
    );
    for c in 0..8 {
        let p = [
            if c & 1 == 0 { lo[0] } else { hi[0] },
            if c & 2 == 0 { lo[1] } else { hi[1] },
            if c & 4 == 0 { lo[2] } else { hi[2] },
        ];
        let cam = view.to_camera(p);
        assert!(cam[2] > 0.0, "corner in front of the eye");
        let [x, y] = view.camera_to_pixel(cam).unwrap();
        assert!(
            x > 0.0 && x < scene.image.width as f64 && y > 0.0 && y < scene.image.height as f64,
            "corner {p:?} at pixel ({x}, {y})"
        );
        (xmin, xmax, ymin, ymax) = (xmin.min(x), xmax.max(x), ymin.min(y), ymax.max(y));
    }
    // Fitted: the box fills the image in at least one direction, up to the margin.
    let fill =
        ((xmax - xmin) / scene.image.width as f64).max((ymax - ymin) / scene.image.height as f64);
    assert!(fill > 0.85, "box fills {fill} of the image");
    // unit_distance gives alpha about 0.9 across the parent.
    let speed = m.scalar("speed").unwrap();
    let range = [0.0, speed.iter().cloned().fold(0.0, f64::max)];
    let geo = Geometry::new(BIG);
    let t = &geo.tubes[PARENT];
    let i = (CENTRELINE_POINTS - 1) / 4;
    let (depth, _) = optical_depth(
        &geo,
        &scene.transfer,
        range,
        t.pts[i],
        [0.0, 1.0, 0.0],
        2.0 * t.rad[i] + 2.0,
    );
    let alpha = 1.0 - (-depth / scene.transfer.unit_distance).exp();
    assert!(
        (0.85..0.95).contains(&alpha),
        "alpha across the parent {alpha}"
    );
}

/// Prints the mesh statistics (`cargo test --release --lib data::demo -- --nocapture`).
#[test]
fn print_statistics() {
    let t0 = std::time::Instant::now();
    let m = generate(&DemoParams::default());
    let dt = t0.elapsed();
    let mut q: Vec<f64> = m
        .tets
        .iter()
        .map(|t| min_dihedral_deg(t.map(|v| m.points[v as usize])))
        .collect();
    q.sort_by(f64::total_cmp);
    let mut vol: Vec<f64> = (0..m.tets.len()).map(|t| m.tet_volume(t)).collect();
    vol.sort_by(f64::total_cmp);
    let wall = boundary_flags(&m).iter().filter(|&&b| b).count();
    let n = q.len();
    eprintln!(
        "demo mesh: generated in {dt:.2?}; {} tetrahedra, {} vertices ({wall} on the wall); volume min {:.4} median {:.4} max {:.4} mm3, total {:.0} mm3; \
         min dihedral {:.2} deg, 1st pct {:.2}, 5th pct {:.2}, median {:.2}; below 20 deg: {}",
        n,
        m.points.len(),
        vol[0],
        vol[n / 2],
        vol[n - 1],
        vol.iter().sum::<f64>(),
        q[0],
        q[n / 100],
        q[n / 20],
        q[n / 2],
        q.iter().filter(|&&a| a < 20.0).count()
    );
}

#[test]
fn lattice_adjacency_equals_the_sorted_face_adjacency() {
    let lat = Lattice {
        origin: [0.0; 3],
        h: 1.0,
        n: [6, 5, 4],
        templates: kuhn_templates(),
    };
    let c = lat.cubes();
    let ntets = c[0] * c[1] * c[2] * 6;
    // A deterministic, irregular subset of the lattice.
    let keep: Vec<bool> = (0..ntets).map(|t| (t * 7919 % 13) < 9).collect();
    let ex = extract(&lat, &keep);
    assert!(ex.mesh.tets.len() > 100);
    assert_eq!(lattice_adjacency(&lat, &keep, &ex), ex.mesh.adjacency());
}
