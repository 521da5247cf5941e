//! What the two slicing renderers (`slice3d`, `slice2d`) share: the
//! classification mode, the transfer-function lookup table, the min–max
//! blocks for empty-space skipping, the texel access of each voxel type and
//! the statistics. The grid reference uses none of it.

pub mod blocks;
pub mod index;
pub mod lut;
pub mod texel;

pub use blocks::MinMaxBlocks;
pub use index::{clamp_fast, clamped_index};
pub use lut::{Lut, LUT_SIZE};
pub use texel::Texel;

/// When the transfer function is applied.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Classify {
    /// Interpolate the scalar, then look it up (the scene contract's field).
    Post,
    /// Look every voxel up into an RGBA8 texture (opacity-weighted colour,
    /// opacity), then interpolate RGBA: what the papers' hardware did.
    Pre,
    /// Post-classification of sample pairs (pre-integrated, `slice3d`
    /// only): the transfer function integrated over the scalar's linear run
    /// between consecutive samples (Engel et al. 2001). Better on label
    /// volumes with step transfer functions, worse where the field has
    /// sharp edges within a sample distance (docs/experiments/grids.md).
    Preint,
}

/// Compositing order of the slices.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Order {
    /// Front to back, `C += (1 - A) C_s`, `A += (1 - A) A_s`, with early ray
    /// termination once `A` reaches the threshold.
    FrontToBack,
    /// Back to front with blend factors `(1, 1 - A_s)`: `C = C_s + (1 - A_s) C`
    /// (the paper's OpenGL blending); no early termination possible.
    BackToFront,
}

/// Statistics of a slicing render (the grid keys of `--stats`).
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct SliceStats {
    /// Which renderer (`slice3d` or `slice2d`).
    pub renderer: &'static str,
    /// Voxels in the volume.
    pub voxels: u64,
    /// Slices (planes) placed across the volume.
    pub slices: u64,
    /// World distance between slices along the view direction (slice3d) or
    /// along the slicing axis (slice2d).
    pub slice_spacing: f64,
    /// Samples classified and composited.
    pub samples_taken: u64,
    /// Samples inside the volume not computed because their min–max block
    /// is transparent under the transfer function.
    pub samples_skipped_empty: u64,
    /// Samples inside the volume behind the early-termination depth.
    pub samples_skipped_ert: u64,
    /// Bytes of texture the frame used (slice3d: the 3D texture; slice2d:
    /// the slices actually sampled, at their level of detail).
    pub texture_bytes: u64,
    /// slice2d: the slicing axis (0 = x, 1 = y, 2 = z).
    pub slicing_axis: Option<usize>,
    /// slice2d: bytes of that axis's slices at full resolution (one stack).
    pub texture_bytes_full: Option<u64>,
    /// slice2d: bytes of the three stacks a 2D slicer keeps to switch axes
    /// without rebuilding (3 x the volume's bytes in the texture format).
    pub texture_bytes_three_stacks: Option<u64>,
    /// slice2d: the LOD distance D (None: LOD off).
    pub lod_d: Option<f64>,
    /// slice2d: number of slices used at level 0, 1, 2, ...
    pub slices_per_level: Option<Vec<u64>>,
    /// Min–max blocks (slice2d: tiles of all levels), and how many are
    /// transparent under the TF.
    pub blocks: u64,
    /// Of [`SliceStats::blocks`], transparent ones.
    pub blocks_empty: u64,
    /// Pixels whose ray met the volume box.
    pub pixels_covered: u64,
    /// Samples taken per covered pixel: with empty-space skipping and ERT
    /// the frame's cost follows what is visible, not the box.
    pub samples_per_pixel: f64,
    /// Classification mode.
    pub classify: Option<Classify>,
    /// Compositing order.
    pub order: Option<Order>,
    /// ERT threshold (1 = off).
    pub ert_threshold: f64,
    /// Bound on the light ERT drops per pixel: `(1 - threshold) x max radiance`.
    pub ert_error_bound: f64,
    /// Seconds to build what does not depend on the view (texture, blocks).
    pub time_prepare_s: f64,
    /// Seconds of the frame itself (classification tables, slicing, compositing).
    pub time_render_s: f64,
    /// Of [`SliceStats::time_render_s`], seconds to classify the min–max
    /// blocks against the transfer function and build the leap distances:
    /// all a transfer-function change costs besides the frame's lookup
    /// table (the blocks' ranges are not rebuilt).
    pub time_classify_s: f64,
    /// Rayon threads.
    pub threads: usize,
}

impl SliceStats {
    /// [`SliceStats::ert_error_bound`] of a slicing render: `(1 - threshold)
    /// x max radiance` when front-to-back compositing terminates early at
    /// `ert < 1`, else 0 (back to front never terminates).
    pub fn ert_bound(ert: f32, order: Order, tf: &crate::scene::TransferFunction) -> f64 {
        if ert < 1.0 && order == Order::FrontToBack {
            (1.0 - ert as f64) * tf.max_radiance()
        } else {
            0.0
        }
    }

    /// Adds the per-row counters of `o`.
    pub fn add_counts(&mut self, o: &SampleCounts) {
        self.samples_taken += o.taken;
        self.samples_skipped_empty += o.skipped_empty;
        self.samples_skipped_ert += o.skipped_ert;
        self.pixels_covered += o.covered;
        self.samples_per_pixel = self.samples_taken as f64 / self.pixels_covered.max(1) as f64;
    }
}

/// Per-thread sample counters.
#[derive(Debug, Clone, Copy, Default)]
pub struct SampleCounts {
    /// Samples taken.
    pub taken: u64,
    /// Samples skipped in empty blocks.
    pub skipped_empty: u64,
    /// Samples skipped behind ERT.
    pub skipped_ert: u64,
    /// Rays that met the box.
    pub covered: u64,
}

impl SampleCounts {
    /// Sum.
    pub fn merge(mut self, o: SampleCounts) -> SampleCounts {
        self.taken += o.taken;
        self.skipped_empty += o.skipped_empty;
        self.skipped_ert += o.skipped_ert;
        self.covered += o.covered;
        self
    }
}

/// Opacity correction: an opacity `o` given per `unit_distance` becomes
/// `alpha = 1 - (1 - o)^(delta / unit_distance)` over a sample distance `delta`.
#[inline]
pub fn correct_opacity(o: f32, k: f32) -> f32 {
    let o = o.min(crate::scene::transfer::OPACITY_MAX as f32);
    1.0 - (1.0 - o).powf(k)
}
