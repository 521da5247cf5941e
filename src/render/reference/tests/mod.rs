//! Analytic tests of the reference renderer: meshes built in code, expected
//! pixels from closed forms or from an independent 1D integration.
//!
//! Files: `support.rs` the shared helpers (scenes, meshes, the 1D
//! integral), `analytic.rs` images against exact answers, `edge_cases.rs`
//! degenerate input and invariants.

mod analytic;
mod edge_cases;
mod support;
