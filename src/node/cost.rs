//! The compute-time cost model: operation counts ([`OpCounts`]) times unit
//! costs ([`CostProfile`], seconds per operation) gives the simulated compute
//! time of a node, the input of the cluster's virtual clock:
//!
//! `t = Σ_k count_k · cost_k`
//!
//! The model is linear on purpose: every counter is an amount of work of one
//! kind whose time does not depend on the others to first order (cache
//! effects are folded into the unit costs of the machine they were measured
//! on). Where counts are always proportional (every generated segment is
//! integrated and inserted once) one unit cost covers both.
//!
//! Profiles come from two places (see `docs/cost-model.md`):
//!
//! - `pvrsim calibrate`: unit costs measured on this machine by timing the
//!   node renderer's steps and updates and fitting by non-negative least
//!   squares ([`super::lsq`]); written to `configs/profiles/calibrated.toml`.
//! - `pentium4` ([`CostProfile::named`]): the calibrated profile scaled, cell
//!   costs and pixel costs separately, so that the paper's sequential
//!   Table 1 times are reproduced from our operation counts on `aorta.vtk`.

use std::path::Path;

use serde::{Deserialize, Serialize};

use super::ops::OpCounts;

/// Seconds per operation, one per [`OpCounts`] counter (defaults 0).
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CostProfile {
    /// Per vertex transformed to screen space.
    pub per_vertex_project: f64,
    /// Per cell received (record built or culled); also per leaf keyed for
    /// a global schedule (`OpCounts::units_keyed`).
    pub per_cell_receive: f64,
    /// Per cell tested against the ERT table.
    pub per_cell_test: f64,
    /// Per cell scan-converted: face set-up and pixel-range set-up.
    pub per_cell_setup: f64,
    /// Per pixel centre tested against a cell.
    pub per_pixel_test: f64,
    /// Per ray segment generated: integration and insertion into its list.
    pub per_segment: f64,
    /// Per merge by partial composition.
    pub per_merge: f64,
    /// Per piece the exact integrator integrates of a segment that crosses
    /// transfer-function control points (`segment_pieces`; measured
    /// directly by `pvrsim calibrate`).
    pub per_segment_piece: f64,
    /// ERT update: per pixel list walked.
    pub per_list_walked: f64,
    /// ERT update: per list entry visited.
    pub per_list_entry_walked: f64,
    /// ERT update: per table entry recomputed.
    pub per_table_entry: f64,
    /// ERT update: per pixel depth read while recomputing entries.
    pub per_table_pixel: f64,
    /// Per shared-table entry merged.
    pub per_shared_entry: f64,
    /// Per cell packed into or unpacked from a work unit.
    pub per_work_cell: f64,
    /// Phase 2: per ray segment a node encodes into a message of lists
    /// (measured by `pvrsim calibrate` on a binary swap; 0: not charged).
    pub per_segment_sent: f64,
    /// Phase 2: per ray segment a node receives in lists, decoded and
    /// merged into its own (0: `per_segment`, an insertion, is charged).
    pub per_segment_received: f64,
    /// Grid nodes without a device model: per trilinear sample taken by the
    /// software slicer (fetch, classify, blend).
    pub per_sample: f64,
    /// Device model (grid nodes): texture memory, bytes; bricks beyond it
    /// are uploaded again every frame. 0: not modelled (all resident).
    pub texture_bytes: f64,
    /// Device model: fill rate, fragments (slice samples) per second. 0: no
    /// device, the software slicer's `per_sample` is charged instead.
    pub fill_rate: f64,
    /// Device model: host-to-device bus bandwidth for texture uploads,
    /// bytes per second. 0: uploads not charged.
    pub upload_bytes_per_s: f64,
    /// Device model: framebuffer read-back bandwidth (the subimage), bytes
    /// per second. 0: not charged.
    pub readback_bytes_per_s: f64,
    /// Device model: bytes a voxel occupies as a texture (4 for the RGBA8
    /// textures of the grid paper). 0: the renderer's own bytes (the
    /// scalar's size, or 4 with pre-classification).
    pub texel_bytes: f64,
    /// Device model: host memory for the textures' system-memory copies,
    /// bytes. When a node's textures exceed it, the textures that are not
    /// resident on the device page in from disk every frame. 0: unlimited.
    pub host_bytes: f64,
    /// Device model: bytes per second of paging from disk (with
    /// `host_bytes`).
    pub disk_bytes_per_s: f64,
    /// Device model: seconds of host-side set-up per texture drawn per
    /// frame (texture bind, state and draw call: one per brick with
    /// `slice3d`, one per block with adaptive sampling, whose blocks are
    /// separate textures). 0: not charged.
    pub per_texture_draw: f64,
    /// Per cell id written into or read from an id unit (replicated data);
    /// 0 = not measured for this profile: [`CostProfile::cell_id_cost`]
    /// then derives it from `per_work_cell`.
    pub per_cell_id: f64,
    /// Splatting (`pvrsim splat`, one thread): per voxel of the grid
    /// (`SplatStats::voxels_total`: classification and the transparency
    /// pre-pass visit every voxel). 0: not charged.
    pub per_splat_voxel: f64,
    /// Splatting: per footprint drawn (`SplatStats::voxels_drawn`: ordering,
    /// projection, binning of a kept, on-screen voxel). 0: not charged.
    pub per_splat: f64,
    /// Splatting: per (splat, band) piece rasterised and composited
    /// (`SplatStats::pieces` less `pieces_skipped_ert`). 0: not charged.
    pub per_splat_piece: f64,
    /// Splatting: per image pixel (`SplatStats::pixels`: the accumulation
    /// buffer cleared, the background composited). 0: not charged.
    pub per_splat_pixel: f64,
}

