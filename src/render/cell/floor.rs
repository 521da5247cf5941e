//! The floor estimate `pvrsim bench` prints beside its timings: what a ray
//! segment costs at least on this machine, measured by a kernel that does
//! per segment only what every exact renderer must do, and no geometry:
//!
//! - read the segment's inputs (entry/exit depth and scalar, 16 bytes),
//!   streamed from a buffer larger than the last-level cache;
//! - read one vertex record (16 bytes) at a pseudo-random place of an
//!   array the size of the frame's vertex data (62k vertices: L2/L3);
//! - evaluate one `exp`;
//! - read, composite into and write back the pixel's accumulator (16 bytes)
//!   at a pseudo-random pixel of a 32x32 tile.
//!
//! `segments x ns_per_segment()` is then a lower bound in the sense of "no
//! renderer doing this work per segment on this machine is faster", not a
//! target a real frame (projection, set-up, binning) can reach.

use std::time::Instant;

use super::fastmath::exp_neg;

/// Segments the kernel streams per run (64 MB of inputs).
const SEGMENTS: usize = 1 << 22;
/// Vertex records gathered from (the aorta's 61,951 vertices, rounded up).
const VERTICES: usize = 1 << 16;
/// Pixels of a 32x32 tile.
const PIXELS: usize = 1024;

/// Measured nanoseconds per segment of the floor kernel on one thread (the
/// fastest of three runs; takes about 0.1 s).
pub fn ns_per_segment() -> f64 {
    let input: Vec<[f32; 4]> = (0..SEGMENTS)
        .map(|i| {
            let f = (i % 977) as f32;
            [f * 0.01, f * 0.01 + 0.5, 0.1 + f * 1e-4, 0.2 + f * 1e-4]
        })
        .collect();
    let verts: Vec<[f32; 4]> = (0..VERTICES).map(|i| [i as f32, 1.0, 2.0, 0.5]).collect();
    let mut acc = vec![[0.0f32; 4]; PIXELS];
    let mut best = f64::INFINITY;
    let mut sink = 0.0f32;
    for _ in 0..3 {
        acc.iter_mut().for_each(|a| *a = [0.0; 4]);
        let t0 = Instant::now();
        let mut h: u32 = 0x9e37_79b9;
        for s in &input {
            // xorshift: the pixel and the vertex, unpredictable to the prefetcher.
            h ^= h << 13;
            h ^= h >> 17;
            h ^= h << 5;
            let v = &verts[(h >> 16) as usize % VERTICES];
            let p = &mut acc[h as usize % PIXELS];
            let a = 1.0 - exp_neg(-(s[1] - s[0]) * (s[2] + s[3]) * v[3]);
            let t = 1.0 - p[3];
            p[0] += t * a * v[1];
            p[1] += t * a * v[2];
            p[2] += t * a * s[2];
            p[3] += t * a;
        }
        best = best.min(t0.elapsed().as_secs_f64());
        sink += acc.iter().map(|a| a[3]).sum::<f32>();
    }
    std::hint::black_box(sink);
    best * 1e9 / SEGMENTS as f64
}

#[cfg(test)]
mod tests {
    #[test]
    fn floor_kernel_runs() {
        let ns = super::ns_per_segment();
        assert!(ns.is_finite() && ns > 0.0);
    }
}
