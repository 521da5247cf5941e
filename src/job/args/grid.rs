//! The options of `pvrsim cluster` that only grid scenes take
//! ([`GridArgs`], with `--radix-k`, which both kinds take), and their
//! refusal on mesh scenes.

use clap::Args;

use crate::node::grid::BrickPlacement;

/// Options of `pvrsim cluster` that only grid scenes take.
#[derive(Debug, Clone, Args)]
pub struct GridArgs {
    /// Grid scenes: cut the volume into d^3 bricks (one-voxel overlap) spread
    /// over the nodes. Default 2 for grid scenes; refused for mesh scenes.
    #[arg(long, value_name = "D")]
    pub subvolumes: Option<u32>,
    /// Grid scenes: add a master rank (renders nothing, composites every
    /// subimage: the paper's 4 slaves + master). Implies `--compositor master`.
    #[arg(long)]
    pub master: bool,
    /// Grid scenes: brick placement (`round-robin` as in the paper, or
    /// `balanced` by visible voxels).
    #[arg(long, value_enum)]
    pub brick_placement: Option<BrickPlacement>,
    /// Grid scenes: render each brick by adaptive block sampling with B
    /// blocks per axis of the brick (`render --renderer adaptive`).
    #[arg(long, value_name = "B")]
    pub blocks: Option<u64>,
    /// Grid scenes with --blocks: the adaptive tolerance τ (RMS error per
    /// block at most τ times the transfer function's scalar range; default 0.05).
    #[arg(long, value_name = "T")]
    pub tolerance: Option<f64>,
    /// With `--compositor radix-k`: the target group size k of each round
    /// (default 8, IceT's; rounds' sizes multiply to the rank count, a
    /// prime factor above k gets a round of its own).
    #[arg(long, value_name = "K")]
    pub radix_k: Option<crate::compositor::strategy::GroupSize>,
    /// Grid scenes: prepare every brick's texture every frame (no cache
    /// across frames; for measuring what the cache saves).
    #[arg(long)]
    pub no_texture_cache: bool,
}

/// Refuses grid-only options on a mesh scene.
pub fn refuse_on_mesh(g: &GridArgs) -> anyhow::Result<()> {
    let mut bad = Vec::new();
    if g.subvolumes.is_some() {
        bad.push("--subvolumes");
    }
    if g.master {
        bad.push("--master");
    }
    if g.brick_placement.is_some() {
        bad.push("--brick-placement");
    }
    if g.blocks.is_some() {
        bad.push("--blocks");
    }
    if g.tolerance.is_some() {
        bad.push("--tolerance");
    }
    if g.no_texture_cache {
        bad.push("--no-texture-cache");
    }
    anyhow::ensure!(
        bad.is_empty(),
        "{} only apply to grid scenes (a volume); this scene's data is a mesh",
        bad.join(", ")
    );
    Ok(())
}
