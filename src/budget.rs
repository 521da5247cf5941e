//! The memory and thread budget: one check before any work, for every
//! command, so that a huge option value is refused with a message that
//! states the estimate and the limit, instead of aborting on a failed
//! allocation or starting thousands of threads.
//!
//! | check | limit |
//! |---|---|
//! | [`threads`] | the machine's cores x [`THREAD_FACTOR`] (0 = all cores is fine) |
//! | [`local_nodes`] | nodes run as threads or processes of this host: the cores x [`NODE_FACTOR`], at least [`MIN_LOCAL_NODES`] |
//! | [`slices`] | [`MAX_SLICES`] |
//! | [`image()`] | [`MAX_IMAGE_SIDE`] a side; `W·H·`[`IMAGE_BYTES_PER_PIXEL`] against `MemAvailable` |
//! | [`volume`] | [`MAX_VOLUME_SIDE`] a side; voxels x bytes a voxel against `MemAvailable` |
//! | [`footprint`] | `sigma` at most [`MAX_SIGMA`] voxels; the footprint table against `MemAvailable` |
//!
//! `MemAvailable` comes from `/proc/meminfo`; where it cannot be read, only
//! the fixed limits apply. Estimates are lower bounds of what the work
//! allocates (the buffers fixed by the sizes), so a refusal is certain to be
//! right, and a pass is no promise.

use anyhow::{bail, Result};

/// Most threads per core an option may ask for.
pub const THREAD_FACTOR: usize = 4;
/// Most cluster nodes per core when every node is a thread or a process of
/// this host (`--clock wall`, `--transport threads|processes`): the nodes
/// mostly wait on each other, so more than cores fit, but thousands only
/// thrash (the simulated clock, one thread for all nodes, has no such limit).
pub const NODE_FACTOR: usize = 16;
/// The node limit on a host with few cores: an 8-node cluster (plus its
/// manager) on a 2-core laptop is the common case, 64 nodes still run.
pub const MIN_LOCAL_NODES: usize = 64;
/// Most slices of a slice renderer (a 4096³ volume's diagonal at a quarter
/// voxel is about 28 000).
pub const MAX_SLICES: u64 = 65_536;
/// Longest image side, pixels.
pub const MAX_IMAGE_SIDE: u64 = 32_768;
/// Bytes a pixel of the final image costs at least (an RGBA f32 image, an
/// accumulation buffer and the PNG row).
pub const IMAGE_BYTES_PER_PIXEL: u64 = 16 + 16 + 4;
/// Longest side of a generated volume, voxels.
pub const MAX_VOLUME_SIDE: u64 = 16_384;
/// Largest splatting kernel, standard deviations in voxels (the usual
/// reconstruction kernels are 0.5 to 1.5).
pub const MAX_SIGMA: f64 = 16.0;

/// The machine's cores (at least 1).
pub fn cores() -> usize {
    std::thread::available_parallelism().map_or(1, |n| n.get())
}

/// `MemAvailable` of `/proc/meminfo`, bytes (`None` where not readable).
pub fn available_bytes() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    parse_mem_available(&text)
}

/// `MemAvailable` of a `/proc/meminfo` text, bytes.
fn parse_mem_available(text: &str) -> Option<u64> {
    let line = text.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb.saturating_mul(1024))
}

/// Bytes as GiB, MiB or KiB (one decimal).
pub fn human(bytes: u64) -> String {
    let b = bytes as f64;
    const K: f64 = 1024.0;
    if b >= K * K * K * K {
        format!("{:.1} TiB", b / (K * K * K * K))
    } else if b >= K * K * K {
        format!("{:.1} GiB", b / (K * K * K))
    } else if b >= K * K {
        format!("{:.1} MiB", b / (K * K))
    } else {
        format!("{:.1} KiB", b / K)
    }
}

/// Refuses `need` bytes (for `what`, because of `option`) beyond
/// `MemAvailable`.
pub fn memory(option: &str, what: &str, need: u64) -> Result<()> {
    memory_within(option, what, need, available_bytes())
}

