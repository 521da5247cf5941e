//! The order in which cells are scan-converted.
//!
//! - `stored`: as in the file (the paper's setting).
//! - `front-to-back`: each tile's cells sorted by nearest depth (ties by cell
//!   id), a visibility order good enough for the paper's purpose (§4.2 suggests
//!   a bucket sort by nearest z). Most insertions then land at the end of a
//!   pixel's list (cheap), partial composition merges earlier, and early ray
//!   termination sees the front segments first. Sorting per tile keeps the
//!   order of any two cells the same in every tile, so the image is still
//!   independent of the tiling.

/// How to order cells for scan conversion.
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize, clap::ValueEnum,
)]
#[serde(rename_all = "kebab-case")]
pub enum CellOrder {
    /// The order of the data file.
    Stored,
    /// Sorted by nearest depth.
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
