//! Early ray termination (ERT) for the cell-projection renderer: the paper's
//! Conservative Subscreen Termination (§3.1) and a tighter max-pyramid.
//!
//! Per screen tile (the unit a thread renders), scan conversion is cut into
//! batches by the update schedule ([`schedule`]). Before each batch the
//! per-pixel termination depths of the pixels whose lists changed are
//! recomputed ([`termination`]) and the tile's structure — a flat table
//! ([`table`]) or a pyramid ([`pyramid`]) — is rebuilt where they changed;
//! then every cell of the batch is tested against it and scan-converted only
//! if it may still be visible. [`oracle`] measures how many cells a perfect
//! per-pixel test with the final termination depths would skip.
//!
//! A pixel's cached termination depth only ever decreases (`min` over the
//! rebuilds): a depth that was valid once stays valid, since segments are
//! only ever added. This avoids the paper's "temporarily deeper `deepest`"
//! effect (footnote of §4.2.2), where a merge by partial composition extends
//! the crossing segment's `z_back`.
//!
//! See `docs/ert.md` for the design and the error bound.

pub mod oracle;
pub mod pyramid;
pub mod schedule;
pub mod table;
pub mod termination;
pub mod tile;

pub use termination::{error_bound, termination_depth};
pub use tile::{scan_tile_ert, ErtTileStats};

/// Which structure holds the termination information.
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize, clap::ValueEnum,
)]
#[serde(rename_all = "kebab-case")]
pub enum ErtStructure {
    /// The paper's D x D table of subscreens (`terminated`, `deepest`).
    Flat,
    /// A max-pyramid over per-pixel (or per-block) depths; cells tested on at most 2 x 2 entries.
    Pyramid,
}

/// Which cells the flat table tests.
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize, clap::ValueEnum,
)]
#[serde(rename_all = "kebab-case")]
pub enum ErtSpan {
    /// Only cells whose pixel range lies inside one entry (the paper).
    Single,
    /// Any cell: all the entries it covers must be terminated in front of it.
    Multi,
}

/// Size of a table entry (or of a pyramid's level-0 block).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EntrySize {
    /// The image cut into `D x D` entries: `ceil(W / D) x ceil(H / D)` pixels each.
    Divisions(u32),
    /// Square entries of `N x N` pixels.
    Pixels(u32),
}

/// What an ERT threshold means, decided once where the threshold is
/// parsed (`--ert`, a scene, the viewer's page, a worker's set-up): the
/// renderers ask the mode, never the raw number, whether ERT runs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ErtMode {
    /// Threshold 1: no test, no update.
    Off,
    /// A pixel terminates where the alpha in front reaches the threshold
    /// (in (0, 1)).
    On(f32),
}

impl ErtMode {
    /// The mode of a threshold already checked to be in (0, 1]: below 1
    /// on, 1 (or more) off. The one place that says what 1 means.
    pub fn of_threshold(threshold: f32) -> ErtMode {
        if threshold < 1.0 {
            ErtMode::On(threshold)
        } else {
            ErtMode::Off
        }
    }

    /// Whether ERT runs.
    pub fn is_on(self) -> bool {
        matches!(self, ErtMode::On(_))
    }

    /// The threshold (1 when off).
    pub fn threshold(self) -> f32 {
        match self {
            ErtMode::On(t) => t,
            ErtMode::Off => 1.0,
        }
    }
}

/// Options of early ray termination.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ErtOptions {
    /// On with its threshold, or off.
    pub mode: ErtMode,
    /// Entry size; `None`: `D = 20` for the flat table, 1 pixel for the pyramid.
    pub entry: Option<EntrySize>,
    /// Update constant `C`: rebuild after every `remaining / C` cells.
    pub update_c: u32,
    /// Flat table: which cells are tested.
    pub span: ErtSpan,
    /// Flat table or pyramid.
    pub structure: ErtStructure,
    /// Back off where ERT cannot skip (no test while no pixel of the tile has
    /// terminated in front of a cell; see [`tile::scan_tile_ert`]). Skip
    /// decisions, hence images, are the same either way; `false` is kept to
    /// test exactly that.
    pub backoff: bool,
}

impl ErtOptions {
    /// ERT off.
    pub const OFF: ErtOptions = ErtOptions {
        mode: ErtMode::Off,
        ..ErtOptions::DEFAULT
    };

    /// The defaults: threshold 0.99 (scene.md), pyramid over pixels, `C = 100`.
    pub const DEFAULT: ErtOptions = ErtOptions {
        mode: ErtMode::On(0.99),
        entry: None,
        update_c: 100,
        span: ErtSpan::Multi,
        structure: ErtStructure::Pyramid,
        backoff: true,
    };

    /// Whether ERT runs at all.
    pub fn enabled(&self) -> bool {
        self.mode.is_on()
    }

