//! # pvrsim
//!
//! Cell-projection parallel volume rendering of tetrahedral meshes with early
//! ray termination, and a simulator of the PC cluster that runs it.
//!
//! Module dependencies flow one way: `cli -> render -> {scene, data, image}`,
//! `compositor -> {render::cell segments, image}`.
#![warn(missing_docs)]

pub mod budget;
pub mod cli;
pub mod cluster;
pub mod compositor;
pub mod data;
pub mod error;
pub mod experiment;
pub mod image;
pub mod manager;
pub mod net;
pub mod node;
pub mod render;
pub mod scene;

pub use error::{Error, Result};
