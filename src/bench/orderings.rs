//! `pvrsim bench --orderings`: the paper's Table 1 on this machine: ms per
//! full back-to-front ordering of an n^3 grid (n = 64, 100, 128, 256) for
//! the axis-aligned, DDA, quicksort and radix (counting) sort orders,
//! averaged over a fixed set of orthographic view directions, all measured
//! in one run. Each order writes every voxel index into one preallocated
//! buffer (the list the paper hands to the GPU).

use std::path::Path;

use crate::render::splat::order::{self, sort::SortScratch, Order, OrderView};

/// One measurement: grid size, method, mean ms per full ordering.
#[derive(Debug, Clone, serde::Serialize)]
pub struct OrderingRow {
    /// Grid side n (the grid is n^3).
    pub size: u64,
    /// `axis`, `dda`, `quicksort` or `radix`.
    pub method: String,
    /// Mean milliseconds per full ordering over the views.
    pub ms: f64,
}

/// The paper's Table 1 (Pentium 4 3.2 GHz): axis, DDA, quicksort ms.
pub const PAPER_TABLE1: [(u64, [f64; 3]); 4] = [
    (64, [0.352, 0.982, 73.1]),
    (100, [0.946, 2.43, 306.0]),
    (128, [2.82, 5.67, 615.0]),
    (256, [17.6, 34.8, 5120.0]),
];

/// View directions averaged over: generic, near 45° in a plane, near the
/// body diagonal, near an axis (fixed, so runs are comparable).
pub const VIEWS: [[f64; 3]; 4] = [
    [0.37, -0.52, 0.77],
    [0.70, 0.71, 0.05],
    [-0.58, 0.57, 0.58],
    [0.15, 0.05, -0.99],
];

/// CPU time of the calling thread, seconds (`CLOCK_THREAD_CPUTIME_ID`): the
/// machine is shared, and wall-clock times of single-threaded code swing
/// with other users' load; CPU time does not count the time we are
/// descheduled (it still counts cache and memory stalls).
pub fn thread_cpu_s() -> f64 {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `ts` is a valid, writable timespec; the clock id is a constant
    // that Linux supports for the calling thread.
    let rc = unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut ts) };
    assert_eq!(rc, 0, "clock_gettime(CLOCK_THREAD_CPUTIME_ID) failed");
    ts.tv_sec as f64 + ts.tv_nsec as f64 * 1e-9
}

/// Mean over [`VIEWS`] of the median of `repeats` timings of one full
/// ordering of an `n^3` grid by `method`, ms.
pub fn time_ordering(
    n: u64,
    method: Order,
    repeats: usize,
    buf: &mut Vec<u64>,
    scratch: &mut SortScratch,
) -> f64 {
    let dims = [n; 3];
    let total = (n * n * n) as usize;
    buf.clear();
    buf.resize(total, 0);
    // One untimed run grows the reused buffers to size (page faults).
    let first = OrderView::orthographic(VIEWS[0], [1.0; 3]);
    order::visit_with(method, dims, &first, |_| true, scratch, |_| {});
    let mut sum = 0.0;
    for d in VIEWS {
        let view = OrderView::orthographic(d, [1.0; 3]);
        let mut ms: Vec<f64> = (0..repeats.max(1))
            .map(|_| {
                let t = thread_cpu_s();
                let mut k = 0usize;
                order::visit_with(
                    method,
                    dims,
                    &view,
                    |_| true,
                    scratch,
                    |i| {
                        buf[k] = i;
                        k += 1;
                    },
                );
                let e = (thread_cpu_s() - t) * 1e3;
                assert_eq!(k, total, "{method} visited {k} of {total} voxels");
                std::hint::black_box(&buf);
                e
            })
            .collect();
        ms.sort_by(f64::total_cmp);
        sum += ms[ms.len() / 2];
    }
    sum / VIEWS.len() as f64
}

/// Runs the ordering benchmark, prints the table and the ratios beside the
/// paper's, and writes the JSON list when `json` is given.
pub fn run(json: Option<&Path>) -> anyhow::Result<()> {
    let mut rows = Vec::new();
    let mut buf = Vec::new();
    let mut scratch = SortScratch::default();
    println!(
        "{:>5} {:>9} {:>9} {:>11} {:>9} | {:>7} {:>9} {:>9} | paper: {:>6} {:>7}",
        "n",
        "axis ms",
        "dda ms",
        "quicksort",
        "radix",
        "dda/ax",
        "qsort/dda",
        "radix/dda",
        "dda/ax",
        "qs/dda"
    );
    for (n, paper) in PAPER_TABLE1 {
        let ms: Vec<f64> = Order::ALL
            .iter()
            .map(|&m| {
                let sort = matches!(m, Order::Quicksort | Order::Radix);
                let repeats = if sort && n >= 256 { 1 } else { 5 };
                time_ordering(n, m, repeats, &mut buf, &mut scratch)
            })
            .collect();
        for (m, &t) in Order::ALL.iter().zip(&ms) {
            rows.push(OrderingRow {
                size: n,
                method: m.name().into(),
                ms: t,
            });
        }
        println!(
            "{:>5} {:>9.2} {:>9.2} {:>11.1} {:>9.2} | {:>7.2} {:>9.1} {:>9.2} | paper: {:>6.2} {:>7.1}",
            n,
            ms[0],
            ms[1],
            ms[2],
            ms[3],
            ms[1] / ms[0],
            ms[2] / ms[1],
            ms[3] / ms[1],
            paper[1] / paper[0],
            paper[2] / paper[1]
        );
    }
    if let Some(path) = json {
        std::fs::write(path, serde_json::to_string_pretty(&rows)?)
            .map_err(|e| anyhow::anyhow!("cannot write {}: {e}", path.display()))?;
        println!("wrote {}", path.display());
    }
    Ok(())
}
