//! Phase 2 worker to worker: each rank runs its part of the compositor's
//! [`Schedule`] over the transport it already has for phase 1, and only the
//! final pixels reach the coordinator. One executor ([`run_partial`]) for
//! both partial kinds through [`RankPartial`]: segment lists (mesh scenes,
//! [`ListRank`]) and visibility-ranked RGBA layers (grid scenes,
//! [`crate::compositor::layer::rank::LayerRank`]; a lists round's payload is
//! then "my layers cropped to the rectangle", and the root hands its own
//! piece over as raw f32).
//!
//! The steps are the in-process executor's ([`NodeState`]: encode a
//! payload, keep a region, merge what arrives, composite), so the image is
//! the same bit for bit. Per round `r` of the schedule, rank `k`:
//!
//! ```text
//! Lists      encode its sends (from the lists it holds), keep keep[k], send,
//!            then wait for every message of round r addressed to it and merge
//!            them in sender order
//! Composite  its lists become pixels
//! Gather     send its pixels to the coordinator (the root's own pixels too:
//!            the coordinator stands in for the schedule's root)
//! ```
//!
//! A message is `round: u32 | kind: u8 (0 lists, 1 pixels) | x0 y0 x1 y1: u32`
//! (21 bytes, little endian, [`HEADER_BYTES`]) followed by the codec's bytes;
//! `MessageKind::Segments` for lists, `MessageKind::Image` for pixels, so the
//! transport counts them per kind. A message of a later round that arrives
//! early waits in a buffer. Every wait has a deadline; a lost peer is the
//! transport's error, which names it.
//!
//! Each rank logs what it sent and merged ([`RankLog`]); the coordinator
//! sums the logs into the same [`CompositeStats`] and network replay as the
//! in-process phase 2 ([`crate::cluster::phase2`]).

use std::collections::BTreeMap;
use std::time::{Duration, Instant};

use serde::{Deserialize, Serialize};

use crate::base::Rect;
use crate::compositor::codec::Codec as ListCodec;
use crate::compositor::exec::{assemble, NodeState};
use crate::compositor::partial::{ListRank, RankPartial};
use crate::compositor::{
    CompositeStats, ExecOptions, Message, Payload, RegionLists, RoundKind, RoundStats, Schedule,
};
use crate::image::Image;
use crate::net::{Envelope, MessageKind, NodeId, Transport};

/// The executor options of phase 2 for a scene, as
/// [`crate::cluster::finish`] sets them.
pub fn exec_options(partial: bool, scene: &crate::scene::Scene) -> ExecOptions {
    ExecOptions {
        partial,
        background: scene.image.background.map(|c| c as f32),
        ..Default::default()
    }
}

/// Bytes of a phase-2 message header (see the module docs).
pub const HEADER_BYTES: usize = 21;

/// `header | body` of a phase-2 message.
pub fn encode_message(round: u32, what: Payload, body: &[u8]) -> Vec<u8> {
    let mut v = Vec::with_capacity(HEADER_BYTES + body.len());
    v.extend_from_slice(&round.to_le_bytes());
    let (kind, r) = match what {
        Payload::Lists(r) => (0u8, r),
        Payload::Pixels(r) => (1u8, r),
    };
    v.push(kind);
    for c in [r.x0, r.y0, r.x1, r.y1] {
        v.extend_from_slice(&c.to_le_bytes());
    }
    v.extend_from_slice(body);
    v
}

/// Splits a phase-2 message into round, payload and body.
pub fn decode_message(bytes: &[u8]) -> Result<(u32, Payload, &[u8]), String> {
    if bytes.len() < HEADER_BYTES {
        return Err(format!(
            "a phase-2 message of {} bytes, shorter than its {HEADER_BYTES}-byte header",
            bytes.len()
        ));
    }
    let u = |i: usize| u32::from_le_bytes(bytes[i..i + 4].try_into().expect("4 bytes"));
    let rect = Rect {
        x0: u(5),
        y0: u(9),
        x1: u(13),
        y1: u(17),
    };
    if rect.x0 > rect.x1 || rect.y0 > rect.y1 {
        return Err(format!(
            "a phase-2 message for the inverted rectangle {rect:?}"
        ));
    }
    let what = match bytes[4] {
        0 => Payload::Lists(rect),
        1 => Payload::Pixels(rect),
        k => return Err(format!("a phase-2 message of unknown payload kind {k}")),
    };
    Ok((u(0), what, &bytes[HEADER_BYTES..]))
}

fn to_arr(r: Rect) -> [u32; 4] {
    [r.x0, r.y0, r.x1, r.y1]
}

fn from_arr(a: [u32; 4]) -> Rect {
    Rect {
        x0: a[0],
        y0: a[1],
        x1: a[2],
        y1: a[3],
    }
}

