//! A cluster of workers that stays up between frames ([`LiveCluster`]):
//! the coordinator connects to its workers once, the workers join the mesh
//! of their peers once and keep their cells (decoded) or pieces (read);
//! each later frame sends every worker only its next set-up (camera,
//! transfer function, options) over the same links, then runs as any frame
//! ([`super::drive`]). The session ends with `End` ([`LiveCluster::end`],
//! also on drop).
//!
//! Losses: with `--on-failure reassign`, a frame that loses workers (at
//! any phase, or between frames) closes the links, hands the lost
//! workers' shares to the survivors ([`super::reassign`]) and runs again on
//! a session of the survivors; the later frames keep the survivors and
//! their shares. Without it the frame's error names the lost worker.

use std::time::{Duration, Instant};

use super::coordinator::{busy_wait, Coordinator};
use super::drive::{cell_setups, drive, part_cells, piece_setups, DriveOptions};
use super::measured::Measured;
use super::pieces::PieceSet;
use super::reassign::{with_reassign, LostWorkers};
use super::session::{Session, WorkerSetup};
use crate::cluster::{ClockKind, ClusterConfig, ClusterOutcome, FrameData};
use crate::net::tcp::TcpTransport;
use crate::net::{Codec, MessageKind, NodeId, RemoteTransport, Transport};
use crate::node::Placement;
use crate::render::RenderInput;
use crate::scene::Scene;

/// Longest wait for the workers' `Ready` when they read their own pieces.
const PIECES_READY_WAIT: Duration = Duration::from_secs(600);

/// What a frame renders.
#[derive(Clone, Copy)]
pub enum Work<'a> {
    /// A mesh the coordinator holds: each worker gets the cells of its
    /// placement part (sent once, cached by hash).
    /// `key` names the data state (the mesh and field: a series' time
    /// step): the parts' encoded cells are kept for the frames that share
    /// it.
    Cells(&'a RenderInput, u64),
    /// A `.pvtu` whose workers read their own pieces, seen through a scene.
    Pieces(&'a PieceSet, &'a Scene),
}

impl Work<'_> {
    fn what(&self) -> &'static str {
        match self {
            Work::Cells(..) => "cells",
            Work::Pieces(..) => "pieces",
        }
    }
}

/// The session's links: the transport, which worker each rank is, and
/// the id every set-up of the session carries.
struct Links {
    t: TcpTransport,
    ranks: Vec<usize>,
    session_id: [u8; 16],
}

/// See the module docs.
pub struct LiveCluster {
    c: Coordinator,
    links: Option<Links>,
    /// The workers still in the session (indices into `c.workers`).
    alive: Vec<usize>,
    /// After a loss: the survivors' shares, by rank (kept for the frames
    /// that follow).
    parts: Option<Vec<Vec<u32>>>,
    /// The data state's key, the parts and their encoded cells (with
    /// their hashes), kept while frames share them.
    encoded: Option<EncodedParts>,
}

/// See [`LiveCluster::encoded`].
type EncodedParts = (u64, Vec<Vec<u32>>, Vec<(Vec<u8>, [u8; 32])>);

impl LiveCluster {
    /// A session on `c`'s workers; nothing is connected before the first
    /// frame.
    pub fn new(c: Coordinator) -> LiveCluster {
        let alive = (0..c.workers.len()).collect();
        LiveCluster {
            c,
            links: None,
            alive,
            parts: None,
            encoded: None,
        }
    }

    /// The workers still in the session (indices into the coordinator's
    /// list; fewer than at the start after a reassigned loss).
    pub fn alive(&self) -> &[usize] {
        &self.alive
    }

