//! Options several commands share, declared once and flattened into each
//! command's arguments (same flag, value name, default and parsing
//! everywhere; job files and sweeps name them by flag as before). A command
//! words the help for what the option means there, through clap's
//! `mut_arg` on its own arguments (the texts below).

use clap::Args;

/// `--ert THRESHOLD`: the early termination threshold of every renderer
/// (rays, splats, slices), in (0, 1]; 1 turns it off. What it means for a
/// command is in that command's help ([`RENDER_ERT_HELP`],
/// [`CLUSTER_ERT_HELP`], [`SPLAT_ERT_HELP`]); the validation layer decides
/// it ([`crate::job::validate::ert_mode`]).
#[derive(Debug, Clone, Copy, PartialEq, Args)]
pub struct ErtArg {
    /// Early termination threshold, in (0, 1]; 1 turns it off.
    #[arg(
        id = "ert",
        long = "ert",
        value_name = "THRESHOLD",
        default_value_t = 0.99,
        allow_negative_numbers = true
    )]
    pub threshold: f32,
}

/// `pvrsim render`'s help for `--ert`.
pub const RENDER_ERT_HELP: &str = "Early ray termination threshold, in (0, 1]: a pixel terminates where the alpha of the segments known in front reaches it. 1.0 turns ERT off (no test, no update). Default 0.99 as in the scene contract (and `pvrsim cluster`); the paper's experiments use 0.9. The per-pixel error bound (1 - THRESHOLD) x max emitted radiance is in the stats";

/// `pvrsim cluster`'s help for `--ert`.
pub const CLUSTER_ERT_HELP: &str = "Early ray termination threshold, in (0, 1]. Default 0.99, as in the scene contract and `pvrsim render`; the paper's experiments use 0.9 (`--ert 0.9`); 1.0 turns ERT off (the `Base` and `DLB` rows of the paper's Table 2). Sharing (`--share`, `--sharing`) needs ERT on";

/// `pvrsim splat`'s help for `--ert`.
pub const SPLAT_ERT_HELP: &str = "Early splat elimination threshold in (0, 1]: splats are composited front to back and skipped where the 8x8 tiles under them have reached this alpha (per-channel error bound (1 - THRESHOLD) x max(radiance, background), in the stats). 1 turns it off (back to front, exact)";