/// One message a rank sent in the schedule.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct SentLog {
    /// Round index.
    pub round: u32,
    /// Receiving rank (the schedule's, i.e. the root for gathers).
    pub to: u32,
    /// Lists (`false`: pixels).
    pub lists: bool,
    /// The rectangle carried.
    pub rect: [u32; 4],
    /// Codec bytes (header excluded).
    pub bytes: u64,
    /// Bytes under the raw codec.
    pub raw_bytes: u64,
    /// Pixels carried (layers; 0 for lists).
    #[serde(default)]
    pub pixels: u64,
}

impl SentLog {
    /// What it carried.
    pub fn what(&self) -> Payload {
        if self.lists {
            Payload::Lists(from_arr(self.rect))
        } else {
            Payload::Pixels(from_arr(self.rect))
        }
    }
}

/// Counters of what one rank merged in one round.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct MergeLog {
    /// Segments received.
    pub segments: u64,
    /// Pixel lists merged.
    pub merges: u64,
    /// Entries removed by partial composition.
    pub segments_merged: u64,
    /// Pixels blended merging adjacent layers early (layers, radix-k).
    #[serde(default)]
    pub blended: u64,
}

/// What one rank did in phase 2.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct RankLog {
    /// The messages of the schedule it sent.
    pub sent: Vec<SentLog>,
    /// Per round, what it merged.
    pub merged: Vec<MergeLog>,
    /// Its composite round: `(round, pixels, entries)` it held (list
    /// entries, or layers).
    pub composite: Option<(u32, u64, u64)>,
    /// Codec bytes of its own pixels handed to the coordinator (the
    /// schedule's root only; not a message of the schedule).
    pub handoff_bytes: u64,
    /// Messages of that hand-off.
    pub handoff_messages: u64,
    /// Wall seconds from its start of phase 2 to its last send.
    pub seconds: f64,
    /// Thread CPU seconds of the same span (merging, compositing, codecs,
    /// handing bytes to the transport; [`crate::net::cpu`]).
    #[serde(default)]
    pub cpu_s: f64,
    /// Wall seconds of the same span spent encoding its messages and its
    /// hand-off with the codec (IceT's compress time).
    #[serde(default)]
    pub compress_s: f64,
}

/// Runs rank `me`'s part of `schedule` over `t`, starting from `lists`;
/// pixels go to rank `coordinator`. `received` holds messages that arrived
/// before the rank started (peers may start first). Messages of other kinds
/// (late phase-1 traffic) are dropped. Returns the rank's log.
#[allow(clippy::too_many_arguments)]
pub fn run_rank<T: Transport>(
    t: &T,
    me: usize,
    coordinator: NodeId,
    schedule: &Schedule,
    codec: &dyn ListCodec,
    opts: &ExecOptions,
    lists: RegionLists,
    received: Vec<Envelope>,
    timeout: Duration,
) -> anyhow::Result<RankLog> {
    let mut state = ListRank {
        state: NodeState::new(lists),
        codec,
        opts,
    };
    run_partial(t, me, coordinator, schedule, &mut state, received, timeout)
}

