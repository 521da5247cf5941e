//! The coordinator's side of a grid frame: [`GridRemote::run`] sends each
//! worker its set-up (and its bricks' samples when not cached), then either
//! collects the layers and composites at the master, or lets the workers
//! composite among themselves and collects the final pixels and the ranks'
//! logs.

use std::time::{Duration, Instant};

use super::{GridMeasured, GridMsg, GridRemote};
use crate::cluster::grid::{finish, prepare, report, GridConfig, GridOutcome, Phase1Out, Prepared};
use crate::cluster::remote::coordinator::{busy_wait, hand_setup, join_setups};
use crate::cluster::remote::grid_wire::{
    encode_bricks, wire_planes, GridSetup, WireBrick, WireSlice,
};
use crate::cluster::remote::guard::take_blame;
use crate::cluster::remote::phase2::{decode_message, RankLog};
use crate::cluster::remote::reassign::{endings_wait, lost_on, with_reassign};
use crate::cluster::remote::session::{new_session_id, sha256, Session};
use crate::cluster::ClockKind;
use crate::compositor::layer::exec as layer_exec;
use crate::compositor::layer::rank::LayerGather;
use crate::compositor::region::screen;
use crate::compositor::{Payload, RoundKind, Schedule};
use crate::data::Volume;
use crate::net::tcp::{self, Link, TcpOptions, TcpTransport};
use crate::net::{Codec, MessageKind, NodeId, RemoteTransport, SimTrace, Transport};
use crate::node::grid::GridNodeStats;
use crate::render::VolumeInput;

impl GridRemote {
    /// One frame of `input` on the workers. With a master (`cfg.master`)
    /// the workers send their layers to the coordinator, which composites
    /// (the paper); without, they run the compositor's schedule among
    /// themselves ([`crate::cluster::remote::phase2::run_partial`]) and only the final
    /// pixels reach the coordinator. With [`GridRemote::reassign`], the
    /// bricks of workers lost at any phase go to the survivors and the
    /// frame runs again on them ([`with_reassign`]).
    pub fn run(
        &self,
        input: &VolumeInput,
        cfg: &GridConfig,
    ) -> anyhow::Result<(GridOutcome, GridMeasured)> {
        anyhow::ensure!(
            !cfg.master || cfg.compositor == crate::compositor::strategy::Compositing::Master,
            "--master composites every subimage at the master; it cannot be combined with \
             --compositor {}",
            cfg.compositor
        );
        anyhow::ensure!(
            self.workers.len() == cfg.nodes,
            "{} workers for --nodes {}",
            self.workers.len(),
            cfg.nodes
        );
        let mut cfg = cfg.clone();
        cfg.clock = ClockKind::Wall;
        let mut prep = prepare(input, &cfg)?;
        let parts = prep.parts.clone();
        let ((mut out, mut m), r) = with_reassign(
            cfg.nodes,
            parts,
            self.tcp.deadline,
            self.reassign,
            "bricks",
            |alive, parts| {
                let sub = GridRemote {
                    workers: alive.iter().map(|&k| self.workers[k].clone()).collect(),
                    ..self.clone()
                };
                let mut c = cfg.clone();
                c.nodes = alive.len();
                prep.parts = parts.to_vec();
                prep.total = c.nodes + prep.off;
                let wait = busy_wait(alive.len() < cfg.nodes, self.tcp.deadline);
                sub.run_prepared(input, &c, &prep, wait)
            },
        )?;
        m.reassigned = r;
        out.report.transport = Some(m.clone());
        Ok((out, m))
    }

