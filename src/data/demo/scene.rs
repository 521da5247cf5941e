//! The demo scene: camera, transfer function and the scene TOML text.

use super::*;

/// Image size of the demo scene.
pub(super) const IMAGE: (u32, u32) = (512, 384);

/// ParaView's "Cool to Warm" map, piecewise linear through five of its colours.
pub(super) fn cool_to_warm(s: f64) -> V3 {
    pub(super) const C: [V3; 5] = [
        [0.230, 0.299, 0.754],
        [0.552, 0.690, 0.996],
        [0.865, 0.865, 0.865],
        [0.958, 0.604, 0.482],
        [0.706, 0.016, 0.150],
    ];
    let x = s.clamp(0.0, 1.0) * 4.0;
    let i = (x.floor() as usize).min(3);
    lerp3(C[i], C[i + 1], x - i as f64)
}

/// Opacity control points `(s, opacity)`: 0 at rest, high over the slow
/// near-wall shell, translucent in the middle, rising again for the fastest
/// cores (the shape of the aorta scenes' function).
pub(super) const OPACITY: [(f64, f64); 8] = [
    (0.0, 0.0),
    (0.04, 0.2),
    (0.10, 0.65),
    (0.24, 0.65),
    (0.34, 0.3),
    (0.5, 0.08),
    (0.75, 0.12),
    (1.0, 0.24),
];

pub(super) fn demo_transfer(unit_distance: f64) -> TransferFunction {
    use crate::scene::ControlPoint;
    let points = OPACITY
        .iter()
        .map(|&(s, opacity)| ControlPoint {
            s,
            rgb: cool_to_warm(s),
            opacity,
        })
        .collect();
    TransferFunction {
        points,
        unit_distance,
    }
}

/// `sum of -ln(1 - opacity) dt` along a straight ray through `c` in direction
/// `dir` (the optical depth times `unit_distance`), and the lumen length crossed.
pub(super) fn optical_depth(
    geo: &Geometry,
    tf: &TransferFunction,
    range: [f64; 2],
    c: V3,
    dir: V3,
    half: f64,
) -> (f64, f64) {
    let dt = 0.05;
    let n = (2.0 * half / dt) as usize;
    let (mut depth, mut len) = (0.0, 0.0);
    for i in 0..n {
        let p = add(c, scale(dir, -half + (i as f64 + 0.5) * dt));
        if geo.phi(p) >= 0.0 {
            continue;
        }
        let (_, speed, _) = geo.flow_at(p, 0.0);
        let s = (speed - range[0]) / (range[1] - range[0]);
        let o = tf.eval(s).1.min(crate::scene::transfer::OPACITY_MAX);
        depth += -(1.0 - o).ln() * dt;
        len += dt;
    }
    (depth, len)
}

