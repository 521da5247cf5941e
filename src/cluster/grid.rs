//! The cluster with grid nodes (sort-last rendering of regular grids,
//! `parallel-texture-vr-rle.txt`): the same phase-1 driver
//! ([`super::phase1::drive`]) runs [`GridNodeActor`]s instead of cell nodes
//! and a manager; phase 2 runs the same compositing schedules over their
//! visibility-ranked RGBA layers ([`crate::compositor::layer::exec`]) and
//! replays every message on the simulated network
//! ([`super::phase2::replay`]).
//!
//! With a master (`--master`, the paper's setting) rank 0 renders nothing
//! and composites; ranks `1..=P` hold the bricks.

use std::collections::BTreeMap;
use std::sync::Arc;

use serde::Serialize;

use super::phase1::{drive, ClockKind};
use super::phase2::{replay, RoundPlan};
use crate::compositor::codec::layers as layer_codec;
use crate::compositor::layer::exec as layer_exec;
use crate::compositor::region::screen;
use crate::image::Image;
use crate::net::{MessageKind, NetworkModel, SimTrace};
use crate::node::grid::bricks::{extract, place, split, visibility_ranks, BrickPlacement};
use crate::node::grid::device::{blend_time, check};
use crate::node::grid::render::{whole_planes, BrickRenderer};
use crate::node::grid::{GridNodeActor, GridNodeStats};
use crate::node::CostProfile;
use crate::render::slice3d::Slice3dOptions;
use crate::render::slicing::Lut;
use crate::render::VolumeInput;

/// A grid cluster run's settings.
#[derive(Clone)]
pub struct GridConfig {
    /// Rendering nodes `P`.
    pub nodes: usize,
    /// Bricks per axis `d` (`d^3` bricks).
    pub subvolumes: u32,
    /// A master rank that renders nothing (rank 0).
    pub master: bool,
    /// Brick placement.
    pub placement: BrickPlacement,
    /// Compositing strategy name.
    pub compositor: String,
    /// Layer codec name.
    pub codec: String,
    /// Slicer options (ERT, slices, classification).
    pub slice: Slice3dOptions,
    /// The brick renderer.
    pub renderer: BrickRenderer,
    /// Clock.
    pub clock: ClockKind,
    /// Network model and its name.
    pub network: NetworkModel,
    /// Network name.
    pub network_name: String,
    /// Cost profile and its name.
    pub profile: CostProfile,
    /// Profile name.
    pub profile_name: String,
    /// Record the timeline.
    pub record_trace: bool,
}

/// Per rank, in the report.
#[derive(Debug, Clone, Serialize)]
pub struct GridNodeReport {
    /// The node's phase-1 numbers.
    #[serde(flatten)]
    pub stats: GridNodeStats,
    /// When it finished rendering (seconds).
    pub render_end_s: f64,
    /// Payload bytes it sent in phase 2.
    pub bytes_sent: u64,
}

/// The report of a grid cluster run (the keys of the cell report that
/// apply, plus the grid's own).
#[derive(Debug, Clone, Serialize)]
pub struct GridReport {
    /// Image size.
    pub image: [u32; 2],
    /// Volume samples per axis.
    pub volume_dims: [u64; 3],
    /// Bricks per axis.
    pub subvolumes: u32,
    /// Rendering nodes.
    pub n_nodes: usize,
    /// With a master rank.
    pub master: bool,
    /// Clock.
    pub clock: ClockKind,
    /// Network name.
    pub network: String,
    /// Profile name.
    pub profile: String,
    /// Placement.
    pub placement: BrickPlacement,
    /// Compositing strategy.
    pub compositor: String,
    /// Layer codec.
    pub codec: String,
    /// Frame time: end of phase 2 (seconds).
    pub frame_s: f64,
    /// End of phase 1: the slowest node's render (seconds).
    pub render_s: f64,
    /// Phase 2 (compositing, with its network time), seconds.
    pub composite_s: f64,
    /// Payload bytes of phase 2.
    pub bytes_total: u64,
    /// Bytes per message kind.
    pub bytes_by_kind: BTreeMap<String, u64>,
    /// Bytes sent / raw RGBA8 bytes of the same layers.
    pub codec_ratio: f64,
    /// Per round: label, messages, bytes, raw bytes.
    pub rounds: Vec<(String, usize, u64, u64)>,
    /// Per rank.
    pub nodes: Vec<GridNodeReport>,
    /// Host seconds of phase 1 and 2.
    pub host_s: [f64; 2],
}

