//! Shared helpers for the cell-projection integration tests: meshes built in
//! code, scene text builders, and the analytic image of a constant-extinction
//! box (f64 ray–box intersection).
#![allow(dead_code)]

use std::path::Path;
use std::sync::{Arc, OnceLock};

use pvrsim::data::demo::{demo_scene_toml, generate, DemoParams};
use pvrsim::data::lattice::kuhn_tets;
use pvrsim::data::{Field, TetMesh};
use pvrsim::image::Image;
use pvrsim::render::cell::{self, CellOptions, CellOrder, CellStats, Integrator};
use pvrsim::render::RenderInput;
use pvrsim::scene::Scene;

/// Both integrators.
pub const INTEGRATORS: [Integrator; 2] = [Integrator::Exact, Integrator::Midpoint];
/// Both cell orders.
pub const ORDERS: [CellOrder; 2] = [CellOrder::Stored, CellOrder::FrontToBack];

/// Name of the scalar field of the meshes built here.
pub const FIELD: &str = "s";

/// Index of lattice vertex `(i, j, k)` of an `(n + 1)^3` lattice.
pub fn lattice_index(n: usize, i: usize, j: usize, k: usize) -> u32 {
    ((k * (n + 1) + j) * (n + 1) + i) as u32
}

/// An axis-aligned box `[origin, origin + size]` cut into `n^3` cells, each
/// split into 6 tets by the Kuhn (Freudenthal) split along its main diagonal
/// `(0,0,0) -> (1,1,1)`: the tet of permutation `(a, b, c)` is
/// `c0, c0 + e_a, c0 + e_a + e_b, c0 + (1,1,1)`. Every cell uses the same
/// split, so the mesh is conforming (neighbours share whole faces). The
/// field `s` is `field(p)` at every vertex.
pub fn box_mesh(
    n: usize,
    origin: [f64; 3],
    size: [f64; 3],
    field: impl Fn([f64; 3]) -> f64,
) -> TetMesh {
    let mut points = Vec::with_capacity((n + 1).pow(3));
    for k in 0..=n {
        for j in 0..=n {
            for i in 0..=n {
                let f = |t: usize, d: usize| origin[d] + size[d] * t as f64 / n as f64;
                points.push([f(i, 0), f(j, 1), f(k, 2)]);
            }
        }
    }
    let tets = kuhn_tets([n; 3], |_, _, _| true);
    let values = points.iter().map(|&p| field(p)).collect();
    TetMesh {
        points,
        tets,
        fields: vec![Field {
            name: FIELD.into(),
            components: 1,
            values,
        }],
    }
}

/// A cube `[origin, origin + size]^3` of `n^3` cells x 6 tets (see [`box_mesh`]).
pub fn cube_mesh(
    n: usize,
    origin: [f64; 3],
    size: f64,
    field: impl Fn([f64; 3]) -> f64,
) -> TetMesh {
    box_mesh(n, origin, [size; 3], field)
}

/// Camera part of a scene.
#[derive(Debug, Clone, Copy)]
pub struct Cam {
    pub eye: [f64; 3],
    pub target: [f64; 3],
    pub up: [f64; 3],
    pub proj: Proj,
}

/// Projection part of a scene.
#[derive(Debug, Clone, Copy)]
pub enum Proj {
    /// World height of the view.
    Ortho(f64),
    /// Vertical field of view, degrees.
    Persp(f64),
}

impl Cam {
    /// Orthographic camera.
    pub fn ortho(eye: [f64; 3], target: [f64; 3], up: [f64; 3], height: f64) -> Cam {
        Cam {
            eye,
            target,
            up,
            proj: Proj::Ortho(height),
        }
    }
    /// Perspective camera.
    pub fn persp(eye: [f64; 3], target: [f64; 3], up: [f64; 3], fov_y_deg: f64) -> Cam {
        Cam {
            eye,
            target,
            up,
            proj: Proj::Persp(fov_y_deg),
        }
    }
    /// The same camera moved by `d`.
    pub fn shifted(&self, d: [f64; 3]) -> Cam {
        let add = |a: [f64; 3]| [a[0] + d[0], a[1] + d[1], a[2] + d[2]];
        Cam {
            eye: add(self.eye),
            target: add(self.target),
            ..*self
        }
    }
}

/// Transfer function, range and image of a test scene.
#[derive(Debug, Clone)]
pub struct Look {
    pub width: u32,
    pub height: u32,
    pub background: [f64; 3],
    pub unit_distance: f64,
    /// `[s, r, g, b, opacity]` control points.
    pub points: Vec<[f64; 5]>,
    /// Scalar range mapped to `[0, 1]`.
    pub range: [f64; 2],
}

impl Look {
    /// Constant colour `rgb` and opacity `o` for every scalar.
    pub fn constant(width: u32, height: u32, rgb: [f64; 3], o: f64, unit_distance: f64) -> Look {
        Look {
            width,
            height,
            background: [0.1, 0.2, 0.3],
            unit_distance,
            points: vec![
                [0.0, rgb[0], rgb[1], rgb[2], o],
                [1.0, rgb[0], rgb[1], rgb[2], o],
            ],
            range: [0.0, 1.0],
        }
    }