/// A profile file: a name, notes, and the unit costs.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ProfileFile {
    /// Profile name.
    pub name: String,
    /// How it was obtained.
    #[serde(default)]
    pub description: String,
    /// Unit costs, seconds per operation.
    pub costs: CostProfile,
}

/// The compute time of `ops` under profile `p`, seconds.
pub fn compute_time(ops: &OpCounts, p: &CostProfile) -> f64 {
    let b = breakdown(ops, p);
    b.receive + b.ert_test + b.scan + b.ert_update + b.share + b.work
}

/// [`compute_time`] split by phase.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct Breakdown {
    /// Receiving cells: vertex transform and records.
    pub receive: f64,
    /// ERT cell tests.
    pub ert_test: f64,
    /// Scan conversion proper: set-up, pixel tests, segments, merges (the paper's Tsc without ERT's own work).
    pub scan: f64,
    /// ERT table updates.
    pub ert_update: f64,
    /// Merging shared tables.
    pub share: f64,
    /// Packing and unpacking work units.
    pub work: f64,
}

/// [`compute_time`] by phase.
pub fn breakdown(o: &OpCounts, p: &CostProfile) -> Breakdown {
    let f = |n: u64, c: f64| n as f64 * c;
    Breakdown {
        receive: f(o.vertices_projected, p.per_vertex_project)
            + f(o.cells_received + o.units_keyed, p.per_cell_receive),
        ert_test: f(o.cells_tested + o.cells_reordered, p.per_cell_test),
        scan: f(o.cells_projected, p.per_cell_setup)
            + f(o.pixels_tested, p.per_pixel_test)
            + f(o.segments_generated, p.per_segment)
            + f(o.segments_merged, p.per_merge)
            + f(o.segment_pieces, p.per_segment_piece),
        ert_update: f(o.lists_walked, p.per_list_walked)
            + f(o.list_entries_walked, p.per_list_entry_walked)
            + f(o.table_entries_updated, p.per_table_entry)
            + f(o.table_pixels_read, p.per_table_pixel),
        share: f(o.shared_entries_merged, p.per_shared_entry),
        work: f(o.work_cells_moved, p.per_work_cell) + f(o.cell_ids_moved, p.cell_id_cost()),
    }
}

/// The `radeon9700` profile file (device model), built in.
pub const RADEON9700_TOML: &str = include_str!("../../configs/profiles/radeon9700.toml");

/// The `pentium4` profile file, built in.
pub const PENTIUM4_TOML: &str = include_str!("../../configs/profiles/pentium4.toml");

impl CostProfile {
    /// The modelled one-thread time of a splatting frame with `st`'s
    /// counts, seconds: `voxels_total · per_splat_voxel + voxels_drawn ·
    /// per_splat + (pieces - pieces_skipped_ert) · per_splat_piece + pixels
    /// · per_splat_pixel`.
    pub fn splat_time(&self, st: &crate::render::splat::SplatStats) -> f64 {
        st.voxels_total as f64 * self.per_splat_voxel
            + st.voxels_drawn as f64 * self.per_splat
            + st.pieces.saturating_sub(st.pieces_skipped_ert) as f64 * self.per_splat_piece
            + st.pixels as f64 * self.per_splat_pixel
    }

    /// Every cost multiplied by `k`.
    pub fn scaled(&self, k: f64) -> CostProfile {
        self.scaled_split(k, k)
    }

