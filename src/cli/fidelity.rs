//! `pvrsim fidelity`: measured beside modelled, per node and per phase
//! ([`crate::experiment::fidelity`]); optionally calibrates the node first
//! (`--calibrate`, the profile then used by both runs).

use std::path::PathBuf;

use clap::Args;

use crate::bench::calibrate;
use crate::experiment::fidelity::{self, FidelityOptions};

/// Options of `pvrsim fidelity`.
#[derive(Debug, Args)]
pub struct FidelityArgs {
    /// Mesh scene (default: the built-in aorta-small view B, 20,169 cells, 100 x 100).
    #[arg(long)]
    pub mesh_scene: Option<PathBuf>,
    /// Grid scene (default: the built-in hydrogen grid, 64^3, 2^3 bricks).
    #[arg(long)]
    pub grid_scene: Option<PathBuf>,
    /// Workloads: mesh, grid.
    #[arg(long, value_delimiter = ',', default_value = "mesh,grid")]
    pub workloads: Vec<String>,
    /// Node counts.
    #[arg(long, value_delimiter = ',', default_value = "2,4")]
    pub nodes: Vec<usize>,
    /// Transports measured: threads (--clock wall), processes, tcp (--workers).
    #[arg(long, value_delimiter = ',', default_value = "processes")]
    pub transports: Vec<String>,
    /// TCP workers (`pvrsim worker` addresses; an N-node frame uses the first N).
    #[arg(long, value_delimiter = ',')]
    pub workers: Vec<String>,
    /// Token file of the workers.
    #[arg(long)]
    pub token_file: Option<PathBuf>,
    /// Network model of the modelled runs: a preset or a file (e.g. the one
    /// `pvrsim calibrate --network` fitted on the same link).
    #[arg(long, default_value = "gbe")]
    pub network: String,
    /// Label of the link in the rows (loopback, 1gbit, 100mbit).
    #[arg(long, default_value = "loopback")]
    pub link: String,
    /// Cost profile of both runs (default: calibrated, see --calibrate).
    #[arg(long, default_value = "calibrated")]
    pub profile: String,
    /// Fit the node's unit costs on this machine first (`pvrsim calibrate`,
    /// written to OUT/profile.toml, used by both runs).
    #[arg(long)]
    pub calibrate: bool,
    /// Mesh variants: ert-off, ert, ert+share, ert+share+dlb, dlb.
    #[arg(long, value_delimiter = ',', default_value = "ert-off,ert+share+dlb")]
    pub mesh_variants: Vec<String>,
    /// Grid variants: binary-swap, master.
    #[arg(long, value_delimiter = ',', default_value = "binary-swap,master")]
    pub grid_variants: Vec<String>,
    /// Measured runs per frame (kept: the least CPU and wall time of each row).
    #[arg(long, default_value_t = 3)]
    pub repeats: usize,
    /// Output folder: fidelity.csv, fidelity.json, fidelity-PHASE.png.
    #[arg(long, short, default_value = "fidelity")]
    pub out: PathBuf,
    /// Keep the rows already in OUT/fidelity.json (other links, transports).
    #[arg(long)]
    pub append: bool,
    /// Check the bands on this link's rows (4 nodes: phase-1 compute per
    /// node within 25 %, phase 2 within 30 %; 2 nodes: frame within 30 %);
    /// exit 1 when a ratio leaves its band.
    #[arg(long, value_name = "LINK")]
    pub check: Option<String>,
    /// With --check: bands whose description contains TEXT (e.g. `frame`)
    /// are printed and marked but do not fail the check (a known gap,
    /// named in docs/experiments/fidelity.md). Repeatable.
    #[arg(long, value_name = "TEXT")]
    pub report_band: Vec<String>,
    /// Run no frame: print, plot and check the rows in OUT/fidelity.json.
    #[arg(long)]
    pub report_only: bool,
}

/// Runs `pvrsim fidelity`.
pub fn run(a: FidelityArgs) -> anyhow::Result<()> {
    anyhow::ensure!(
        !(a.report_only && a.calibrate),
        "--report-only runs nothing; leave out --calibrate"
    );
    anyhow::ensure!(
        a.report_band.is_empty() || a.check.is_some(),
        "--report-band marks bands of --check; give --check LINK"
    );
    let report_band = a.report_band.clone();
    let mut profile = a.profile.clone();
    let mut o = FidelityOptions {
        mesh_scene: a.mesh_scene,
        grid_scene: a.grid_scene,
        workloads: a.workloads,
        nodes: a.nodes,
        transports: a.transports,
        workers: a.workers,
        token_file: a.token_file,
        network: a.network,
        link: a.link,
        profile: String::new(),
        mesh_variants: a.mesh_variants,
        grid_variants: a.grid_variants,
        repeats: a.repeats,
        out: a.out,
        append: a.append,
        check_link: a.check,
        report_only: a.report_only,
    };
    o.profile = profile.clone();
    fidelity::check_options(&o)?;
    if a.calibrate {
        std::fs::create_dir_all(&o.out).map_err(|e| {
            anyhow::anyhow!("--out {}: cannot create the folder: {e}", o.out.display())
        })?;
        let path = o.out.join("profile.toml");
        let mut c = <calibrate::CalibrateArgs as clap::FromArgMatches>::from_arg_matches(
            &<calibrate::CalibrateArgs as clap::Args>::augment_args(clap::Command::new(
                "calibrate",
            ))
            .no_binary_name(true)
            .get_matches_from(Vec::<String>::new()),
        )?;
        c.out = path.clone();
        c.force = true;
        calibrate::run(c)?;
        profile = path.display().to_string();
        o.profile = profile;
    }
    let r = fidelity::run(&o)?;
    println!("measured clock: cpu = the node's CPU seconds (thread; process for a grid node's render) against modelled compute; wall = elapsed seconds (wire, peers and waiting for a core included) against modelled time with communication");
    print!("{}", fidelity::table(&r.rows));
    for f in &r.files {
        println!("wrote {}", f.display());
    }
    let mut failed = 0;
    for b in &r.bands {
        let reported = report_band.iter().any(|t| b.what.contains(t.as_str()));
        println!(
            "band {}: {}: modelled / measured {:.3} (within {:.0} %){}",
            if b.ok { "ok  " } else { "FAIL" },
            b.what,
            b.ratio,
            100.0 * b.tolerance,
            if reported {
                " [reported, not held: --report-band]"
            } else {
                ""
            }
        );
        failed += usize::from(!b.ok && !reported);
    }
    if o.check_link.is_some() {
        anyhow::ensure!(
            !r.bands.is_empty(),
            "--check {}: no row of that link to check",
            o.check_link.as_deref().unwrap_or("")
        );
        anyhow::ensure!(failed == 0, "{failed} of {} bands failed", r.bands.len());
    }
    Ok(())
}