fn memory_within(option: &str, what: &str, need: u64, avail: Option<u64>) -> Result<()> {
    if let Some(avail) = avail {
        if need > avail {
            bail!(
                "{option}: {what} needs at least {} of memory, but this machine has {} available \
                 (MemAvailable in /proc/meminfo); use a smaller {option}",
                human(need),
                human(avail)
            );
        }
    }
    Ok(())
}

/// Refuses more than cores x [`THREAD_FACTOR`] threads (0 means all cores).
pub fn threads(option: &str, n: usize) -> Result<()> {
    threads_on(option, n, cores())
}

fn threads_on(option: &str, n: usize, cores: usize) -> Result<()> {
    let limit = cores.max(1) * THREAD_FACTOR;
    if n > limit {
        bail!(
            "{option} {n}: more than {limit} threads ({cores} cores x {THREAD_FACTOR}) would only \
 \
             thrash; use at most {limit}, or 0 for one per core"
        );
    }
    Ok(())
}

/// Refuses a cluster of more than cores x [`NODE_FACTOR`] (at least
/// [`MIN_LOCAL_NODES`]) nodes when each node is a thread or a process of
/// this host; `how` names them (`--transport processes`).
pub fn local_nodes(option: &str, n: usize, how: &str) -> Result<()> {
    local_nodes_on(option, n, how, cores())
}

fn local_nodes_on(option: &str, n: usize, how: &str, cores: usize) -> Result<()> {
    let limit = (cores.max(1) * NODE_FACTOR).max(MIN_LOCAL_NODES);
    if n > limit {
        bail!(
            "{option} {n} with {how}: every node is a thread or a process of this host, and more \
             than {limit} ({cores} cores x {NODE_FACTOR}, at least {MIN_LOCAL_NODES}) would only \
             thrash; use at most {limit} here, drop {how} for the simulated clock (any node \
             count), or spread the nodes over machines with --transport tcp"
        );
    }
    Ok(())
}

/// Refuses more than [`MAX_SLICES`] slices.
pub fn slices(option: &str, n: u64) -> Result<()> {
    if n > MAX_SLICES {
        bail!(
            "{option} {n}: at most {MAX_SLICES} slices (a 4096³ volume needs fewer than 30 000 at a \
             quarter voxel apart)"
        );
    }
    Ok(())
}

/// Refuses an image side above [`MAX_IMAGE_SIDE`] or an image whose
/// buffers do not fit in `MemAvailable`; `what` names where the size comes
/// from (`--width/--height`, or the scene's `image.width`).
pub fn image(what: &str, width: u64, height: u64) -> Result<()> {
    image_within(what, width, height, available_bytes())
}

fn image_within(what: &str, width: u64, height: u64, avail: Option<u64>) -> Result<()> {
    if width.max(height) > MAX_IMAGE_SIDE {
        bail!(
            "{what}: a {width}x{height} image is larger than the limit of {MAX_IMAGE_SIDE} pixels a side"
        );
    }
    let need = width
        .saturating_mul(height)
        .saturating_mul(IMAGE_BYTES_PER_PIXEL);
    memory_within(
        what,
        &format!("a {width}x{height} image ({IMAGE_BYTES_PER_PIXEL} bytes a pixel)"),
        need,
        avail,
    )
}

/// Refuses a volume of `dims` voxels (`bytes_per_voxel` while it is made
/// and written) with a side above [`MAX_VOLUME_SIDE`] or beyond
/// `MemAvailable`.
pub fn volume(option: &str, dims: [u64; 3], bytes_per_voxel: u64) -> Result<()> {
    volume_within(option, dims, bytes_per_voxel, available_bytes())
}

fn volume_within(option: &str, dims: [u64; 3], bpv: u64, avail: Option<u64>) -> Result<()> {
    let [a, b, c] = dims;
    if a.max(b).max(c) > MAX_VOLUME_SIDE {
        bail!("{option} {a}x{b}x{c}: larger than the limit of {MAX_VOLUME_SIDE} voxels a side");
    }
    let need = a.saturating_mul(b).saturating_mul(c).saturating_mul(bpv);
    memory_within(
        option,
        &format!("a {a}x{b}x{c} volume ({bpv} bytes a voxel)"),
        need,
        avail,
    )
}