    /// Per-cell costs (vertex transform, receive, test, set-up, work
    /// packing) multiplied by `k_cell`, all others (per pixel, segment,
    /// merge, ERT update, sharing) by `k_pixel`.
    pub fn scaled_split(&self, k_cell: f64, k_pixel: f64) -> CostProfile {
        CostProfile {
            per_vertex_project: self.per_vertex_project * k_cell,
            per_cell_receive: self.per_cell_receive * k_cell,
            per_cell_test: self.per_cell_test * k_cell,
            per_cell_setup: self.per_cell_setup * k_cell,
            per_work_cell: self.per_work_cell * k_cell,
            per_cell_id: self.per_cell_id * k_cell,
            per_pixel_test: self.per_pixel_test * k_pixel,
            per_segment: self.per_segment * k_pixel,
            per_merge: self.per_merge * k_pixel,
            per_list_walked: self.per_list_walked * k_pixel,
            per_list_entry_walked: self.per_list_entry_walked * k_pixel,
            per_table_entry: self.per_table_entry * k_pixel,
            per_table_pixel: self.per_table_pixel * k_pixel,
            per_shared_entry: self.per_shared_entry * k_pixel,
            per_sample: self.per_sample * k_pixel,
            ..*self
        }
    }

    /// Seconds per cell id moved with replicated data: `per_cell_id` if
    /// set, else `per_work_cell` × [`super::replica::ID_COST_RATIO`] (the
    /// measured ratio of the two operations): never zero while moving a
    /// cell costs anything.
    pub fn cell_id_cost(&self) -> f64 {
        if self.per_cell_id > 0.0 {
            self.per_cell_id
        } else {
            self.per_work_cell * super::replica::ID_COST_RATIO
        }
    }

    /// Parses a profile file's text.
    pub fn parse(text: &str) -> anyhow::Result<ProfileFile> {
        let f: ProfileFile = toml::from_str(text)?;
        let c = f.costs;
        let all = [
            c.per_vertex_project,
            c.per_cell_receive,
            c.per_cell_test,
            c.per_cell_setup,
            c.per_pixel_test,
            c.per_segment,
            c.per_merge,
            c.per_list_walked,
            c.per_list_entry_walked,
            c.per_table_entry,
            c.per_table_pixel,
            c.per_shared_entry,
            c.per_work_cell,
            c.per_sample,
            c.texture_bytes,
            c.fill_rate,
            c.upload_bytes_per_s,
            c.readback_bytes_per_s,
            c.per_cell_id,
            c.per_splat_voxel,
            c.per_splat,
            c.per_splat_piece,
            c.per_splat_pixel,
        ];
        anyhow::ensure!(
            all.iter().all(|v| v.is_finite() && *v >= 0.0),
            "profile {}: unit costs must be finite and non-negative",
            f.name
        );
        Ok(f)
    }

    /// Reads a profile file.
    pub fn load(path: &Path) -> anyhow::Result<ProfileFile> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| anyhow::anyhow!("reading {}: {e}", path.display()))?;
        CostProfile::parse(&text).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))
    }

    /// A built-in profile by name: `pentium4`, `radeon9700`.
    pub fn named(name: &str) -> anyhow::Result<CostProfile> {
        match name {
            "pentium4" => Ok(CostProfile::parse(PENTIUM4_TOML)?.costs),
            "radeon9700" => Ok(CostProfile::parse(RADEON9700_TOML)?.costs),
            _ => anyhow::bail!("unknown profile {name:?} (built in: pentium4, radeon9700)"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn time_is_the_dot_product() {
        let ops = OpCounts {
            cells_projected: 10,
            pixels_tested: 100,
            segments_generated: 50,
            segments_merged: 20,
            list_entries_walked: 7,
            work_cells_moved: 3,
            ..Default::default()
        };
        let p = CostProfile {
            per_cell_setup: 1e-6,
            per_pixel_test: 1e-8,
            per_segment: 1e-7,
            per_merge: 2e-8,
            per_list_entry_walked: 1e-9,
            per_work_cell: 1e-6,
            ..Default::default()
        };
        let want = 10e-6 + 100e-8 + 50e-7 + 20.0 * 2e-8 + 7e-9 + 3e-6;
        assert!((compute_time(&ops, &p) - want).abs() < 1e-18);
        let b = breakdown(&ops, &p);
        assert!((b.scan - (10e-6 + 100e-8 + 50e-7 + 40e-8)).abs() < 1e-18);
        assert!((compute_time(&ops, &p.scaled(3.0)) - 3.0 * want).abs() < 1e-15);
        let s = p.scaled_split(2.0, 1.0);
        assert_eq!(s.per_cell_setup, 2e-6);
        assert_eq!(s.per_pixel_test, 1e-8);
    }

    #[test]
    fn pentium4_loads_and_rejects_negative_costs() {
        let p = CostProfile::named("pentium4").unwrap();
        assert!(p.per_cell_setup > 0.0 && p.per_pixel_test >= 0.0);
        assert!(CostProfile::named("cray").is_err());
        let bad = "name = \"x\"\n[costs]\nper_pixel_test = -1.0\n";
        assert!(CostProfile::parse(bad).is_err());
        let unknown = "name = \"x\"\n[costs]\nper_pixel = 1.0\n";
        assert!(CostProfile::parse(unknown).is_err());
    }
}