    /// One attempt of a frame on these workers with `prep`'s placement.
    /// `busy_wait`: see [`hand_setup`].
    fn run_prepared(
        &self,
        input: &VolumeInput,
        cfg: &GridConfig,
        prep: &Prepared,
        busy_wait: Duration,
    ) -> anyhow::Result<(GridOutcome, GridMeasured)> {
        let p2p = !cfg.master;
        let codec = Codec::default();
        let rt = tcp::runtime()?;
        let scene_toml = input
            .scene
            .to_toml(&input.scene.data.path.to_string_lossy());
        let t_setup = Instant::now();
        // The coordinator's rank: one past every rank of the frame.
        let me = NodeId::from(prep.total);
        let slice = WireSlice::from(&cfg.slice);
        let session_id = new_session_id();
        let mut tasks = Vec::with_capacity(cfg.nodes);
        for k in 0..cfg.nodes {
            let rank = k + prep.off;
            let held = prep.held(rank);
            let vols: Vec<&Volume> = held.iter().map(|h| &*h.1).collect();
            let bytes = encode_bricks(&vols);
            let setup = GridSetup {
                rank: rank as u32,
                nodes: prep.total as u32,
                scene_toml: scene_toml.clone(),
                whole_dims: input.volume.dims,
                whole_spacing: input.volume.spacing,
                whole_origin: input.volume.origin,
                field: input.volume.field.clone(),
                range: input.range,
                planes: wire_planes(prep.planes),
                slice,
                renderer: cfg.renderer,
                codec: cfg.codec,
                profile: cfg.profile,
                bricks: held.iter().map(|h| WireBrick::new(&h.0, h.2)).collect(),
                bricks_sha256: sha256(&bytes),
                max_message_bytes: codec.max_message_bytes,
                texture_cache: cfg.texture_cache,
                peers: if p2p {
                    self.workers.clone()
                } else {
                    Vec::new()
                },
                compositor: cfg.compositor,
                bricks_total: prep.bricks.len() as u32,
                recv_timeout_s: self.recv_timeout.as_secs_f64(),
                session_id,
            };
            let addr = self.workers[k].clone();
            let token = self.token.clone();
            let opts = self.tcp;
            tasks.push(rt.spawn(async move {
                let name = format!("grid worker {k} ({addr})");
                let to = NodeId::from(rank);
                let msg = Session::Grid(Box::new(GridMsg::Setup(Box::new(setup))));
                let (s, sent) =
                    hand_setup(&addr, &name, &token, &opts, me, to, &msg, bytes, busy_wait).await?;
                let link = Link {
                    rank: to,
                    name,
                    stream: s,
                };
                Ok((link, sent, Instant::now()))
            }));
        }
        let mut m = GridMeasured {
            transport: self.transport.clone(),
            ..Default::default()
        };
        let mut links = Vec::new();
        let mut last_sent = t_setup;
        for (link, sent, t_sent) in join_setups(&rt, tasks, "a grid worker task", |k| {
            format!("grid worker {k} ({})", self.workers[k])
        })? {
            m.bricks_bytes_sent += sent;
            m.bricks_cached += usize::from(sent == 0);
            last_sent = last_sent.max(t_sent);
            links.push(link);
        }
        m.setup_s = last_sent.duration_since(t_setup).as_secs_f64();
        let opts = TcpOptions { codec, ..self.tcp };
        let t = TcpTransport::new(rt.clone(), me, prep.total + 1, links, opts)?;
        let mut phase = "rendering";
        let r = if p2p {
            self.collect_p2p(&t, input, cfg, prep, &mut m, last_sent, &mut phase)
        } else {
            self.collect_master(&t, input, cfg, prep, &mut m, last_sent)
        };
        let r = r.map_err(|e| {
            let wait = endings_wait(self.reassign, self.tcp.deadline);
            lost_on(&t, prep.off, cfg.nodes, wait, e, phase)
        });
        t.close(Duration::from_secs(2));
        Ok((r?, m))
    }