/// Scene TOML (`shared/spec/scene.md`) for the demo mesh: field `speed`, an
/// orthographic camera looking along +y at the bifurcation plane (image
/// right = +z, the flow direction; image up = -x), fitted to the mesh bounds
/// with a 5 % margin, 512 x 384, black background, a cool-to-warm transfer
/// function, and `unit_distance` chosen so that a ray across the parent vessel
/// reaches alpha 0.9. A comment block at the top explains the choices.
pub fn demo_scene_toml(data_file_name: &str, mesh: &TetMesh) -> String {
    let (lo, hi) = mesh.bounds();
    let centre = [
        0.5 * (lo[0] + hi[0]),
        0.5 * (lo[1] + hi[1]),
        0.5 * (lo[2] + hi[2]),
    ];
    let ext = sub(hi, lo);
    let (w, h) = IMAGE;
    // right = +z, screen up = -x: the projected box is ext[2] wide, ext[0] high.
    let (pw, ph) = (ext[2] * 1.1, ext[0] * 1.1);
    let height = ((ph.max(pw * h as f64 / w as f64)) * 100.0).ceil() / 100.0;
    let r3 = |x: f64| (x * 1000.0).round() / 1000.0;
    let target = centre.map(r3);
    let eye = [target[0], r3(lo[1] - ext[1] - 100.0), target[2]];

    let speed = mesh.scalar("speed").unwrap_or_default();
    let range = [
        speed.iter().cloned().fold(f64::INFINITY, f64::min),
        speed.iter().cloned().fold(f64::NEG_INFINITY, f64::max),
    ];
    let range = if range[0] < range[1] {
        range
    } else {
        [0.0, 1.0]
    };

    // unit_distance: alpha 0.9 across the parent vessel (a quarter along it,
    // upstream of the side branch), along the view direction.
    let geo = Geometry::new(BIG);
    let tf1 = demo_transfer(1.0);
    let y = [0.0, 1.0, 0.0];
    let probe = |tube: usize, t: f64| {
        let tb = &geo.tubes[tube];
        let i = ((tb.pts.len() - 1) as f64 * t).round() as usize;
        optical_depth(&geo, &tf1, range, tb.pts[i], y, tb.rad[i] * 2.0 + 2.0)
    };
    let (parent_depth, _) = probe(PARENT, 0.25);
    let ud_exact = parent_depth / 10f64.ln();
    // Two significant digits, printed exactly as used.
    let ud: f64 = {
        let decimals = (1.0 - ud_exact.log10().floor()).max(0.0) as usize;
        format!("{ud_exact:.decimals$}").parse().unwrap_or(ud_exact)
    };
    let tf = demo_transfer(ud);
    let alpha = |(depth, len): (f64, f64)| (1.0 - (-depth / ud).exp(), len);
    let probes = [
        (
            "parent (r = 10 -> 9 mm), a quarter along it",
            probe(PARENT, 0.25),
        ),
        ("parent just before the junction", probe(PARENT, 0.9)),
        (
            "daughter A (r = 7 -> 6 mm), halfway",
            probe(DAUGHTER_A, 0.5),
        ),
        (
            "daughter B (r = 6 -> 5 mm), halfway",
            probe(DAUGHTER_B, 0.5),
        ),
        ("side branch (r = 4 -> 3.5 mm), halfway", probe(SIDE, 0.5)),
    ];
    let mean_opacity = speed
        .iter()
        .map(|&v| tf.eval((v - range[0]) / (range[1] - range[0])).1)
        .sum::<f64>()
        / speed.len().max(1) as f64;
    let wall = speed.iter().filter(|&&v| v == 0.0).count();

    let mut s = String::new();
    s += "# pvrsim demo: a synthetic arterial bifurcation (generated by pvrsim, not patient data), mm and m/s.\n";
    s += &format!(
        "# Data: {data_file_name}, {} tetrahedra, {} vertices; speed = 2 |velocity| (1 - (rho/R)^2) (Poiseuille-like,\n",
        mesh.tets.len(),
        mesh.points.len()
    );
    s += &format!(
        "# 0 on the {wall} wall vertices); range = the field's min..max, [{:.4}, {:.4}] m/s.\n",
        range[0], range[1]
    );
    s += "# Camera: orthographic, looking along +y at the bifurcation plane: image right = +z (the flow runs left to right,\n";
    s += "# inlet at the left, outlets at the right), image up = -x (daughter B above, daughter A and the side branch below).\n";
    s += &format!(
        "# Fitted to the mesh bounding box with a 5% margin on each side (projected extent {:.1} x {:.1} mm).\n",
        ext[2], ext[0]
    );
    s += "# Transfer function: colours blue -> red (ParaView 'Cool to Warm'); opacity rises fast from 0 at the wall,\n";
    s += "# is high for slow flow (the near-wall shell, s 0.10-0.24), translucent around s = 0.5 and rises again to 0.24\n";
    s += "# for the fastest cores, as in the aorta scenes.\n";
    s += &format!(
        "# Mean TF opacity over all {} vertices = {mean_opacity:.4}.\n",
        speed.len()
    );
    s += &format!(
        "# unit_distance = {ud} mm, so that a ray across the parent vessel along the view direction reaches alpha 0.9\n"
    );
    s += "# (exact value for that: ";
    s += &format!(
        "{ud_exact:.3} mm). Accumulated alpha along such rays (analytic field, 0.05 mm steps):\n"
    );
    for (name, d) in probes {
        let (a, len) = alpha(d);
        s += &format!("#   {name}: {a:.3} over {len:.1} mm of lumen\n");
    }
    s += "\n[data]\n";
    s += &format!("path  = {data_file_name:?}\nfield = \"speed\"\n");
    s += "\n[camera]\n";
    let v = |p: V3| format!("[{}, {}, {}]", p[0], p[1], p[2]);
    s += &format!(
        "eye        = {}\ntarget     = {}\nup         = [-1, 0, 0]\n",
        v(eye),
        v(target)
    );
    s += &format!("projection = \"orthographic\"\nheight     = {height}\n");
    s += &format!("\n[image]\nwidth      = {w}\nheight     = {h}\nbackground = [0, 0, 0]\n");
    s += &format!("\n[transfer]\nunit_distance = {ud}\npoints = [\n");
    for p in &tf.points {
        s += &format!(
            "  [{:.4}, {:.4}, {:.4}, {:.4}, {:.4}],\n",
            p.s, p.rgb[0], p.rgb[1], p.rgb[2], p.opacity
        );
    }
    s += "]\n";
    s
}