/// Refuses a splatting kernel wider than [`MAX_SIGMA`] voxels, or whose
/// footprint table (`phases`² footprints of `(2r+3)²` floats, `r = 3 sigma
/// px_per_voxel` pixels) does not fit in `MemAvailable`.
pub fn footprint(option: &str, sigma: f64, px_per_voxel: f64, phases: u32) -> Result<()> {
    footprint_within(option, sigma, px_per_voxel, phases, available_bytes())
}

fn footprint_within(
    option: &str,
    sigma: f64,
    px_per_voxel: f64,
    phases: u32,
    avail: Option<u64>,
) -> Result<()> {
    if !(sigma.is_finite() && sigma > 0.0) {
        bail!("{option} must be > 0, got {sigma}");
    }
    if sigma > MAX_SIGMA {
        bail!(
            "{option} {sigma}: a kernel of more than {MAX_SIGMA} voxels (standard deviation) blurs \
             the volume away and its footprints would not fit in memory; usual values are 0.5 to 1.5"
        );
    }
    let r = 3.0 * sigma * px_per_voxel.max(0.0);
    let side = (2.0 * r.ceil() + 3.0).min(1e9) as u64;
    let p = u64::from(phases.max(1));
    let need = (p * p)
        .saturating_mul(side.saturating_mul(side))
        .saturating_mul(4);
    memory_within(
        option,
        &format!("a footprint of radius {r:.0} pixels ({p}x{p} phases)"),
        need,
        avail,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_meminfo() {
        let t = "MemTotal:  8000 kB\nMemFree: 100 kB\nMemAvailable:    2048 kB\n";
        assert_eq!(parse_mem_available(t), Some(2048 * 1024));
        assert_eq!(parse_mem_available("MemTotal: 1 kB\n"), None);
    }

    #[test]
    fn limits_name_the_option_the_estimate_and_the_limit() {
        let e = threads_on("--threads", 100_000, 2).unwrap_err().to_string();
        assert!(
            e.contains("--threads 100000") && e.contains("at most 8"),
            "{e}"
        );
        assert!(threads_on("--threads", 0, 2).is_ok());
        assert!(threads_on("--threads", 8, 2).is_ok());
        let e = local_nodes_on("--nodes", 5000, "--clock wall", 2)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("--nodes 5000 with --clock wall") && e.contains("at most 64"),
            "{e}"
        );
        assert!(local_nodes_on("--nodes", 64, "--clock wall", 2).is_ok());
        assert!(local_nodes_on("--nodes", 128, "--clock wall", 8).is_ok());
        let e = slices("--slices", 100_000_000).unwrap_err().to_string();
        assert!(e.contains("--slices") && e.contains("65536"), "{e}");
        let e = image_within("--width/--height", 65_536, 65_536, None)
            .unwrap_err()
            .to_string();
        assert!(e.contains("32768"), "{e}");
        let e = image_within("--width/--height", 20_000, 20_000, Some(1 << 30))
            .unwrap_err()
            .to_string();
        assert!(e.contains("13.4 GiB") && e.contains("1.0 GiB"), "{e}");
        let e = volume_within("--size", [100_000; 3], 4, None)
            .unwrap_err()
            .to_string();
        assert!(e.contains("--size 100000x100000x100000"), "{e}");
        let e = volume_within("--size", [4000; 3], 4, Some(1 << 30))
            .unwrap_err()
            .to_string();
        assert!(e.contains("GiB of memory"), "{e}");
        let e = footprint_within("--sigma", 1000.0, 1.0, 32, None)
            .unwrap_err()
            .to_string();
        assert!(e.contains("--sigma 1000"), "{e}");
        assert!(footprint_within("--sigma", 0.6, 2.0, 32, Some(1 << 30)).is_ok());
        let e = footprint_within("--sigma", 16.0, 100.0, 64, Some(1 << 30))
            .unwrap_err()
            .to_string();
        assert!(e.contains("footprint of radius 4800"), "{e}");
    }
}
