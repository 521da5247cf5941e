//! Pre-classification of voxels for splatting: each sample's extinction
//! `tau(s) = -ln(1 - opacity(s)) / unit_distance` and colour `c(s)` from the
//! transfer function at its normalised scalar `s = (v - r0) / (r1 - r0)`.
//! Integer voxels go through a table over every possible value (256 or
//! 65,536 entries, f64 evaluation once per value); f32 voxels are evaluated
//! per voxel. A voxel with `tau = 0` is transparent and never drawn.

use crate::data::{Volume, Voxels};
use crate::scene::TransferFunction;

/// Extinction and colour of one sample.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Class {
    /// Extinction per world unit.
    pub tau: f32,
    /// Colour (not premultiplied).
    pub rgb: [f32; 3],
}

/// The classifier of one volume under one transfer function and range.
pub struct Classifier<'a> {
    volume: &'a Volume,
    tf: &'a TransferFunction,
    range: [f64; 2],
    /// Table by raw value (offset by 32,768 for i16); empty for f32.
    table: Vec<Class>,
    /// `table[v].tau > 0` by raw value (the culling test, one byte).
    vis: Vec<bool>,
}

fn class_of(tf: &TransferFunction, s: f64) -> Class {
    let (rgb, _) = tf.eval(s);
    Class {
        tau: tf.extinction(s) as f32,
        rgb: rgb.map(|c| c as f32),
    }
}

impl<'a> Classifier<'a> {
    /// Builds the table for integer voxel types.
    pub fn new(volume: &'a Volume, tf: &'a TransferFunction, range: [f64; 2]) -> Self {
        let norm = |v: f64| (v - range[0]) / (range[1] - range[0]);
        let table = match &volume.voxels {
            Voxels::U8(_) => (0..256).map(|v| class_of(tf, norm(v as f64))).collect(),
            Voxels::U16(_) => (0..65536).map(|v| class_of(tf, norm(v as f64))).collect(),
            Voxels::I16(_) => (0..65536)
                .map(|v| class_of(tf, norm(v as f64 - 32768.0)))
                .collect(),
            Voxels::F32(_) => Vec::new(),
        };
        let vis = table.iter().map(|c| c.tau > 0.0).collect();
        Classifier {
            volume,
            tf,
            range,
            table,
            vis,
        }
    }

    /// Class of voxel `idx`.
    #[inline(always)]
    pub fn get(&self, idx: u64) -> Class {
        let i = idx as usize;
        match &self.volume.voxels {
            Voxels::U8(v) => self.table[v[i] as usize],
            Voxels::U16(v) => self.table[v[i] as usize],
            Voxels::I16(v) => self.table[(v[i] as i32 + 32768) as usize],
            Voxels::F32(v) => class_of(
                self.tf,
                (v[i] as f64 - self.range[0]) / (self.range[1] - self.range[0]),
            ),
        }
    }

    /// True when voxel `idx` has non-zero extinction (is drawn).
    #[inline(always)]
    pub fn visible(&self, idx: u64) -> bool {
        let i = idx as usize;
        match &self.volume.voxels {
            Voxels::U8(v) => self.vis[v[i] as usize],
            Voxels::U16(v) => self.vis[v[i] as usize],
            Voxels::I16(v) => self.vis[(v[i] as i32 + 32768) as usize],
            Voxels::F32(_) => self.get(idx).tau > 0.0,
        }
    }
}