/// Runs rank `me`'s part of `schedule` over `t` for either partial kind
/// (`state`: [`ListRank`] or [`crate::compositor::layer::rank::LayerRank`]);
/// gathered pixels and the root's hand-off go to rank `coordinator`.
/// `received` holds messages that arrived before the rank started. Every
/// lists round merges (even with nothing received: radix-k's early merges
/// of layers). Returns the rank's log.
pub fn run_partial<T: Transport, P: RankPartial>(
    t: &T,
    me: usize,
    coordinator: NodeId,
    schedule: &Schedule,
    state: &mut P,
    received: Vec<Envelope>,
    timeout: Duration,
) -> anyhow::Result<RankLog> {
    let t0 = Instant::now();
    let cpu0 = crate::net::cpu::thread_cpu_s();
    let mut log = RankLog {
        merged: vec![MergeLog::default(); schedule.rounds.len()],
        ..Default::default()
    };
    let mut early: BTreeMap<u32, Vec<Message>> = BTreeMap::new();
    for e in received {
        if let Some((r, m)) = phase2_message(e, me, schedule)? {
            early.entry(r).or_default().push(m);
        }
    }
    for (r, round) in schedule.rounds.iter().enumerate() {
        let r32 = r as u32;
        match round.kind {
            RoundKind::Lists => {
                let mut out = Vec::new();
                let tc = Instant::now();
                for e in round.sends.iter().filter(|e| e.from == me) {
                    let enc = state.encode(e.what)?.ok_or_else(|| {
                        anyhow::anyhow!("phase 2, round {r}: rank {me} holds nothing to send")
                    })?;
                    out.push((e.to, e.what, enc));
                }
                log.compress_s += tc.elapsed().as_secs_f64();
                state.keep(round.keep.get(me).copied().flatten());
                for (to, what, enc) in out {
                    log.sent.push(SentLog {
                        round: r32,
                        to: to as u32,
                        lists: true,
                        rect: to_arr(what.rect()),
                        bytes: enc.bytes.len() as u64,
                        raw_bytes: enc.raw_bytes,
                        pixels: enc.pixels,
                    });
                    t.send(
                        NodeId::from(to),
                        MessageKind::Segments,
                        encode_message(r32, what, &enc.bytes),
                    )?;
                }
                let want = round.sends.iter().filter(|e| e.to == me).count();
                let mut got = early.remove(&r32).unwrap_or_default();
                while got.len() < want {
                    let m = next_message(t, me, schedule, timeout, r)?;
                    let (mr, m) = m;
                    if mr == r32 {
                        got.push(m);
                    } else {
                        early.entry(mr).or_default().push(m);
                    }
                }
                anyhow::ensure!(
                    got.len() == want,
                    "phase 2, round {r} ({}): {} messages for rank {me}, the schedule has {want}",
                    round.label,
                    got.len()
                );
                got.sort_by_key(|m| m.from);
                let c = state.merge(&got)?;
                log.merged[r] = MergeLog {
                    segments: c.segments,
                    merges: c.merges,
                    segments_merged: c.segments_merged,
                    blended: c.blended,
                };
            }
            RoundKind::Composite => {
                if let Some((px, entries)) = state.composite()? {
                    log.composite = Some((r32, px, entries));
                }
            }
            RoundKind::Gather => {
                for e in round.sends.iter().filter(|e| e.from == me) {
                    let tc = Instant::now();
                    let enc = state.encode(e.what)?;
                    log.compress_s += tc.elapsed().as_secs_f64();
                    let Some(enc) = enc else {
                        continue;
                    };
                    log.sent.push(SentLog {
                        round: r32,
                        to: e.to as u32,
                        lists: false,
                        rect: to_arr(e.what.rect()),
                        bytes: enc.bytes.len() as u64,
                        raw_bytes: enc.raw_bytes,
                        pixels: enc.pixels,
                    });
                    t.send(
                        coordinator,
                        MessageKind::Image,
                        encode_message(r32, e.what, &enc.bytes),
                    )?;
                }
                if me == schedule.root {
                    let tc = Instant::now();
                    let handoff = state.handoff();
                    log.compress_s += tc.elapsed().as_secs_f64();
                    for (rect, bytes) in handoff {
                        log.handoff_bytes += bytes.len() as u64;
                        log.handoff_messages += 1;
                        t.send(
                            coordinator,
                            MessageKind::Image,
                            encode_message(r32, Payload::Pixels(rect), &bytes),
                        )?;
                    }
                }
            }
        }
    }
    anyhow::ensure!(
        early.is_empty(),
        "phase 2: rank {me} got messages for rounds {:?} that the schedule does not send it",
        early.keys().collect::<Vec<_>>()
    );
    log.seconds = t0.elapsed().as_secs_f64();
    log.cpu_s = crate::net::cpu::thread_cpu_s() - cpu0;
    Ok(log)
}

/// The next phase-2 message for rank `me`, as `(round, message)`; other
/// kinds are dropped.
fn next_message<T: Transport>(
    t: &T,
    me: usize,
    schedule: &Schedule,
    timeout: Duration,
    r: usize,
) -> anyhow::Result<(u32, Message)> {
    loop {
        let e = t.recv_timeout(timeout)?.ok_or_else(|| {
            anyhow::anyhow!(
                "phase 2, round {r}: rank {me} received nothing within {:.0} s",
                timeout.as_secs_f64()
            )
        })?;
        if let Some(m) = phase2_message(e, me, schedule)? {
            return Ok(m);
        }
    }
}

/// A received envelope as `(round, message)` if it is a phase-2 message
/// (`Segments`); `None` for other kinds.
fn phase2_message(
    e: Envelope,
    me: usize,
    schedule: &Schedule,
) -> anyhow::Result<Option<(u32, Message)>> {
    if e.kind != MessageKind::Segments {
        return Ok(None);
    }
    let from = e.from.index();
    let (mr, what, body) = decode_message(&e.payload)
        .map_err(|why| anyhow::anyhow!("phase 2: from rank {from}: {why}"))?;
    anyhow::ensure!(
        (mr as usize) < schedule.rounds.len() && from < schedule.nodes,
        "phase 2: rank {from} sent a message for round {mr}, which is not in the schedule"
    );
    Ok(Some((
        mr,
        Message {
            from,
            to: me,
            what,
            bytes: body.to_vec(),
            raw_bytes: 0,
        },
    )))
}

