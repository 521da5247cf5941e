//! The built-in demo dataset: a synthetic arterial bifurcation, meshed with
//! tetrahedra and carrying a flow-like field, generated deterministically so
//! the quick start needs no download.
//!
//! # Geometry (millimetres)
//!
//! Four tubes, each a cubic Bézier centreline with a linearly tapering radius:
//!
//! - **parent**: from the inlet near `(8, 0, -100)` to the junction at the
//!   origin, an S-curve in x with a little y; radius 10 → 9; flat inlet cap;
//! - **daughter A**: from the junction to `(42, 10, 72)`, radius 7 → 6, flat
//!   outlet cap;
//! - **daughter B**: from the junction to `(-34, -14, 75)`, radius 6 → 5, flat
//!   outlet cap;
//! - **side branch**: leaves the parent at 45 % of its length towards +x,
//!   radius 4 → 3.5, flat outlet cap.
//!
//! The solid is implicit: each tube's signed distance is `|p - c(s)| - r(s)`
//! to its centreline polyline (48 points per tube), cut by the planes of its
//! open ends; the tubes are merged with a polynomial smooth minimum (radius
//! 4 mm at the junction, 3 mm at the carina, 2 mm at the side branch), which
//! gives filleted junctions. The bifurcation lies roughly in the x-z plane and
//! the flow runs towards +z.
//!
//! # Mesh
//!
//! 1. A regular lattice of spacing `h` covers the solid; `h` is chosen from
//!    `cells_target` and the solid's volume (estimated on a 3 mm grid) so that
//!    about `6 V / h³` tetrahedra result.
//! 2. Each lattice cube is split into the 6 tetrahedra of the Freudenthal
//!    (Kuhn) subdivision around its main diagonal, the same way in every cube,
//!    so the lattice tetrahedralisation is conforming (dihedral angles 45°,
//!    60°, 90°).
//! 3. A tetrahedron is kept when all four of its vertices are inside. Any
//!    subset of a conforming mesh is conforming. Where the kept set pinches
//!    (a boundary edge with 4 boundary triangles, or a boundary vertex whose
//!    boundary triangles form two fans), the lattice tetrahedra around it are
//!    all added or all removed, by majority, until none is left; then only the
//!    largest face-connected component is kept. Tetrahedra whose four
//!    vertices all lie on the boundary (they would be flattened when their
//!    vertices reach a smooth surface) are peeled off, and the repair is
//!    repeated (up to 3 rounds).
//! 4. The staircase boundary is moved onto the surface. Each boundary
//!    vertex's target is its projection on the zero level set (two Newton
//!    steps); from the second pass on, the projection of the point halfway to
//!    the mean of its boundary neighbours (snapping plus tangential
//!    smoothing). A vertex takes the full step or the largest of 1/2, 1/4, 1/8
//!    of it that keeps the smallest dihedral angle of every incident
//!    tetrahedron at or above a floor (`quality_floor_deg`, default 15°), or
//!    not worse than it was. Then interior vertices next to the boundary whose
//!    worst incident tetrahedron is below 35° move to the mean of their
//!    incident tetrahedra's centroids when that improves it. 4 passes. No move
//!    is accepted that makes a volume non-positive.
//! 5. Vertices move in 8 colour classes (lattice index parity): two vertices
//!    of one class never share a tetrahedron, so each class moves in parallel
//!    with a result independent of the thread count. Nothing uses hashing or
//!    randomness, so the same parameters give a bit-identical mesh (tested,
//!    also against a 1-thread pool).
//!
//! Measured at the default target of 150 000 (the `print_statistics` test):
//! 150 365 tetrahedra, 30 474 vertices (9 957 on the wall), `h` = 1.17 mm;
//! tetrahedron volume min 0.0735 (0.046 h³), median 0.285, max 1.43 mm³;
//! smallest dihedral angle 15.6°, 1st percentile 25.0°, 5th 31.4°, median
//! 45°, 62 tetrahedra below 20°. 5 of the 9 957 wall vertices are more than
//! 0.1 h from the implicit surface (at most 0.47 h), the rest on it. The
//! boundary is a closed 2-manifold and the mesh one component. Generation
//! takes about 0.27 s in release on 2 shared cores (0.47 s on one thread;
//! `pvrsim demo --cells 150000 --nodes 0 [--threads 1]`, "generated ... in").
//!
//! Step 3 works on the lattice's kept flags (`clean.rs`) and extracts the
//! mesh once; the extraction numbers vertices and tetrahedra in lattice
//! order, so it decides as repairing an extracted mesh would.
//!
//! # Fields (at the vertices)
//!
//! - `velocity` (m/s): the cross-section mean velocity `Q(s) / (π r(s)²)`
//!   along the local centreline tangent, blended between tubes near the
//!   junctions with weights that fall to 0 over 4 mm of signed-distance
//!   difference. Inlet mean 0.4 m/s; the side branch takes 10 % of the
//!   flow, daughter A 50 %, daughter B 40 %.
//! - `speed` (m/s): `2 |velocity| (1 - (ρ/R)²)`, the Poiseuille profile, with
//!   `d` the distance to the wall (minus the signed distance), `ρ` the
//!   distance to the (blended) centreline and `R = d + ρ`; `d` ignores the
//!   inlet and outlet caps, and the speed is instead faded to 0 over the
//!   last 3 mm before each cap (smoothstep), so that it is 0 on every boundary
//!   vertex (unphysical at the caps, but smooth). It is exactly 0 on the
//!   boundary vertices and positive inside.
//! - `pressure` (Pa): Poiseuille pressure drop `dp/ds = -8 μ Q / (π r⁴)` with
//!   blood viscosity `μ = 3.5 mPa s`, integrated along each tube from the
//!   inlet, continuous at the junctions, shifted so that the lowest outlet is
//!   at 0. It falls along the flow.

