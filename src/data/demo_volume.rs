//! The demo's regular grid: the hydrogen atom ([`hydrogen`]) at 64^3 (256 KiB
//! of u8, generated in milliseconds) and its scene, written beside the mesh
//! demo so that the grid renderers have a dataset that needs no download.

use crate::data::volume::generate::hydrogen;
use crate::data::volume::scene::hydrogen_scene;
use crate::data::Volume;

/// Samples per axis of the demo volume.
pub const DEMO_VOLUME_SIZE: u64 = 64;

/// The demo volume and its scene text, the scene naming `data_file_name`.
pub fn demo_volume_and_scene(data_file_name: &str) -> (Volume, String) {
    let v = hydrogen(DEMO_VOLUME_SIZE);
    let s = hydrogen_scene(data_file_name, &v);
    (v, s)
}