    /// With a master: every worker's layers over `t` (ranks `off..`), then
    /// the master's compositing here, with the same code as the other
    /// clocks ([`finish`]).
    fn collect_master(
        &self,
        t: &TcpTransport,
        input: &VolumeInput,
        cfg: &GridConfig,
        prep: &Prepared,
        m: &mut GridMeasured,
        t_sent: Instant,
    ) -> anyhow::Result<GridOutcome> {
        let codec = Codec::default();
        let (n, off) = (cfg.nodes, prep.off);
        for k in 0..n {
            t.set_essential(NodeId::from(k + off), true);
        }
        let lc = cfg.codec.build();
        let mut stats = vec![GridNodeStats::default(); prep.total];
        let mut layers = vec![Vec::new(); prep.total];
        let mut ends = vec![0.0; prep.total];
        let mut done = vec![false; n];
        let mut t_in = t_sent;
        while done.iter().any(|d| !d) {
            let e = t.recv_timeout(self.recv_timeout)?.ok_or_else(|| {
                anyhow::anyhow!(
                    "rendering: grid workers {:?} sent nothing within {:.0} s",
                    (0..n).filter(|&k| !done[k]).collect::<Vec<_>>(),
                    self.recv_timeout.as_secs_f64()
                )
            })?;
            let rank = e.from.index();
            let name = t.peer_name(e.from);
            anyhow::ensure!(
                (off..off + n).contains(&rank) && e.kind == MessageKind::Session,
                "rendering: a {} message from {name}, not a grid worker's result",
                e.kind
            );
            let k = rank - off;
            let r = match codec.decode::<Session>(&e.payload)? {
                Session::Grid(g) => match *g {
                    GridMsg::Result(r) if !done[k] => r,
                    other => anyhow::bail!("{name}: sent {other:?} instead of its layers"),
                },
                Session::Failed(why) => anyhow::bail!("{name}, rendering: {why}"),
                other => anyhow::bail!("{name}: sent {other:?} instead of its layers"),
            };
            t_in = t_in.max(Instant::now());
            m.result_payload_bytes += e.payload.len() as u64;
            m.layer_bytes += r.layers.len() as u64;
            anyhow::ensure!(
                r.stats.rank == rank,
                "{name} reported rank {} instead of {rank}",
                r.stats.rank
            );
            layers[rank] = layer_exec::decode(lc.as_ref(), &r.layers)
                .map_err(|e| anyhow::anyhow!("the layers of {name}: {e}"))?;
            ends[rank] = r.stats.host_s;
            stats[rank] = r.stats;
            done[k] = true;
            t.set_essential(e.from, false);
        }
        m.collect_s = t_in.saturating_duration_since(t_sent).as_secs_f64();
        stats[0].rank = 0;
        let p1 = Phase1Out {
            stats,
            layers,
            ends,
            host_s: m.setup_s + m.collect_s,
            trace: SimTrace::default(),
        };
        let t2 = Instant::now();
        let out = finish(input, cfg, prep, p1)?;
        m.composite_s = t2.elapsed().as_secs_f64();
        Ok(out)
    }
}