/// What a grid run produced.
#[derive(Debug)]
pub struct GridOutcome {
    /// The image at the root.
    pub image: Image,
    /// The report.
    pub report: GridReport,
    /// Phase 1 and 2 timeline.
    pub trace: SimTrace,
}

/// Runs one frame of `input` on the grid cluster.
pub fn run(input: &VolumeInput, cfg: &GridConfig) -> anyhow::Result<GridOutcome> {
    anyhow::ensure!(cfg.nodes >= 1, "--nodes must be at least 1");
    anyhow::ensure!(
        cfg.nodes <= 4096,
        "--nodes {} is more than grid runs support (4096)",
        cfg.nodes
    );
    if cfg.clock == ClockKind::Virtual {
        check(&cfg.profile, &cfg.profile_name)?;
    }
    crate::render::slice3d::check(&cfg.slice)?;
    let strategy =
        crate::compositor::strategy::from_name(&cfg.compositor).map_err(|e| anyhow::anyhow!(e))?;
    let codec = layer_codec::from_name(&cfg.codec).map_err(|e| anyhow::anyhow!(e))?;
    let d = cfg.subvolumes;
    let bricks = split(input.volume.dims, d)?;
    anyhow::ensure!(
        bricks.len() >= cfg.nodes,
        "--subvolumes {d} gives {} bricks for {} nodes: some nodes would have none",
        bricks.len(),
        cfg.nodes
    );
    let s = &input.scene;
    let view = s.camera.view(s.image.width, s.image.height);
    let ranks = visibility_ranks(&view, &input.volume, d, &bricks);
    let vols: Vec<Arc<crate::data::Volume>> = bricks
        .iter()
        .map(|b| Arc::new(extract(&input.volume, b)))
        .collect();
    // Balanced placement weighs a brick by its voxels the TF makes visible.
    let lut = Lut::new(&s.transfer, input.range);
    let weight: Vec<u64> = vols
        .iter()
        .map(|v| {
            (0..v.len())
                .filter(|&i| {
                    let x = v.voxels.get_f32(i);
                    !lut.transparent(x, x)
                })
                .count() as u64
        })
        .collect();
    let parts = place(bricks.len(), cfg.nodes, cfg.placement, &weight);
    let planes = whole_planes(input, &cfg.slice);
    let whole = Arc::new(input.clone());
    let off = usize::from(cfg.master);
    let total = cfg.nodes + off;
    let mut actors: Vec<GridNodeActor> = Vec::with_capacity(total);
    for k in 0..total {
        let mine = if k < off {
            &[][..]
        } else {
            &parts[k - off][..]
        };
        let held = mine
            .iter()
            .map(|&b| {
                (
                    bricks[b as usize],
                    vols[b as usize].clone(),
                    ranks[b as usize],
                )
            })
            .collect();
        actors.push(GridNodeActor::new(
            k,
            whole.clone(),
            planes,
            held,
            cfg.slice,
            cfg.profile,
            cfg.renderer.clone(),
        ));
    }
    let t1 = std::time::Instant::now();
    let (stopped, trace1, _traffic1) = drive(
        actors.iter_mut().collect::<Vec<_>>(),
        cfg.clock,
        &cfg.network,
        cfg.record_trace,
        "grid phase 1",
    )?;
    let host1 = t1.elapsed().as_secs_f64();
    if let Some(a) = actors.iter().find(|a| a.stats().error.is_some()) {
        anyhow::bail!(
            "grid node {} failed: {}",
            a.stats().rank,
            a.stats().error.as_deref().unwrap_or("")
        );
    }
    let ends: Vec<f64> = stopped.iter().map(|t| t.unwrap_or(0.0)).collect();
    let render_s = ends.iter().fold(0.0f64, |a, &b| a.max(b));

    // Phase 2: the schedule over layers, every message encoded and decoded.
    let t2 = std::time::Instant::now();
    let held: Vec<_> = actors.iter_mut().map(|a| a.take_layers()).collect();
    let sched = strategy.schedule(total, screen(s.image.width, s.image.height));
    let bg = s.image.background.map(|x| x as f32);
    let (image, rounds) = layer_exec::run(&sched, codec.as_ref(), held, bg)?;
    let mut plans: Vec<Vec<RoundPlan>> = vec![vec![RoundPlan::default(); rounds.len()]; total];
    let mut costs: Vec<BTreeMap<(u32, u32), f64>> = vec![BTreeMap::new(); total];
    let mut bytes_sent = vec![0u64; total];
    let (mut bytes, mut raw) = (0u64, 0u64);
    let mut round_rows = Vec::new();
    for (r, lr) in rounds.iter().enumerate() {
        if lr.composite {
            for (k, &px) in lr.blended.iter().enumerate() {
                plans[k][r].before = blend_time(px, &cfg.profile);
            }
        }
        let (mut rb, mut rr) = (0, 0);
        for m in &lr.messages {
            plans[m.from][r]
                .sends
                .push((m.to, m.bytes as usize, MessageKind::Image));
            plans[m.to][r].expect += 1;
            // Received subimages are blended in the composite round, except
            // the final gather's pieces, which are pasted (one blend).
            if !lr.composite && lr.label == "gather" {
                costs[m.to].insert(
                    (r as u32, m.from as u32),
                    blend_time(m.pixels, &cfg.profile),
                );
            }
            bytes_sent[m.from] += m.bytes;
            rb += m.bytes;
            rr += m.raw_bytes;
        }
        bytes += rb;
        raw += rr;
        round_rows.push((lr.label.clone(), lr.messages.len(), rb, rr));
    }
    let sim = replay(
        plans,
        costs,
        &cfg.network,
        cfg.record_trace && cfg.clock == ClockKind::Virtual,
    )?;
    let host2 = t2.elapsed().as_secs_f64();
    let composite_s = match cfg.clock {
        ClockKind::Virtual => sim.end_time,
        ClockKind::Wall => host2,
    };
    let mut trace = trace1;
    for mut e in sim.trace.events.iter().cloned() {
        e.start += render_s;
        e.end += render_s;
        trace.events.push(e);
    }
    let mut by_kind = BTreeMap::new();
    if bytes > 0 {
        by_kind.insert("image".to_string(), bytes);
    }
    let report = GridReport {
        image: [s.image.width, s.image.height],
        volume_dims: input.volume.dims,
        subvolumes: d,
        n_nodes: cfg.nodes,
        master: cfg.master,
        clock: cfg.clock,
        network: cfg.network_name.clone(),
        profile: cfg.profile_name.clone(),
        placement: cfg.placement,
        compositor: strategy.name().to_string(),
        codec: codec.name().to_string(),
        frame_s: render_s + composite_s,
        render_s,
        composite_s,
        bytes_total: bytes,
        bytes_by_kind: by_kind,
        codec_ratio: if raw > 0 {
            bytes as f64 / raw as f64
        } else {
            1.0
        },
        rounds: round_rows,
        nodes: actors
            .iter()
            .zip(&ends)
            .zip(&bytes_sent)
            .map(|((a, &end), &b)| GridNodeReport {
                stats: a.stats().clone(),
                render_end_s: end,
                bytes_sent: b,
            })
            .collect(),
        host_s: [host1, host2],
    };
    Ok(GridOutcome {
        image,
        report,
        trace,
    })
}

