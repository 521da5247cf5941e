//! Option groups that several commands share, declared once: the
//! transport ([`transport`]), the grid renderers ([`grid`]), `--ert`
//! ([`shared`]); options by flag name ([`by_name`]). These only parse and
//! check: nothing here spawns, loads or runs.

pub mod by_name;
pub mod grid;
pub mod shared;
pub mod transport;
