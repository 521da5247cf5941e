//! The reference renderer: the f64 oracle every accuracy claim is measured
//! against. It shares nothing with the cell-projection renderer but the scene,
//! transfer-function and mesh types.
//!
//! # What it computes
//!
//! For each pixel, the ray `r(t) = o + t d` of [`View::ray`](crate::scene::View::ray)
//! (`d` unit, `t >= 0`; `t` is the spec's depth: along the view direction for
//! an orthographic camera, along the ray for a perspective one) is followed
//! through every tetrahedron it crosses. Inside a tet the scalar is the
//! barycentric (linear) interpolant, so along the ray it is linear in `t`
//! between the tet's entry and exit. The emission–absorption model of
//! `scene.md` is
//!
//! ```text
//!   tau(s) = -ln(1 - min(opacity(s), 1 - 1e-6)) / unit_distance
//!   T(t)   = exp(-∫_0^t tau(s(u)) du)
//!   C      = ∫ c(s(t)) tau(s(t)) T(t) dt,    A = 1 - T(end)
//!   pixel  = C + (1 - A) background,         alpha = A
//! ```
//!
//! Per stretch the result is a premultiplied `(C, T)` pair, composited front
//! to back (`C += T_front C_seg`, `T_front *= T_seg`) over the whole ray; the
//! ray stops only when `T_front < 1e-12` ([`T_MIN`]): there is no early ray
//! termination beyond that.
//!
//! # How
//!
//! - `walk`: finding every stretch. The mesh need not be convex: all
//!   boundary faces the ray enters through are found with a BVH over the
//!   boundary faces, and each starts a walk from tet to tet across shared
//!   faces, with watertight (Plücker) face tests, robust to rays through
//!   edges and vertices, along edges, and to degenerate tets, and a recovery
//!   (point location with a BVH over the tets and barycentric clipping) when a
//!   walk gets stuck. A ray whose origin is inside the mesh starts in the tet
//!   located there.
//! - `quadrature`: each stretch is cut at the transfer function's control
//!   points (and where the opacity crosses the clamp `1 - 1e-6`), and each
//!   kink-free piece is integrated by adaptive Gauss–Legendre collocation
//!   whose local tolerance is `tol · length / (L_ref · T_front)`, `L_ref` the
//!   bounding-box diagonal, so the estimated error per pixel channel (and in
//!   alpha) is at most `tol` ([`ReferenceOptions::tolerance`], default 1e-6).
//! - `bvh`: the hierarchy both searches use.
//!
//! Everything is f64 and ray-relative (`p - o`), so a mesh offset by 1e6
//! renders the same image. Rows are rendered in parallel with rayon; every
//! pixel is computed by the same sequential code whatever the thread count,
//! so the image is bit-identical for any number of threads.

mod bvh;
mod quadrature;
mod walk;

#[cfg(test)]
mod tests;

use std::time::Instant;

use rayon::prelude::*;

use crate::data::Adjacency;
use crate::image::Image;
use crate::render::RenderInput;

/// A ray stops once its transmittance is below this.
pub const T_MIN: f64 = 1e-12;

/// Options of the reference renderer.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ReferenceOptions {
    /// Absolute error budget per pixel channel (RGB and alpha, in `[0, 1]`
    /// units) for the quadrature. Values below 1e-14 are raised to 1e-14.
    pub tolerance: f64,
}

impl Default for ReferenceOptions {
    fn default() -> Self {
        ReferenceOptions { tolerance: 1e-6 }
    }
}