    /// One frame on the session's workers (connecting them on the first).
    pub fn frame(
        &mut self,
        work: Work<'_>,
        cfg: &ClusterConfig,
    ) -> anyhow::Result<(ClusterOutcome, Measured)> {
        let n = self.alive.len();
        anyhow::ensure!(n > 0, "the session has no workers left");
        let mut cfg = cfg.clone();
        cfg.phase1.clock = ClockKind::Wall;
        cfg.phase1.nodes = n;
        let parts = match (&self.parts, work) {
            (Some(p), _) => p.clone(),
            // A placement that does not follow the camera is the same for
            // every frame of a data state.
            (None, Work::Cells(input, key)) => match &self.encoded {
                Some((k, parts, _))
                    if *k == key
                        && parts.len() == n
                        && cfg.placement != crate::node::PlacementMethod::RcbView =>
                {
                    parts.clone()
                }
                _ => crate::cluster::place(input, &cfg).parts,
            },
            (None, Work::Pieces(p, _)) => p.parts(n),
        };
        let deadline = self.c.tcp.deadline;
        let alive0 = self.alive.clone();
        let mut last: Vec<usize> = (0..n).collect();
        let ((out, mut m), r) = with_reassign(
            n,
            parts,
            deadline,
            self.c.reassign,
            work.what(),
            |alive, parts| {
                last = alive.to_vec();
                let ranks: Vec<usize> = alive.iter().map(|&i| alive0[i]).collect();
                let mut cfg = cfg.clone();
                cfg.phase1.nodes = ranks.len();
                let wait = busy_wait(ranks.len() < n, deadline);
                self.attempt(&ranks, work, &cfg, parts, wait)
            },
        )?;
        if let Some(r) = &r {
            self.alive = last.iter().map(|&i| alive0[i]).collect();
            self.parts = Some(r.parts.clone());
        }
        m.reassigned = r;
        Ok((out, m))
    }

    /// One attempt of a frame on the workers `ranks` with shares `parts`:
    /// over the session's links when they join exactly these workers, else
    /// on new links. A failed attempt closes the links.
    fn attempt(
        &mut self,
        ranks: &[usize],
        work: Work<'_>,
        cfg: &ClusterConfig,
        parts: &[Vec<u32>],
        busy_wait: Duration,
    ) -> anyhow::Result<(ClusterOutcome, Measured)> {
        let t_setup = Instant::now();
        let n = ranks.len();
        if self.links.as_ref().is_some_and(|l| l.ranks != ranks) {
            self.close(Duration::from_secs(2));
        }
        let addrs: Vec<String> = ranks.iter().map(|&k| self.c.workers[k].clone()).collect();
        let codec = Codec::default();
        let (mut setups, data) = match work {
            Work::Cells(input, key) => {
                let p = Placement {
                    parts: parts.to_vec(),
                };
                let kept = self
                    .encoded
                    .as_ref()
                    .is_some_and(|(k, parts, _)| *k == key && *parts == p.parts);
                if !kept {
                    self.encoded = Some((key, p.parts.clone(), part_cells(input, &p)));
                }
                let (_, _, cells) = self.encoded.as_ref().expect("encoded above");
                let s = cell_setups(input, cfg, &p, cells, &addrs, codec, self.c.recv_timeout);
                (s, FrameData::Mesh(input))
            }
            Work::Pieces(pieces, scene) => {
                let depth_range = pieces.depth_range(scene)?;
                let s = piece_setups(
                    pieces,
                    scene,
                    depth_range,
                    cfg,
                    parts,
                    &addrs,
                    codec,
                    self.c.recv_timeout,
                );
                let data = FrameData::Pieces {
                    scene,
                    cells: 0,
                    depth_range,
                };
                (s, data)
            }
        };
        let mut measured = Measured::default();
        if let Some(l) = &self.links {
            for (s, _) in &mut setups {
                s.session_id = l.session_id;
            }
            let failed = self
                .next_setups(&l.t, setups, &mut measured)
                .err()
                .map(|e| self.c.lost_workers(&l.t, n, e, "set-up"));
            if let Some(e) = failed {
                self.close(Duration::from_secs(2));
                return Err(e);
            }
        } else {
            let session_id = setups.first().map(|s| s.0.session_id).unwrap_or_default();
            let t = self.c.connect(ranks, setups, busy_wait, &mut measured)?;
            self.links = Some(Links {
                t,
                ranks: ranks.to_vec(),
                session_id,
            });
        }
        let l = self.links.as_ref().expect("connected above");
        let d = DriveOptions {
            // Workers that read their pieces take the time that needs
            // (their links stay up: a death is still seen at once).
            ready_wait: if matches!(work, Work::Pieces(..)) {
                PIECES_READY_WAIT
            } else {
                self.c.tcp.handshake_timeout * 4 + Duration::from_secs(10)
            },
            recv_timeout: self.c.recv_timeout,
        };
        let c = &self.c;
        let r = drive(&l.t, d, data, cfg, t_setup, measured, |t, e, phase| {
            c.lost_workers(t, n, e, phase)
        });
        if r.is_err() {
            self.close(Duration::from_secs(2));
        }
        r
    }

