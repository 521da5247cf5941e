//! Issue 12's skip target as a checked property of the bundled aorta:
//! runs `pvrsim cluster SCENE --nodes N --ert 0.9 --share --dlb` (the
//! defaults: the global front-to-back schedule where it applies), prints
//! cells skipped, share efficiency and the speed-up over Base, and exits
//! non-zero if fewer than MIN cells were skipped or the speed-up is below
//! RATIO.
//!
//! ```text
//! cargo run --release --example schedule_skips -- ../shared/data/aorta-view-b.toml 8 136000 1.5
//! ```
//!
//! (The aorta is in the shared data folder, not in tests/data, so this is
//! an example and not a test; docs/experiments/cluster.md gives its output.)

use clap::Parser;
use pvrsim::job::cluster::ClusterArgs;
use pvrsim::job::ClusterResult;

#[derive(Parser)]
struct Line {
    #[command(flatten)]
    args: ClusterArgs,
}

fn main() -> anyhow::Result<()> {
    let mut a = std::env::args().skip(1);
    let scene = a
        .next()
        .ok_or_else(|| anyhow::anyhow!("usage: SCENE [NODES] [MIN] [RATIO]"))?;
    let nodes = a.next().unwrap_or_else(|| "8".into());
    let min: u64 = a.next().map_or(Ok(136_000), |s| s.parse())?;
    let ratio: f64 = a.next().map_or(Ok(1.5), |s| s.parse())?;
    let line = Line::try_parse_from([
        "cluster", &scene, "--nodes", &nodes, "--ert", "0.9", "--share", "--dlb",
    ])?;
    let ClusterResult::Mesh(mut frames) = line.args.run()? else {
        anyhow::bail!("{scene}: not a mesh scene");
    };
    let r = frames.pop().expect("a frame").report;
    let over = r.base_tsc_max_s.unwrap_or(f64::NAN) / r.tsc_max_s;
    println!(
        "{scene}, {nodes} nodes: skipped {} (share efficiency {:.3}), tsc_max {:.3} s, Base {:.3} s, {over:.3}x over Base, imbalance {:.2} %, schedule {} (stacking {:?}), {} cells dealt",
        r.cells_skipped_ert,
        r.share_efficiency.unwrap_or(f64::NAN),
        r.tsc_max_s,
        r.base_tsc_max_s.unwrap_or(f64::NAN),
        100.0 * r.imbalance,
        if r.schedule_applied { "applied" } else { "not applied" },
        r.schedule_stacking,
        r.cells_scheduled
    );
    anyhow::ensure!(
        r.cells_skipped_ert >= min,
        "skipped {} < {min}",
        r.cells_skipped_ert
    );
    anyhow::ensure!(over >= ratio, "{over:.3}x over Base < {ratio}x");
    Ok(())
}
