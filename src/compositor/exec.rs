//! The in-process executor: runs a [`Schedule`] round by round, encoding and
//! decoding every message with the codec so that byte counts are real.
//!
//! A simulator drives the same steps itself: [`LocalRun::outgoing`] gives the
//! round's encoded messages (charge each to a network model), then
//! [`LocalRun::deliver`] decodes and merges them. [`run_local`] does both for
//! every round.

use crate::image::Image;
use crate::render::cell::scan::Rect;

use super::canonical::over_background;
use super::codec::{raw_lists_bytes, raw_pixels_bytes, Codec, DecodeError, Limits};
use super::lists::{RegionLists, RegionMismatch, RegionPixels};
use super::region::area;
use super::schedule::{Payload, Round, RoundKind, Schedule};
use super::strategy::Strategy;

/// How to run.
#[derive(Debug, Clone, Copy)]
pub struct ExecOptions {
    /// Merge touching segments (partial composition) while merging lists.
    pub partial: bool,
    /// Background colour the final image is composited over.
    pub background: [f32; 3],
    /// Decode limits applied to every message.
    pub limits: Limits,
}

impl Default for ExecOptions {
    fn default() -> Self {
        ExecOptions {
            partial: true,
            background: [0.0; 3],
            limits: Limits::default(),
        }
    }
}

/// Why a run failed.
#[derive(Debug, thiserror::Error)]
pub enum ExecError {
    /// The strategy produced an inconsistent schedule.
    #[error("invalid schedule: {0}")]
    Schedule(String),
    /// The node inputs do not fit the schedule.
    #[error("bad input: {0}")]
    Input(String),
    /// A message failed to decode.
    #[error("message {from} -> {to}: {source}")]
    Decode {
        /// Sender.
        from: usize,
        /// Receiver.
        to: usize,
        /// Why.
        source: DecodeError,
    },
    /// A message carried another region than the schedule says.
    #[error("message {from} -> {to}: {source}")]
    Region {
        /// Sender.
        from: usize,
        /// Receiver.
        to: usize,
        /// Which regions.
        source: RegionMismatch,
    },
    /// `deliver` was called with no round left, or `finish` too early.
    #[error("{0}")]
    Sequence(&'static str),
}

/// One encoded message of the current round.
#[derive(Debug, Clone)]
pub struct Message {
    /// Sender.
    pub from: usize,
    /// Receiver.
    pub to: usize,
    /// What the schedule says it carries.
    pub what: Payload,
    /// The encoded bytes.
    pub bytes: Vec<u8>,
    /// Its size under the raw codec.
    pub raw_bytes: u64,
}

/// Counters of one round.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct RoundStats {
    /// The round's label.
    pub label: String,
    /// Messages sent.
    pub messages: usize,
    /// Encoded bytes sent.
    pub bytes: u64,
    /// What the raw codec would have sent.
    pub bytes_uncompressed: u64,
    /// Segments sent.
    pub segments: u64,
    /// Pixel lists merged (both sides non-empty).
    pub merges: u64,
    /// List entries removed by partial composition while merging.
    pub segments_merged: u64,
}

/// Counters of a whole run.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct CompositeStats {
    /// Strategy name.
    pub strategy: String,
    /// Codec name.
    pub codec: String,
    /// Nodes.
    pub nodes: usize,
    /// Per round.
    pub rounds: Vec<RoundStats>,
    /// Encoded bytes per round.
    pub bytes_by_round: Vec<u64>,
    /// Messages in all rounds.
    pub messages: usize,
    /// Encoded bytes in all rounds.
    pub bytes_total: u64,
    /// Raw-codec bytes in all rounds.
    pub bytes_uncompressed: u64,
    /// Pixel lists merged.
    pub merges: u64,
    /// List entries removed by partial composition.
    pub segments_merged: u64,
}

#[derive(Debug, Default)]
struct NodeState {
    lists: Option<RegionLists>,
    pixels: Vec<RegionPixels>,
}

/// A schedule being executed in-process.
pub struct LocalRun<'a> {
    schedule: Schedule,
    codec: &'a dyn Codec,
    opts: ExecOptions,
    nodes: Vec<NodeState>,
    next: usize,
    stats: CompositeStats,
}