use rayon::prelude::*;

use crate::data::mesh::{Adjacency, Field, TetMesh, FACE_VERTICES, NO_NEIGHBOR};
use crate::scene::TransferFunction;

/// Parameters of the demo dataset.
#[derive(Debug, Clone, PartialEq)]
pub struct DemoParams {
    /// Approximate number of tetrahedra (the lattice spacing is chosen for it).
    pub cells_target: usize,
    /// Boundary vertices are not moved onto the surface further than keeps
    /// every incident tetrahedron's smallest dihedral angle above this.
    pub quality_floor_deg: f64,
    /// Passes of boundary snapping plus interior smoothing.
    pub relax_passes: usize,
}

impl Default for DemoParams {
    fn default() -> Self {
        DemoParams {
            cells_target: 150_000,
            quality_floor_deg: 15.0,
            relax_passes: 4,
        }
    }
}

mod clean;
mod fields;
mod geometry;
mod lattice;
mod quality;
mod relax;
mod scene;
#[cfg(test)]
mod tests;
mod topology;
mod vec;

use clean::*;
use fields::*;
use geometry::*;
use lattice::*;
use quality::*;
use relax::*;
use topology::*;
use vec::*;

pub use scene::demo_scene_toml;

// ---------------------------------------------------------------- generation

/// Lattice spacing for about `cells` tetrahedra: `cells = 6 V (1 - c h) / h³`,
/// where `1 - c h` accounts for the boundary layer lost by keeping only the
/// tetrahedra with all four vertices inside (`c = 0.157 / mm`, measured).
fn spacing_for(geo: &Geometry, cells: usize) -> f64 {
    let v = geo.volume_estimate();
    let n = cells.max(100) as f64;
    let mut h = (6.0 * v / n).cbrt();
    for _ in 0..20 {
        h = (6.0 * v * (1.0 - 0.157 * h).max(0.2) / n).cbrt();
    }
    h
}

/// Generates the demo mesh (see the module documentation).
pub fn generate(p: &DemoParams) -> TetMesh {
    let clock = std::time::Instant::now();
    let phase = |what: &str| {
        tracing::info!(
            "demo generator: {what} done at {:.2} s",
            clock.elapsed().as_secs_f64()
        )
    };
    // The volume estimate only needs the sign, which culling at a margin of
    // K_JUNCTION (> every smooth-min bulge, k / 4) preserves.
    let h = spacing_for(&Geometry::new(K_JUNCTION), p.cells_target);
    // Tubes farther than 3 h + the smooth-min radius are irrelevant to which
    // tetrahedra are kept and to the field blending.
    let geo = Geometry::new((3.0 * h + K_JUNCTION).max(BLEND + K_JUNCTION));

    // Lattice with one spacing of margin around the tubes.
    let (lo, hi) = geo.bounds();
    let origin = sub(lo, [1.5 * h; 3]);
    let n = [0, 1, 2].map(|k| ((hi[k] - lo[k] + 3.0 * h) / h).ceil() as usize + 1);
    let lat = Lattice {
        origin,
        h,
        n,
        templates: kuhn_templates(),
    };
    // Which lattice vertices are inside (`phi < 0`), row by row along x;
    // past a point, phi is not evaluated where its clearance shows the
    // point is outside.
    let inside: Vec<bool> = (0..n[2])
        .into_par_iter()
        .flat_map_iter(|k| {
            let (lat, geo) = (&lat, &geo);
            (0..n[1]).flat_map(move |j| {
                let mut clear_to = f64::NEG_INFINITY;
                (0..n[0]).map(move |i| {
                    let p = lat.pos(lat.vid(i, j, k));
                    if p[0] < clear_to {
                        return false;
                    }
                    let hits = geo.hits(p);
                    clear_to = p[0] + geo.clearance(&hits);
                    Geometry::phi_of(&hits) < 0.0
                })
            })
        })
        .collect();
    phase("level set");

    let mut kept = KeptSet::new(select(&lat, &inside));
    drop(inside);

    // Repair pinches and keep the largest component; then peel off the
    // tetrahedra whose four vertices all lie on the boundary (they would be
    // flattened by snapping), and repair again.
    phase("lattice selection");
    clean(&lat, &mut kept, None);
    phase("first clean-up");
    for _ in 0..3 {
        let peeled = peel(&lat, &mut kept);
        if peeled.is_empty() {
            break;
        }
        clean(&lat, &mut kept, Some(peeled));
        phase("peel and clean-up");
    }
    let keep = kept.keep;
    let ex = extract(&lat, &keep);
    let adj = lattice_adjacency(&lat, &keep, &ex);
    phase("extraction");
    let Extracted {
        mut mesh,
        lattice_vertex,
        ..
    } = ex;
    let nv = mesh.points.len();
    let tris = boundary_triangles(&mesh, &adj);
    let mut on_boundary = vec![false; nv];
    for tri in &tris {
        for &v in tri {
            on_boundary[v as usize] = true;
        }
    }
    phase("boundary");
    relax(
        &mut mesh,
        &geo,
        &lattice_vertex,
        &lat,
        &on_boundary,
        &tris,
        p,
    );
    phase("relaxation");
    mesh.fields = flow_fields(&mesh, &geo, &on_boundary, h);
    phase("fields");
    mesh
}

/// The demo mesh and its scene text (see [`generate`] and [`demo_scene_toml`]).
pub fn demo_mesh_and_scene(p: &DemoParams, data_file_name: &str) -> (TetMesh, String) {
    let mesh = generate(p);
    let scene = demo_scene_toml(data_file_name, &mesh);
    (mesh, scene)
}