    /// A transfer function with several kinks, colour and opacity varying.
    pub fn varied(width: u32, height: u32, unit_distance: f64) -> Look {
        Look {
            width,
            height,
            background: [0.05, 0.1, 0.2],
            unit_distance,
            points: vec![
                [0.0, 0.2, 0.3, 0.8, 0.05],
                [0.3, 0.3, 0.8, 0.4, 0.4],
                [0.55, 0.9, 0.9, 0.2, 0.1],
                [0.8, 0.9, 0.3, 0.1, 0.6],
                [1.0, 0.7, 0.0, 0.1, 0.3],
            ],
            range: [0.0, 1.0],
        }
    }
}

fn v3(a: [f64; 3]) -> String {
    format!("[{:?}, {:?}, {:?}]", a[0], a[1], a[2])
}

/// Scene TOML for `cam` and `look` (the data path is a dummy: meshes are passed in memory).
pub fn scene_toml(cam: &Cam, look: &Look) -> String {
    let proj = match cam.proj {
        Proj::Ortho(h) => format!("projection = \"orthographic\"\nheight = {h:?}\n"),
        Proj::Persp(f) => format!("projection = \"perspective\"\nfov_y_deg = {f:?}\n"),
    };
    let mut s = format!(
        "[data]\npath = \"mesh.vtk\"\nfield = \"{FIELD}\"\nrange = [{:?}, {:?}]\n\n[camera]\neye = {}\ntarget = {}\nup = {}\n{proj}\n[image]\nwidth = {}\nheight = {}\nbackground = {}\n\n[transfer]\nunit_distance = {:?}\npoints = [\n",
        look.range[0],
        look.range[1],
        v3(cam.eye),
        v3(cam.target),
        v3(cam.up),
        look.width,
        look.height,
        v3(look.background),
        look.unit_distance
    );
    for p in &look.points {
        s += &format!(
            "  [{:?}, {:?}, {:?}, {:?}, {:?}],\n",
            p[0], p[1], p[2], p[3], p[4]
        );
    }
    s += "]\n";
    s
}

/// Parses a scene text.
pub fn scene(text: &str) -> Scene {
    Scene::parse(text, Path::new("test.toml")).expect("test scene parses")
}

/// The render input of `mesh` seen by `cam` with `look`.
pub fn input(mesh: TetMesh, cam: &Cam, look: &Look) -> RenderInput {
    RenderInput::new(scene(&scene_toml(cam, look)), Arc::new(mesh)).expect("render input")
}

/// Options with the given integrator and cell order (partial composition on, 32-pixel tiles).
pub fn opts(integrator: Integrator, cell_order: CellOrder) -> CellOptions {
    CellOptions {
        integrator,
        partial_composition: true,
        tile_size: 32,
        cell_order,
        ert: pvrsim::render::cell::ErtOptions::OFF,
        oracle: false,
        canonical: false,
    }
}

/// Renders and checks the image holds no NaN or infinity.
pub fn render_finite(input: &RenderInput, o: &CellOptions) -> (Image, CellStats) {
    let (img, stats) = cell::render(input, o);
    assert!(
        !img.has_non_finite(),
        "non-finite pixel with {o:?}: {:?}",
        img.pixels
            .iter()
            .position(|p| p.iter().any(|v| !v.is_finite()))
    );
    (img, stats)
}

/// `t` range `(t0, t1)` of the ray `o + t d` inside the box `[lo, hi]`, for
/// `t >= 0` (slab method, f64); `None` if it misses.
pub fn ray_box(o: [f64; 3], d: [f64; 3], lo: [f64; 3], hi: [f64; 3]) -> Option<(f64, f64)> {
    let (mut t0, mut t1) = (0.0f64, f64::INFINITY);
    for k in 0..3 {
        if d[k] == 0.0 {
            if o[k] < lo[k] || o[k] > hi[k] {
                return None;
            }
            continue;
        }
        let (a, b) = ((lo[k] - o[k]) / d[k], (hi[k] - o[k]) / d[k]);
        let (a, b) = if a < b { (a, b) } else { (b, a) };
        t0 = t0.max(a);
        t1 = t1.min(b);
    }
    (t0 < t1).then_some((t0, t1))
}

/// Length of the chord of pixel `(i, j)`'s ray through the box `[lo, hi]`.
pub fn chord(scene: &Scene, i: u32, j: u32, lo: [f64; 3], hi: [f64; 3]) -> f64 {
    let (o, d) = scene.view().ray(i, j);
    ray_box(o, d, lo, hi).map_or(0.0, |(a, b)| b - a)
}

