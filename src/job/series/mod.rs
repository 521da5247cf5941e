//! The frames of a series: its options ([`args`]: `--frames`, `--turn`,
//! `--series`, `--resume`), its steps (camera, transfer function, data
//! state per frame, [`steps`]) and each frame's files, written as it
//! completes ([`output`]).

pub mod args;
pub mod output;
pub mod steps;