/// What the reference renderer did.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct ReferenceStats {
    /// Rays cast (one per pixel).
    pub rays: u64,
    /// Rays that met the mesh.
    pub rays_hit: u64,
    /// Walks started: boundary entries taken plus origins inside the mesh.
    pub mesh_entries: u64,
    /// Rays whose origin lay inside the mesh.
    pub origin_inside: u64,
    /// Entering boundary-face crossings found by the BVH (before skipping the
    /// ones already passed).
    pub boundary_hits: u64,
    /// Tet visits of all walks (a tet is counted each time it is entered;
    /// location steps, including the check after each exit, count too).
    pub tets_visited: u64,
    /// Visits that advanced the ray by nothing (edge / vertex circulation,
    /// degenerate tets).
    pub zero_length_steps: u64,
    /// Times a walk got stuck (or left through a boundary face while the ray
    /// was still inside the mesh) and went on with a locate-and-clip step.
    pub walk_recoveries: u64,
    /// Walks given up after too many recoveries (the rest of the ray was
    /// then taken from the next boundary entry; a stretch may be missing).
    pub walks_abandoned: u64,
    /// Kink-free pieces integrated.
    pub quadrature_pieces: u64,
    /// Applications of the 8-node rule.
    pub quadrature_rules: u64,
    /// Intervals accepted at the refinement depth limit without meeting the
    /// tolerance (0 in a healthy run).
    pub quadrature_depth_limited: u64,
    /// Boundary faces of the mesh.
    pub boundary_faces: u64,
    /// The tolerance used.
    pub tolerance: f64,
    /// Time to build the hierarchies, seconds.
    pub build_time_s: f64,
    /// Wall time of the whole render, seconds (including the build).
    pub time_s: f64,
    /// Rayon threads available.
    pub threads: usize,
}

/// Renders `input` with the reference method. `adjacency` must be
/// `input.mesh.adjacency()` (if its length does not match the mesh it is
/// recomputed). The mesh must have valid indices ([`crate::data::TetMesh::validate`]);
/// any geometry is accepted, including inverted, flat and sliver tets.
pub fn render(
    input: &RenderInput,
    adjacency: &Adjacency,
    opts: &ReferenceOptions,
) -> (Image, ReferenceStats) {
    let start = Instant::now();
    let scene = &input.scene;
    let (w, h) = (scene.image.width, scene.image.height);
    let view = scene.camera.view(w, h);
    let bg = scene.image.background;
    let tol = if opts.tolerance.is_nan() {
        1e-6
    } else {
        opts.tolerance.max(1e-14)
    };
    let own_adj;
    let adj = if adjacency.neighbors.len() == input.mesh.tets.len() {
        adjacency
    } else {
        own_adj = input.mesh.adjacency();
        &own_adj
    };
    let tracer = walk::Tracer::new(&input.mesh, adj, &input.s_norm, tol, &scene.transfer);
    let build_time_s = start.elapsed().as_secs_f64();

    let rows: Vec<(Vec<[f32; 4]>, walk::RayCounters)> = (0..h)
        .into_par_iter()
        .map(|j| {
            let mut ctr = walk::RayCounters::default();
            let row = (0..w)
                .map(|i| {
                    let (o, d) = view.ray(i, j);
                    let acc = tracer.trace(o, d, &mut ctr);
                    let a = 1.0 - acc.t;
                    [
                        (acc.c[0] + acc.t * bg[0]) as f32,
                        (acc.c[1] + acc.t * bg[1]) as f32,
                        (acc.c[2] + acc.t * bg[2]) as f32,
                        a as f32,
                    ]
                })
                .collect();
            (row, ctr)
        })
        .collect();

    let mut image = Image::new(w, h);
    image.pixels.clear();
    let mut ctr = walk::RayCounters::default();
    for (row, c) in rows {
        image.pixels.extend(row);
        ctr.add(&c);
    }
    let stats = ReferenceStats {
        rays: w as u64 * h as u64,
        rays_hit: ctr.rays_hit,
        mesh_entries: ctr.mesh_entries,
        origin_inside: ctr.origin_inside,
        boundary_hits: ctr.boundary_hits,
        tets_visited: ctr.tets_visited,
        zero_length_steps: ctr.zero_length_steps,
        walk_recoveries: ctr.walk_recoveries,
        walks_abandoned: ctr.walks_abandoned,
        quadrature_pieces: ctr.quad.pieces,
        quadrature_rules: ctr.quad.rules,
        quadrature_depth_limited: ctr.quad.depth_limited,
        boundary_faces: tracer.boundary_faces() as u64,
        tolerance: tol,
        build_time_s,
        time_s: start.elapsed().as_secs_f64(),
        threads: rayon::current_num_threads(),
    };
    (image, stats)
}