/// The coordinator's side: the gathered pixels.
pub struct Gather<'a> {
    schedule: &'a Schedule,
    codec: &'a dyn ListCodec,
    opts: ExecOptions,
    root: NodeState,
    stats: RoundStats,
}

impl<'a> Gather<'a> {
    /// Waits for the pixels of `schedule` (decoded with `codec` under `opts`).
    pub fn new(schedule: &'a Schedule, codec: &'a dyn ListCodec, opts: ExecOptions) -> Self {
        Gather {
            schedule,
            codec,
            opts,
            root: NodeState::default(),
            stats: RoundStats::default(),
        }
    }

    /// Takes one `Image` message from rank `from`.
    pub fn take(&mut self, from: usize, payload: &[u8]) -> anyhow::Result<()> {
        let (r, what, body) = decode_message(payload)
            .map_err(|why| anyhow::anyhow!("phase 2, gather: from worker {from}: {why}"))?;
        let ok = self
            .schedule
            .rounds
            .get(r as usize)
            .is_some_and(|x| x.kind == RoundKind::Gather)
            && matches!(what, Payload::Pixels(_));
        anyhow::ensure!(
            ok,
            "phase 2, gather: worker {from} sent a message for round {r}, not a gather of pixels"
        );
        let m = Message {
            from,
            to: self.schedule.root,
            what,
            bytes: body.to_vec(),
            raw_bytes: 0,
        };
        self.root
            .apply(self.codec, &self.opts, &m, &mut self.stats)
            .map_err(|e| anyhow::anyhow!("phase 2, gather: from worker {from}: {e}"))
    }

    /// The image, once every pixel arrived.
    pub fn image(&self) -> anyhow::Result<Image> {
        assemble(self.schedule.image, &self.root.pixels, self.opts.background)
            .map_err(|e| anyhow::anyhow!("phase 2, gather: {e}"))
    }
}

/// The compositor's counters of a run, from every rank's log: the same
/// numbers [`crate::compositor::LocalRun`] counts in-process.
pub fn stats_from_logs(
    schedule: &Schedule,
    strategy: &str,
    codec: &str,
    logs: &[RankLog],
) -> CompositeStats {
    let mut rounds: Vec<RoundStats> = schedule
        .rounds
        .iter()
        .map(|r| RoundStats {
            label: r.label.clone(),
            ..Default::default()
        })
        .collect();
    for l in logs {
        for s in &l.sent {
            let st = &mut rounds[s.round as usize];
            st.messages += 1;
            st.bytes += s.bytes;
            st.bytes_uncompressed += s.raw_bytes;
        }
        for (st, m) in rounds.iter_mut().zip(&l.merged) {
            st.segments += m.segments;
            st.merges += m.merges;
            st.segments_merged += m.segments_merged;
        }
    }
    CompositeStats {
        strategy: strategy.into(),
        codec: codec.into(),
        nodes: schedule.nodes,
        bytes_by_round: rounds.iter().map(|r| r.bytes).collect(),
        messages: rounds.iter().map(|r| r.messages).sum(),
        bytes_total: rounds.iter().map(|r| r.bytes).sum(),
        bytes_uncompressed: rounds.iter().map(|r| r.bytes_uncompressed).sum(),
        merges: rounds.iter().map(|r| r.merges).sum(),
        segments_merged: rounds.iter().map(|r| r.segments_merged).sum(),
        rounds,
    }
}

/// The network replay of a run from every rank's log (see
/// [`crate::cluster::phase2::ReplayPlan`]).
pub fn replay_plan(
    schedule: &Schedule,
    logs: &[RankLog],
    profile: &crate::node::CostProfile,
) -> crate::cluster::phase2::ReplayPlan {
    let mut plan = crate::cluster::phase2::ReplayPlan::new(schedule.nodes, schedule.rounds.len());
    for (k, l) in logs.iter().enumerate() {
        if let Some((r, px, segs)) = l.composite {
            plan.composite(r as usize, k, px as usize, segs as usize, profile);
        }
    }
    // In schedule order (round, sender), as the in-process run records them.
    let mut all: Vec<(usize, &SentLog)> = logs
        .iter()
        .enumerate()
        .flat_map(|(k, l)| l.sent.iter().map(move |s| (k, s)))
        .collect();
    all.sort_by_key(|&(k, s)| (s.round, k));
    for (k, s) in all {
        plan.message(
            s.round as usize,
            k,
            s.to as usize,
            s.what(),
            s.bytes as usize,
            s.raw_bytes,
            profile,
        );
    }
    plan
}