    /// A later frame's set-ups over the session's links: each worker's
    /// `Setup`, its `Need` answer (within the heartbeat deadline) and, if
    /// it asks, its cells. A link that ended between frames is a loss.
    fn next_setups(
        &self,
        t: &TcpTransport,
        setups: Vec<(WorkerSetup, Vec<u8>)>,
        measured: &mut Measured,
    ) -> anyhow::Result<()> {
        let n = setups.len();
        let codec = Codec::default();
        let ended: Vec<usize> = t
            .link_endings(Duration::ZERO)
            .iter()
            .take(n)
            .enumerate()
            .filter(|(_, e)| e.is_some())
            .map(|(k, _)| k)
            .collect();
        if !ended.is_empty() {
            let names: Vec<String> = ended
                .iter()
                .map(|&k| t.peer_name(NodeId::from(k)))
                .collect();
            return Err(anyhow::anyhow!(
                "set-up: {} left the session between frames",
                names.join(", ")
            )
            .context(LostWorkers {
                ranks: ended,
                names,
                phase: "set-up".into(),
            }));
        }
        let mut cells = Vec::with_capacity(n);
        for (k, (setup, c)) in setups.into_iter().enumerate() {
            let to = NodeId::from(k);
            t.set_essential(to, true);
            t.send(
                to,
                MessageKind::Session,
                codec.encode(&Session::Setup(Box::new(setup)))?,
            )?;
            cells.push(Some(c));
        }
        let mut answered = vec![false; n];
        let wait = self.c.tcp.deadline;
        let until = Instant::now() + wait;
        while answered.iter().any(|a| !a) {
            let left = until.saturating_duration_since(Instant::now());
            let e = t.recv_timeout(left)?.ok_or_else(|| {
                let missing: Vec<usize> = (0..n).filter(|&k| !answered[k]).collect();
                anyhow::anyhow!("set-up: workers {missing:?} did not answer within {wait:?}")
            })?;
            let k = e.from.index();
            if e.kind != MessageKind::Session {
                continue;
            }
            match codec.decode::<Session>(&e.payload) {
                Ok(Session::Need(need)) if k < n && !answered[k] => {
                    answered[k] = true;
                    let c = cells[k].take().unwrap_or_default();
                    if need {
                        measured.cells_bytes_sent += c.len() as u64;
                        t.send(
                            e.from,
                            MessageKind::Session,
                            codec.encode(&Session::Cells(c))?,
                        )?;
                    } else {
                        measured.cells_cached += 1;
                    }
                }
                Ok(Session::Failed(why)) => {
                    anyhow::bail!("set-up: {} failed: {why}", t.peer_name(e.from))
                }
                _ => anyhow::bail!(
                    "set-up: {} sent a session message instead of its cache answer",
                    t.peer_name(e.from)
                ),
            }
        }
        Ok(())
    }

    /// Closes the links without `End` (after a failure: the workers give
    /// the frame up and serve the next session).
    fn close(&mut self, wait: Duration) {
        if let Some(l) = self.links.take() {
            l.t.close(wait);
        }
    }

    /// Ends the session: `End` to every worker, then the links close.
    pub fn end(&mut self) {
        if let Some(l) = self.links.take() {
            if let Ok(b) = Codec::default().encode(&Session::End) {
                for k in 0..l.ranks.len() {
                    let _ = l.t.send(NodeId::from(k), MessageKind::Session, b.clone());
                }
            }
            for k in 0..l.ranks.len() {
                l.t.set_essential(NodeId::from(k), false);
            }
            l.t.close(Duration::from_secs(10));
        }
    }
}

impl Drop for LiveCluster {
    fn drop(&mut self) {
        self.end();
    }
}