/// Final pixel `[r, g, b, a]` of a ray crossing `len` world units of constant
/// colour `rgb` and opacity `o` (per `ud`), over `bg`.
pub fn slab_pixel(len: f64, rgb: [f64; 3], o: f64, ud: f64, bg: [f64; 3]) -> [f64; 4] {
    let o = o.min(1.0 - 1e-6);
    let a = 1.0 - (1.0 - o).powf(len / ud);
    [
        rgb[0] * a + (1.0 - a) * bg[0],
        rgb[1] * a + (1.0 - a) * bg[1],
        rgb[2] * a + (1.0 - a) * bg[2],
        a,
    ]
}

/// The analytic image of a constant box `[lo, hi]` under `look` (whose TF
/// must be constant) and the scene's camera.
pub fn analytic_box_image(scene: &Scene, look: &Look, lo: [f64; 3], hi: [f64; 3]) -> Vec<[f64; 4]> {
    let p = look.points[0];
    let mut out = Vec::with_capacity((look.width * look.height) as usize);
    for j in 0..look.height {
        for i in 0..look.width {
            let l = chord(scene, i, j, lo, hi);
            out.push(slab_pixel(
                l,
                [p[1], p[2], p[3]],
                p[4],
                look.unit_distance,
                look.background,
            ));
        }
    }
    out
}

/// Largest per-channel difference between `img` and `want`, and where (pixel index).
pub fn max_err(img: &Image, want: &[[f64; 4]]) -> (f64, usize) {
    let mut worst = (0.0f64, 0usize);
    for (k, (p, w)) in img.pixels.iter().zip(want).enumerate() {
        for c in 0..4 {
            let e = (p[c] as f64 - w[c]).abs();
            if e > worst.0 || e.is_nan() {
                worst = (e, k);
            }
        }
    }
    worst
}

/// The demo mesh (~20k cells) and its scene, generated once per test binary.
pub fn demo_input() -> &'static RenderInput {
    static DEMO: OnceLock<RenderInput> = OnceLock::new();
    DEMO.get_or_init(|| {
        let mesh = generate(&DemoParams {
            cells_target: 20_000,
            ..Default::default()
        });
        let text = demo_scene_toml("demo.vtk", &mesh);
        RenderInput::new(scene(&text), Arc::new(mesh)).expect("demo input")
    })
}

/// `t` range of the ray `o + t d` (`t >= 0`) inside the tetrahedron `v` (f64); `None` if it misses.
pub fn ray_tet(o: [f64; 3], d: [f64; 3], v: [[f64; 3]; 4]) -> Option<(f64, f64)> {
    let sub = |a: [f64; 3], b: [f64; 3]| [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
    let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let cross = |a: [f64; 3], b: [f64; 3]| {
        [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ]
    };
    let (mut t0, mut t1) = (0.0f64, f64::INFINITY);
    for f in 0..4 {
        let [a, b, c] = [(f + 1) % 4, (f + 2) % 4, (f + 3) % 4].map(|k| v[k]);
        let mut n = cross(sub(b, a), sub(c, a));
        if dot(n, sub(v[f], a)) > 0.0 {
            n = n.map(|x| -x); // outward
        }
        let den = dot(n, d);
        let num = dot(n, sub(a, o));
        if den > 0.0 {
            t1 = t1.min(num / den);
        } else if den < 0.0 {
            t0 = t0.max(num / den);
        } else if num < 0.0 {
            return None;
        }
    }
    (t0 < t1).then_some((t0, t1))
}

/// The oblique camera with a rational frame: view direction `(3, 4, 12) / 13`,
/// `up = +z`, so `right = (4, -3, 0) / 5` and screen up `(-36, -48, 25) / 65`.
/// With `target` a lattice point of spacing 5 and an odd image size, lattice
/// point `target + 5 (x, y, z)` projects to pixel
/// `(W/2 + (4x - 3y) / ps, H/2 - (-36x - 48y + 25z) / (13 ps))`, a pixel centre
/// whenever both offsets are integers (up to f64 rounding, far below an f32 ulp).
pub fn rational_cam(target: [f64; 3], pixel_size: f64, height_px: u32) -> Cam {
    let eye = [target[0] - 12.0, target[1] - 16.0, target[2] - 48.0];
    Cam::ortho(eye, target, [0.0, 0.0, 1.0], pixel_size * height_px as f64)
}

/// The analytic image of a single constant tet `v` under `look` (constant TF).
pub fn analytic_tet_image(scene: &Scene, look: &Look, v: [[f64; 3]; 4]) -> Vec<[f64; 4]> {
    let p = look.points[0];
    let view = scene.view();
    let mut out = Vec::with_capacity((look.width * look.height) as usize);
    for j in 0..look.height {
        for i in 0..look.width {
            let (o, d) = view.ray(i, j);
            let l = ray_tet(o, d, v).map_or(0.0, |(a, b)| b - a);
            out.push(slab_pixel(
                l,
                [p[1], p[2], p[3]],
                p[4],
                look.unit_distance,
                look.background,
            ));
        }
    }
    out
}