    /// The threshold (1 when off).
    pub fn threshold(&self) -> f32 {
        self.mode.threshold()
    }

    /// Entry (or level-0 block) width and height in pixels for a `width x height` image.
    pub fn entry_px(&self, width: u32, height: u32) -> (u32, u32) {
        let default = match self.structure {
            ErtStructure::Flat => EntrySize::Divisions(20),
            ErtStructure::Pyramid => EntrySize::Pixels(1),
        };
        match self.entry.unwrap_or(default) {
            EntrySize::Divisions(d) => (
                width.div_ceil(d.max(1)).max(1),
                height.div_ceil(d.max(1)).max(1),
            ),
            EntrySize::Pixels(n) => (n.max(1), n.max(1)),
        }
    }

    /// Tile size when ERT is on: the requested edge `tile` rounded to the
    /// nearest multiple of the entry size along each axis (at least one
    /// entry), so that no entry straddles two tiles.
    pub fn tile_dims(&self, tile: u32, width: u32, height: u32) -> (u32, u32) {
        let (ex, ey) = self.entry_px(width, height);
        let k = |e: u32| ((tile as f64 / e as f64).round() as u32).max(1) * e;
        (k(ex), k(ey))
    }
}

impl Default for ErtOptions {
    fn default() -> Self {
        ErtOptions::DEFAULT
    }
}

impl std::fmt::Display for ErtStructure {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            ErtStructure::Flat => "flat",
            ErtStructure::Pyramid => "pyramid",
        })
    }
}

impl std::fmt::Display for ErtSpan {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            ErtSpan::Single => "single",
            ErtSpan::Multi => "multi",
        })
    }
}

/// Adds what ERT did in `frame` to `stats` (cells skipped, update and test
/// times, the error bound) and takes ERT's own time out of `time_scan_s`.
pub fn fill_stats(
    stats: &mut super::CellStats,
    frame: &super::Frame,
    opts: &super::CellOptions,
    tf: &crate::scene::TransferFunction,
    background: [f64; 3],
) {
    let e = &opts.ert;
    stats.ert_structure = e.structure.to_string();
    stats.ert_span = if e.structure == ErtStructure::Flat {
        e.span.to_string()
    } else {
        String::new()
    };
    stats.ert_entry_px = [frame.entry_px.0, frame.entry_px.1];
    stats.ert_update_c = e.update_c;
    stats.ert_error_bound = error_bound(stats.ert_threshold, tf.max_radiance(), background);
    let mut spanning: Vec<(u32, u32)> = Vec::new();
    for t in &frame.ert {
        stats.ert_updates += t.updates;
        stats.ert_update_s += t.update_s;
        stats.ert_tests += t.tests;
        stats.ert_tests_s += t.tests_s;
        stats.cells_skipped_ert += t.skipped_whole;
        stats.cell_tile_pairs_skipped_ert += t.skipped_whole + t.skipped_spanning.len() as u64;
        spanning.extend_from_slice(&t.skipped_spanning);
    }
    stats.cells_skipped_ert += cells_skipped_everywhere(&mut spanning);
    let overhead = (stats.ert_update_s + stats.ert_tests_s) / stats.threads.max(1) as f64;
    stats.time_scan_s = (stats.time_scan_phase_s - overhead).max(0.0);
    stats.ert_overhead_share = if stats.time_scan_s > 0.0 {
        overhead / stats.time_scan_s
    } else {
        0.0
    };
}

/// Given (cell, tiles it touches) once per tile that skipped it, the number of
/// cells skipped in all the tiles they touch.
pub fn cells_skipped_everywhere(pairs: &mut [(u32, u32)]) -> u64 {
    pairs.sort_unstable();
    pairs
        .chunk_by(|a, b| a.0 == b.0)
        .filter(|g| g.len() as u32 == g[0].1)
        .count() as u64
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn entries_and_tiles_align() {
        let flat = ErtOptions {
            structure: ErtStructure::Flat,
            ..ErtOptions::DEFAULT
        };
        assert_eq!(flat.entry_px(300, 300), (15, 15));
        assert_eq!(flat.entry_px(900, 300), (45, 15));
        assert_eq!(flat.tile_dims(32, 300, 300), (30, 30));
        assert_eq!(flat.tile_dims(32, 900, 300), (45, 30));
        assert_eq!(ErtOptions::DEFAULT.entry_px(300, 300), (1, 1));
        assert_eq!(ErtOptions::DEFAULT.tile_dims(32, 300, 300), (32, 32));
        let px = ErtOptions {
            entry: Some(EntrySize::Pixels(8)),
            ..flat
        };
        assert_eq!(px.tile_dims(32, 900, 300), (32, 32));
        assert!(!ErtOptions::OFF.enabled() && ErtOptions::DEFAULT.enabled());
    }
}