impl<'a> LocalRun<'a> {
    /// Prepares to run `strategy` over `node_lists` (one per node, each for
    /// the whole image `node_lists[0].rect()`).
    pub fn new(
        strategy: &dyn Strategy,
        codec: &'a dyn Codec,
        node_lists: Vec<RegionLists>,
        opts: ExecOptions,
    ) -> Result<Self, ExecError> {
        let Some(first) = node_lists.first() else {
            return Err(ExecError::Input("no nodes".into()));
        };
        let image = first.rect();
        if let Some(l) = node_lists.iter().find(|l| l.rect() != image) {
            return Err(ExecError::Input(format!(
                "node lists for {:?} and {image:?}",
                l.rect()
            )));
        }
        let schedule = strategy.schedule(node_lists.len(), image);
        schedule.validate().map_err(ExecError::Schedule)?;
        let stats = CompositeStats {
            strategy: strategy.name().into(),
            codec: codec.name().into(),
            nodes: node_lists.len(),
            ..Default::default()
        };
        let nodes = node_lists
            .into_iter()
            .map(|l| NodeState {
                lists: Some(l),
                pixels: Vec::new(),
            })
            .collect();
        Ok(LocalRun {
            schedule,
            codec,
            opts,
            nodes,
            next: 0,
            stats,
        })
    }

    /// The schedule being run.
    pub fn schedule(&self) -> &Schedule {
        &self.schedule
    }

    /// What `node` holds now: `(pixels, segments)` of its lists, if it
    /// holds lists (for a simulator's compute-cost model).
    pub fn held(&self, node: usize) -> Option<(usize, usize)> {
        let l = self.nodes.get(node)?.lists.as_ref()?;
        Some((l.pixels(), l.segments().len()))
    }

    /// The round the next [`deliver`](Self::deliver) completes, if any.
    pub fn next_round(&self) -> Option<&Round> {
        self.schedule.rounds.get(self.next)
    }

    /// Encodes the messages of the next round, from the senders' current state.
    pub fn outgoing(&self) -> Result<Vec<Message>, ExecError> {
        let round = self
            .next_round()
            .ok_or(ExecError::Sequence("no round left"))?;
        let mut out = Vec::with_capacity(round.sends.len());
        for e in &round.sends {
            let node = &self.nodes[e.from];
            let mut bytes = Vec::new();
            let raw_bytes = match e.what {
                Payload::Lists(r) => {
                    let held = node
                        .lists
                        .as_ref()
                        .ok_or(ExecError::Sequence("sender holds no lists"))?;
                    let part = held.sub(r);
                    self.codec.encode_lists(&part, &mut bytes);
                    raw_lists_bytes(&part)
                }
                Payload::Pixels(r) => {
                    let p = node
                        .pixels
                        .iter()
                        .find(|p| p.rect == r)
                        .ok_or(ExecError::Sequence("sender holds no such pixels"))?;
                    self.codec.encode_pixels(p, &mut bytes);
                    raw_pixels_bytes(p)
                }
            };
            out.push(Message {
                from: e.from,
                to: e.to,
                what: e.what,
                bytes,
                raw_bytes,
            });
        }
        Ok(out)
    }

