//! The grid cluster's driver: bricks cut, ranked and placed
//! ([`prepare`]), phase 1 on the nodes, phase 2 over their layers
//! ([`finish`]), one frame or a series on the same nodes ([`run_frames`]).

use super::prepared::{prepare, Phase1Out, Prepared};
use super::{report, GridConfig, GridOutcome};
use std::sync::Arc;

use crate::cluster::phase1::drive;
use crate::compositor::layer::exec as layer_exec;
use crate::compositor::region::screen;
use crate::node::grid::GridNodeActor;
use crate::render::VolumeInput;

/// Runs one frame of `input` on the grid cluster.
pub fn run(input: &VolumeInput, cfg: &GridConfig) -> anyhow::Result<GridOutcome> {
    let mut out = run_frames(input, cfg, std::slice::from_ref(&input.scene.camera))?;
    Ok(out.pop().expect("one frame"))
}

/// Runs one frame per camera of `cameras` (`input` with each camera in
/// turn) on the same nodes: bricks are cut and placed once, and each node
/// keeps its bricks' textures from frame to frame (unless
/// `cfg.texture_cache` is off), as a cluster keeps what it uploaded.
pub fn run_frames(
    input: &VolumeInput,
    cfg: &GridConfig,
    cameras: &[crate::scene::Camera],
) -> anyhow::Result<Vec<GridOutcome>> {
    anyhow::ensure!(!cameras.is_empty(), "no frame to render");
    let t0 = std::time::Instant::now();
    let mut prep = prepare(input, cfg)?;
    let mut actors: Vec<GridNodeActor> = Vec::new();
    let mut outs = Vec::with_capacity(cameras.len());
    let mut input = input.clone();
    for (f, cam) in cameras.iter().enumerate() {
        crate::base::cancel::checkpoint();
        let t = if f == 0 {
            t0
        } else {
            std::time::Instant::now()
        };
        input.scene.camera = *cam;
        prep.view(&input, cfg);
        let whole = Arc::new(input.clone());
        if f == 0 {
            actors = (0..prep.total)
                .map(|k| {
                    let a = GridNodeActor::new(
                        k,
                        whole.clone(),
                        prep.planes,
                        prep.held(k),
                        cfg.slice,
                        prep.codec.depth(),
                        cfg.profile,
                        cfg.renderer,
                    );
                    let keep = cfg.texture_cache.then(Default::default);
                    a.with_textures(keep)
                })
                .collect();
        } else {
            for (k, a) in actors.iter_mut().enumerate() {
                let ranks: Vec<u32> = prep.held(k).iter().map(|h| h.2).collect();
                a.next_frame(whole.clone(), prep.planes, &ranks)?;
            }
        }
        let mut out = phase1_and_2(&input, cfg, &prep, &mut actors)?;
        out.report.wall_s = t.elapsed().as_secs_f64();
        outs.push(out);
    }
    Ok(outs)
}

/// One frame on `actors` (set up for it): phase 1, phase 2, the report.
fn phase1_and_2(
    input: &VolumeInput,
    cfg: &GridConfig,
    prep: &Prepared,
    actors: &mut [GridNodeActor],
) -> anyhow::Result<GridOutcome> {
    let t1 = std::time::Instant::now();
    let (stopped, trace1, _traffic1) = drive(
        actors.iter_mut().collect::<Vec<_>>(),
        cfg.clock,
        &cfg.network,
        cfg.record_trace,
        "grid phase 1",
    )?;
    let host_s = t1.elapsed().as_secs_f64();
    if let Some(a) = actors.iter().find(|a| a.stats().error.is_some()) {
        anyhow::bail!(
            "grid node {} failed: {}",
            a.stats().rank,
            a.stats().error.as_deref().unwrap_or("")
        );
    }
    let p1 = Phase1Out {
        stats: actors.iter().map(|a| a.stats().clone()).collect(),
        layers: actors.iter_mut().map(|a| a.take_layers()).collect(),
        ends: stopped.iter().map(|t| t.unwrap_or(0.0)).collect(),
        host_s,
        trace: trace1,
    };
    finish(input, cfg, prep, p1)
}

/// Phase 2 over the ranks' layers (every message encoded and decoded,
/// replayed on the modelled network) and the report.
pub fn finish(
    input: &VolumeInput,
    cfg: &GridConfig,
    prep: &Prepared,
    p1: Phase1Out,
) -> anyhow::Result<GridOutcome> {
    let s = &input.scene;
    let t2 = std::time::Instant::now();
    let sched = prep
        .strategy
        .schedule(prep.total, screen(s.image.width, s.image.height));
    let bg = s.image.background.map(|x| x as f32);
    let (image, rounds) = layer_exec::run(
        &sched,
        prep.codec.as_ref(),
        p1.layers,
        bg,
        prep.strategy.merges_early(),
    )?;
    let p1 = Phase1Out {
        layers: Vec::new(),
        ..p1
    };
    report(input, cfg, prep, p1, image, rounds, t2)
}