/// A one-paragraph summary for the terminal.
pub fn summary(r: &GridReport) -> String {
    let mut s = format!(
        "grid cluster: {} node(s){}, {}^3 bricks, {} / {} / {}, {:?} clock\n\
         frame {:.4} s = render {:.4} s + composite {:.4} s; phase-2 bytes {} (codec ratio {:.3})\n",
        r.n_nodes,
        if r.master { " + master" } else { "" },
        r.subvolumes,
        r.compositor,
        r.codec,
        r.network,
        r.clock,
        r.frame_s,
        r.render_s,
        r.composite_s,
        r.bytes_total,
        r.codec_ratio
    );
    for n in &r.nodes {
        s.push_str(&format!(
            "  rank {:>2}: bricks {:?} render {:.4} s (fill {:.4}, upload {:.4} for {} B) sent {} B\n",
            n.stats.rank,
            n.stats.bricks,
            n.render_end_s,
            n.stats.device.fill_s,
            n.stats.device.upload_s,
            n.stats.device.uploaded_bytes,
            n.bytes_sent
        ));
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::node::grid::tests::{seam_input, OBLIQUE, PERSP};

    fn cfg(compositor: &str, codec: &str, master: bool) -> GridConfig {
        GridConfig {
            nodes: 4,
            subvolumes: 2,
            master,
            placement: BrickPlacement::RoundRobin,
            compositor: compositor.into(),
            codec: codec.into(),
            slice: Slice3dOptions {
                ert: 1.0,
                ..Default::default()
            },
            renderer: crate::node::grid::render::slice3d_renderer(),
            clock: ClockKind::Virtual,
            network: NetworkModel::from_name("100base").unwrap(),
            network_name: "100base".into(),
            profile: CostProfile::named("radeon9700").unwrap(),
            profile_name: "radeon9700".into(),
            record_trace: false,
        }
    }

    #[test]
    fn every_strategy_and_codec_gives_the_single_node_image() {
        for cam in [OBLIQUE, PERSP] {
            let inp = seam_input(cam, 48);
            let (one, _) = crate::render::slice3d::render(
                &inp,
                &Slice3dOptions {
                    ert: 1.0,
                    ..Default::default()
                },
            )
            .unwrap();
            let mut raw_bytes = None;
            for (comp, master) in [
                ("master", true),
                ("master", false),
                ("binary-swap", false),
                ("direct-send", false),
            ] {
                for codec in ["raw", "rle-paper", "sparse"] {
                    let out = run(&inp, &cfg(comp, codec, master)).unwrap();
                    let e = out.image.error_against(&one);
                    // Four layers at most along a ray at d = 2, plus the
                    // gathered piece's own rounding (binary swap, direct send).
                    assert!(e.max_abs <= 5.0 && e.rmse <= 0.5, "{comp} {codec}: {e}");
                    if comp == "master" && master {
                        if codec == "raw" {
                            raw_bytes = Some(out.report.bytes_total);
                            assert_eq!(out.report.codec_ratio, 1.0);
                        } else {
                            assert!(out.report.bytes_total < raw_bytes.unwrap(), "{codec}");
                        }
                    }
                    let again = run(&inp, &cfg(comp, codec, master)).unwrap();
                    assert_eq!(again.image.pixels, out.image.pixels, "deterministic");
                    assert_eq!(again.report.frame_s, out.report.frame_s, "deterministic");
                }
            }
        }
    }

    #[test]
    fn bad_combinations_are_refused() {
        let inp = seam_input(OBLIQUE, 16);
        let mut c = cfg("master", "rle", true);
        assert!(run(&inp, &c).unwrap_err().to_string().contains("rle-paper"));
        c.codec = "raw".into();
        c.subvolumes = 1;
        assert!(run(&inp, &c)
            .unwrap_err()
            .to_string()
            .contains("bricks for 4 nodes"));
        c.subvolumes = 2;
        c.profile = CostProfile::named("pentium4").unwrap();
        assert!(run(&inp, &c)
            .unwrap_err()
            .to_string()
            .contains("no grid costs"));
    }
}
