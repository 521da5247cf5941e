//! The sweep config file (TOML, see docs/sweeps.md): [`RawConfig`] as
//! written, validated into a [`Plan`]. Every error names the file and the key.
//!
//! Files: `raw.rs` the file's tables as written (serde), `plan.rs` their
//! validation into a [`Plan`] and the plan's queries.

mod plan;
mod raw;
#[cfg(test)]
mod tests;

pub use plan::{canonical, Make, Plan, PlotKind, PlotSpec, LEGEND_POSITIONS, RESERVED};
pub use raw::{OneOrMany, RawConfig, RawPlot, RawSummary};