    /// Decodes `messages` (those of [`outgoing`](Self::outgoing), possibly
    /// after a trip over a network), applies the round, and returns its counters.
    pub fn deliver(&mut self, mut messages: Vec<Message>) -> Result<RoundStats, ExecError> {
        let round = self
            .schedule
            .rounds
            .get(self.next)
            .ok_or(ExecError::Sequence("no round left"))?
            .clone();
        let mut st = RoundStats {
            label: round.label.clone(),
            messages: messages.len(),
            ..Default::default()
        };
        // Merge order never changes the bits (canonical form); sort anyway so
        // that counters are reproducible.
        messages.sort_by_key(|m| (m.to, m.from));
        match round.kind {
            RoundKind::Lists => {
                for (node, keep) in self.nodes.iter_mut().zip(&round.keep) {
                    node.lists = match (node.lists.take(), keep) {
                        (Some(l), Some(k)) if l.rect() == *k => Some(l),
                        (Some(l), Some(k)) => Some(l.sub(*k)),
                        _ => None,
                    };
                }
                for m in &messages {
                    st.bytes += m.bytes.len() as u64;
                    st.bytes_uncompressed += m.raw_bytes;
                    let got = self
                        .codec
                        .decode_lists(&m.bytes, &self.opts.limits)
                        .map_err(|source| ExecError::Decode {
                            from: m.from,
                            to: m.to,
                            source,
                        })?;
                    st.segments += got.segments().len() as u64;
                    let mine = self.nodes[m.to]
                        .lists
                        .as_mut()
                        .ok_or(ExecError::Sequence("receiver keeps no lists"))?;
                    let (merges, removed) =
                        mine.merge(&got, self.opts.partial).map_err(|source| {
                            ExecError::Region {
                                from: m.from,
                                to: m.to,
                                source,
                            }
                        })?;
                    st.merges += merges;
                    st.segments_merged += removed;
                }
            }
            RoundKind::Composite => {
                for node in &mut self.nodes {
                    if let Some(l) = node.lists.take() {
                        node.pixels.push(l.composite());
                    }
                }
            }
            RoundKind::Gather => {
                for m in &messages {
                    st.bytes += m.bytes.len() as u64;
                    st.bytes_uncompressed += m.raw_bytes;
                    let got = self
                        .codec
                        .decode_pixels(&m.bytes, &self.opts.limits)
                        .map_err(|source| ExecError::Decode {
                            from: m.from,
                            to: m.to,
                            source,
                        })?;
                    if got.rect != m.what.rect() {
                        return Err(ExecError::Region {
                            from: m.from,
                            to: m.to,
                            source: RegionMismatch(got.rect, m.what.rect()),
                        });
                    }
                    self.nodes[m.to].pixels.push(got);
                }
            }
        }
        self.stats.messages += st.messages;
        self.stats.bytes_total += st.bytes;
        self.stats.bytes_uncompressed += st.bytes_uncompressed;
        self.stats.merges += st.merges;
        self.stats.segments_merged += st.segments_merged;
        self.stats.bytes_by_round.push(st.bytes);
        self.stats.rounds.push(st.clone());
        self.next += 1;
        Ok(st)
    }

    /// Runs the next round in-process.
    pub fn step(&mut self) -> Result<RoundStats, ExecError> {
        let m = self.outgoing()?;
        self.deliver(m)
    }

    /// The root's image (over the background) and the counters, once every
    /// round has run.
    pub fn finish(self) -> Result<(Image, CompositeStats), ExecError> {
        if self.next != self.schedule.rounds.len() {
            return Err(ExecError::Sequence("rounds left to run"));
        }
        let img: Rect = self.schedule.image;
        let mut image = Image::new(img.width(), img.height());
        let mut covered = 0;
        for p in &self.nodes[self.schedule.root].pixels {
            let w = p.rect.width() as usize;
            for (k, c) in p.px.iter().enumerate() {
                let (x, y) = (
                    p.rect.x0 as usize + k % w.max(1),
                    p.rect.y0 as usize + k / w.max(1),
                );
                image.pixels[(y - img.y0 as usize) * img.width() as usize + x - img.x0 as usize] =
                    over_background(*c, self.opts.background);
            }
            covered += area(&p.rect);
        }
        if covered != area(&img) {
            return Err(ExecError::Sequence(
                "the root did not receive the whole image",
            ));
        }
        Ok((image, self.stats))
    }
}

/// Runs `strategy` with `codec` over the nodes' lists in-process: the final
/// image at the root and the counters.
pub fn run_local(
    strategy: &dyn Strategy,
    codec: &dyn Codec,
    node_lists: Vec<RegionLists>,
    opts: ExecOptions,
) -> Result<(Image, CompositeStats), ExecError> {
    let mut run = LocalRun::new(strategy, codec, node_lists, opts)?;
    while run.next_round().is_some() {
        run.step()?;
    }
    run.finish()
}
