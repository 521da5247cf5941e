//! Memory a frame needs (the bytes helpers, `MemAvailable` and
//! [`crate::budget::human`], are the budget's), checked before anything is allocated, so that a
//! huge `--width`/`--height` (or a huge cluster) is refused with a message
//! instead of aborting the process on a failed allocation.
//!
//! The estimate is a **lower bound**: it counts the buffers whose size is
//! fixed by the image size and the node count, not the segments (which
//! depend on the data):
//!
//! ```text
//! cell render:  W·H · (16 image + 16 tile blocks + 3 PNG)            bytes
//!               + threads · tile² · 25 (per-pixel list heads + change flags)
//!   --compare:  + W·H · (16 reference + 16 difference + 3·16 strip)
//! cluster:      W·H · (16 + 3) + N · W·H · (24 list head + 1 change flag)
//!               + W·H · 24 (the canonical lists of phase 2, at least one head per pixel)
//! ```
//!
//! It is compared with `MemAvailable` from `/proc/meminfo` (when readable).

/// Bytes of one list head (`Vec<Segment>`) per pixel.
const LIST_HEAD: u64 = 24;
/// Bytes of one RGBA f32 pixel.
const PIXEL: u64 = 16;

/// What is rendered, for [`frame_bytes`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FrameKind {
    /// `pvrsim render` (cell projection or reference), with `compare`.
    Render {
        /// Screen tile edge (pixels).
        tile: u32,
        /// Worker threads.
        threads: usize,
        /// Also the reference, difference and strip images.
        compare: bool,
    },
    /// `pvrsim cluster` with this many nodes (each holds full-screen lists).
    Cluster {
        /// Nodes.
        nodes: usize,
    },
}

/// Lower bound on the bytes a `width x height` frame needs (see the module doc).
pub fn frame_bytes(width: u32, height: u32, kind: FrameKind) -> u64 {
    let px = width as u64 * height as u64;
    match kind {
        FrameKind::Render {
            tile,
            threads,
            compare,
        } => {
            let t = tile.max(1) as u64;
            let tile_px = (t * t).min(px);
            let mut b = px * (2 * PIXEL + 3) + threads.max(1) as u64 * tile_px * (LIST_HEAD + 1);
            if compare {
                b += px * (2 * PIXEL + 3 * PIXEL);
            }
            b
        }
        FrameKind::Cluster { nodes } => {
            px * (PIXEL + 3) + nodes as u64 * px * (LIST_HEAD + 1) + px * LIST_HEAD
        }
    }
}

/// Refuses a frame whose lower-bound size exceeds `available` bytes.
pub fn check_fits(
    width: u32,
    height: u32,
    kind: FrameKind,
    available: Option<u64>,
) -> anyhow::Result<()> {
    let need = frame_bytes(width, height, kind);
    if let Some(avail) = available {
        anyhow::ensure!(
            need <= avail,
            "a {width}x{height} frame needs at least {} of memory (image buffers and per-pixel lists{}), but this machine has {} available (MemAvailable in /proc/meminfo); use a smaller --width/--height{}",
            crate::budget::human(need),
            match kind {
                FrameKind::Cluster { nodes } => format!(", {nodes} nodes each holding full-screen lists"),
                FrameKind::Render { .. } => String::new(),
            },
            crate::budget::human(avail),
            match kind {
                FrameKind::Cluster { .. } => " or fewer --nodes",
                FrameKind::Render { .. } => "",
            }
        );
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn huge_frames_are_refused_small_ones_pass() {
        let r = FrameKind::Render {
            tile: 32,
            threads: 2,
            compare: false,
        };
        // 65536 x 65536 x 35 bytes > 140 GiB.
        let e = check_fits(65536, 65536, r, Some(64 << 30))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("needs at least 140.0 GiB") && e.contains("64.0 GiB available"),
            "{e}"
        );
        assert!(check_fits(300, 300, r, Some(64 << 20)).is_ok());
        // The cluster's bound grows with the node count.
        let c8 = frame_bytes(300, 300, FrameKind::Cluster { nodes: 8 });
        let c64 = frame_bytes(300, 300, FrameKind::Cluster { nodes: 64 });
        assert!(c64 > 6 * c8, "{c64} vs {c8}");
        assert!(check_fits(300, 300, r, None).is_ok());
    }
}
