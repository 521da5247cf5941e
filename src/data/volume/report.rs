//! What `pvrsim info` says about a volume.

use std::fmt;

use serde::Serialize;

use super::Volume;

/// A volume's summary: dims, type, placement, value range, memory, zeros.
#[derive(Debug, Clone, Serialize)]
pub struct VolumeReport {
    /// Samples per axis.
    pub dims: [u64; 3],
    /// Stored voxel type (`u8`, `u16`, `i16`, `f32`).
    pub voxel_type: String,
    /// Scalar name.
    pub field: String,
    /// World spacing.
    pub spacing: [f64; 3],
    /// World position of sample (0, 0, 0).
    pub origin: [f64; 3],
    /// World box of the samples (min corner).
    pub bounds_min: [f64; 3],
    /// World box of the samples (max corner).
    pub bounds_max: [f64; 3],
    /// Smallest and largest sample.
    pub value_range: [f64; 2],
    /// Total samples.
    pub voxels: u64,
    /// Bytes the samples occupy in memory.
    pub memory_bytes: u64,
    /// Fraction of samples equal to 0.
    pub zero_fraction: f64,
}

impl VolumeReport {
    /// Computes the report (one pass over the samples for the range, one
    /// for the zeros).
    pub fn compute(v: &Volume) -> VolumeReport {
        let (lo, hi) = v.bounds();
        let n = v.len();
        let zeros = (0..n).filter(|&i| v.voxels.get_f32(i) == 0.0).count() as u64;
        VolumeReport {
            dims: v.dims,
            voxel_type: v.voxels.voxel_type().name().into(),
            field: v.field.clone(),
            spacing: v.spacing,
            origin: v.origin,
            bounds_min: lo,
            bounds_max: hi,
            value_range: v.value_range(),
            voxels: n,
            memory_bytes: v.voxels.bytes(),
            zero_fraction: zeros as f64 / n as f64,
        }
    }
}

impl fmt::Display for VolumeReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let v3 = |a: [f64; 3]| format!("({}, {}, {})", a[0], a[1], a[2]);
        writeln!(
            f,
            "regular grid: {} x {} x {} = {} voxels of {} (field \"{}\")",
            self.dims[0], self.dims[1], self.dims[2], self.voxels, self.voxel_type, self.field
        )?;
        writeln!(f, "spacing:      {}", v3(self.spacing))?;
        writeln!(f, "origin:       {}", v3(self.origin))?;
        writeln!(
            f,
            "world bounds: {} .. {}",
            v3(self.bounds_min),
            v3(self.bounds_max)
        )?;
        writeln!(
            f,
            "value range:  [{}, {}]",
            self.value_range[0], self.value_range[1]
        )?;
        writeln!(
            f,
            "memory:       {} bytes ({:.1} MiB)",
            self.memory_bytes,
            self.memory_bytes as f64 / (1u64 << 20) as f64
        )?;
        writeln!(f, "zero voxels:  {:.1} %", 100.0 * self.zero_fraction)
    }
}
