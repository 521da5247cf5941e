//! The order in which cells are scan-converted.
//!
//! - `stored`: as in the file (the paper's setting).
//! - `front-to-back`: a rough visibility order, a bucket sort of the cells by
//!   their nearest depth (the paper's suggestion in §4.2). It makes most
//!   insertions land at the end of a pixel's list (cheap), lets partial
//!   composition merge earlier, and gives early ray termination the front
//!   segments first. Counting sort, O(n), stable (ties keep stored order), so
//!   the order is deterministic.

use super::project::ProjectedVertices;

/// How to order cells for scan conversion.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum CellOrder {
    /// The order of the data file.
    Stored,
    /// Bucket-sorted by nearest depth.
    FrontToBack,
}

impl std::fmt::Display for CellOrder {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            CellOrder::Stored => "stored",
            CellOrder::FrontToBack => "front-to-back",
        })
    }
}

/// Nearest depth of each vertex: screen depth (orthographic) or distance
/// from the eye (perspective).
fn vertex_depth(pv: &ProjectedVertices) -> Vec<f32> {
    if pv.perspective {
        pv.pos.iter().map(|p| (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt()).collect()
    } else {
        pv.pos.iter().map(|p| p[2]).collect()
    }
}

/// The cells in front-to-back order of their nearest vertex depth, bucketed
/// into about one bucket per four cells.
pub fn front_to_back(tets: &[[u32; 4]], pv: &ProjectedVertices) -> Vec<u32> {
    let depth = vertex_depth(pv);
    let near: Vec<f32> = tets.iter().map(|t| t.iter().map(|&v| depth[v as usize]).fold(f32::INFINITY, f32::min)).collect();
    let (lo, hi) = near.iter().filter(|z| z.is_finite()).fold((f32::INFINITY, f32::NEG_INFINITY), |(l, h), &z| (l.min(z), h.max(z)));
    let buckets = (tets.len() / 4).max(1);
    let scale = if hi > lo { (buckets - 1) as f32 / (hi - lo) } else { 0.0 };
    let key = |z: f32| if z.is_finite() { (((z - lo) * scale) as usize).min(buckets - 1) } else { buckets - 1 };
    let mut start = vec![0u32; buckets + 1];
    for &z in &near {
        start[key(z) + 1] += 1;
    }
    for b in 0..buckets {
        start[b + 1] += start[b];
    }
    let mut out = vec![0u32; tets.len()];
    for (c, &z) in near.iter().enumerate() {
        let k = key(z);
        out[start[k] as usize] = c as u32;
        start[k] += 1;
    }
    out
}