impl GridRemote {
    /// The coordinator's side of a frame composited worker to worker: each
    /// worker's stats, the gathered pixels (pieces, and the root's own as
    /// raw f32), each rank's log; then the report from the logs.
    #[allow(clippy::too_many_arguments)]
    fn collect_p2p(
        &self,
        t: &TcpTransport,
        input: &VolumeInput,
        cfg: &GridConfig,
        prep: &Prepared,
        m: &mut GridMeasured,
        t_sent: Instant,
        phase: &mut &'static str,
    ) -> anyhow::Result<GridOutcome> {
        let codec = Codec::default();
        let n = cfg.nodes;
        for k in 0..n {
            t.set_essential(NodeId::from(k), true);
        }
        let s = &input.scene;
        let sched = prep
            .strategy
            .schedule(prep.total, screen(s.image.width, s.image.height));
        sched.validate().map_err(|e| anyhow::anyhow!(e))?;
        let lc = cfg.codec.build();
        let mut gather = LayerGather::new(lc.as_ref(), sched.image);
        let mut stats: Vec<Option<GridNodeStats>> = vec![None; n];
        let mut logs: Vec<Option<RankLog>> = vec![None; n];
        let mut t_in = t_sent;
        let mut t2 = None;
        let mut t_last: Option<Instant> = None;
        while logs.iter().any(Option::is_none) {
            let e = t.recv_timeout(self.recv_timeout)?.ok_or_else(|| {
                anyhow::anyhow!(
                    "grid workers {:?} sent nothing within {:.0} s",
                    (0..n).filter(|&k| logs[k].is_none()).collect::<Vec<_>>(),
                    self.recv_timeout.as_secs_f64()
                )
            })?;
            let from = e.from.index();
            let name = t.peer_name(e.from);
            anyhow::ensure!(from < n, "a message from {name}, not a grid worker");
            match e.kind {
                MessageKind::Image => {
                    let (r, what, body) = decode_message(&e.payload)
                        .map_err(|why| anyhow::anyhow!("phase 2, gather: {name}: {why}"))?;
                    let ok = sched
                        .rounds
                        .get(r as usize)
                        .is_some_and(|x| x.kind == RoundKind::Gather)
                        && matches!(what, Payload::Pixels(_));
                    anyhow::ensure!(ok, "phase 2, gather: {name} sent a message for round {r}, not a gather of pixels");
                    let taken = if from == sched.root {
                        gather.take_handoff(what.rect(), body)
                    } else {
                        gather.take(what.rect(), body)
                    };
                    taken.map_err(|e| anyhow::anyhow!("phase 2, gather: {name}: {e}"))?;
                }
                MessageKind::Session => match codec.decode::<Session>(&e.payload)? {
                    Session::Grid(g) => match *g {
                        GridMsg::Result(r) if stats[from].is_none() => {
                            t_in = t_in.max(Instant::now());
                            anyhow::ensure!(
                                r.stats.rank == from,
                                "{name} reported rank {} instead of {from}",
                                r.stats.rank
                            );
                            t2.get_or_insert_with(Instant::now);
                            t_last = Some(Instant::now());
                            stats[from] = Some(r.stats);
                            if stats.iter().all(Option::is_some) {
                                *phase = "phase 2";
                            }
                        }
                        GridMsg::Done(log) if stats[from].is_some() && logs[from].is_none() => {
                            anyhow::ensure!(
                                log.merged.len() == sched.rounds.len()
                                    && log
                                        .sent
                                        .iter()
                                        .all(|s| (s.round as usize) < sched.rounds.len()
                                            && (s.to as usize) < n),
                                "{name} sent a phase-2 log that does not fit the schedule"
                            );
                            t.set_essential(e.from, false);
                            logs[from] = Some(*log);
                        }
                        other => anyhow::bail!("{name} sent {other:?} out of turn"),
                    },
                    Session::Failed(why) => anyhow::bail!("{name}: {why}"),
                    Session::Lost(r) => {
                        let (who, why) = take_blame(t, e.from, &r);
                        anyhow::bail!("{who} {why}")
                    }
                    other => anyhow::bail!("{name} sent {other:?} out of turn"),
                },
                k => anyhow::bail!("{name} sent a {k:?} message to the coordinator"),
            }
        }
        m.collect_s = t_in.saturating_duration_since(t_sent).as_secs_f64();
        let t2 = t2.unwrap_or_else(Instant::now);
        let stats: Vec<GridNodeStats> = stats.into_iter().map(Option::unwrap_or_default).collect();
        let logs: Vec<RankLog> = logs.into_iter().map(Option::unwrap_or_default).collect();
        let rounds = layer_rounds(&sched, &logs);
        m.phase2_ranks = logs.iter().map(|l| (l.seconds, l.cpu_s)).collect();
        m.layer_bytes = rounds
            .iter()
            .flat_map(|r| &r.messages)
            .map(|x| x.bytes)
            .sum();
        let p1 = Phase1Out {
            ends: stats.iter().map(|s| s.host_s).collect(),
            stats,
            layers: Vec::new(),
            host_s: m.setup_s + m.collect_s,
            trace: SimTrace::default(),
        };
        let bg = s.image.background.map(|x| x as f32);
        let out = report(input, cfg, prep, p1, gather.image(bg), rounds, t2)?;
        m.composite_s = t2.elapsed().as_secs_f64();
        m.phase2_after_renders_s = t_last.map_or(0.0, |t| t.elapsed().as_secs_f64());
        Ok(out)
    }
}

/// The rounds of the in-process executor ([`layer_exec::LayerRound`]) from
/// the ranks' logs: the same messages in the same order (by sender, each
/// sender's in schedule order), blends and early merges.
fn layer_rounds(sched: &Schedule, logs: &[RankLog]) -> Vec<layer_exec::LayerRound> {
    let n = sched.nodes;
    sched
        .rounds
        .iter()
        .enumerate()
        .map(|(r, round)| layer_exec::LayerRound {
            label: round.label.clone(),
            composite: round.kind == RoundKind::Composite,
            blended: logs
                .iter()
                .map(|l| match l.composite {
                    Some((cr, px, _)) if cr as usize == r => px,
                    _ => 0,
                })
                .collect(),
            merged: (0..n).map(|k| logs[k].merged[r].blended).collect(),
            messages: logs
                .iter()
                .enumerate()
                .flat_map(|(k, l)| {
                    l.sent
                        .iter()
                        .filter(move |s| s.round as usize == r)
                        .map(move |s| layer_exec::LayerMessage {
                            from: k,
                            to: s.to as usize,
                            bytes: s.bytes,
                            raw_bytes: s.raw_bytes,
                            pixels: s.pixels,
                        })
                })
                .collect(),
        })
        .collect()
}
