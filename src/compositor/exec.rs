//! The in-process executor: runs a [`Schedule`] round by round, encoding and
//! decoding every message with the codec so that byte counts are real.
//!
//! A simulator drives the same steps itself: [`LocalRun::outgoing`] gives the
//! round's encoded messages (charge each to a network model), then
//! [`LocalRun::deliver`] decodes and merges them. [`run_local`] does both for
//! every round.

use crate::base::Rect;
use crate::image::Image;

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

/// What one rank holds between rounds: lists (until its composite round),
/// then composited pixels (and, at the root, the gathered ones).
#[derive(Debug, Default)]
pub struct NodeState {
    /// Its segment lists, if it still holds any.
    pub lists: Option<RegionLists>,
    /// Its composited (and received) pixel regions.
    pub pixels: Vec<RegionPixels>,
}

impl NodeState {
    /// A rank that starts with `lists`.
    pub fn new(lists: RegionLists) -> NodeState {
        NodeState {
            lists: Some(lists),
            pixels: Vec::new(),
        }
    }

    /// The encoded form of what this rank sends for `what`, and its size
    /// under the raw codec.
    pub fn encode_payload(
        &self,
        codec: &dyn Codec,
        what: Payload,
    ) -> Result<(Vec<u8>, u64), ExecError> {
        let mut bytes = Vec::new();
        let raw_bytes = match what {
            Payload::Lists(r) => {
                let held = self
                    .lists
                    .as_ref()
                    .ok_or(ExecError::Sequence("sender holds no lists"))?;
                let part = held.sub(r);
                codec.encode_lists(&part, &mut bytes);
                raw_lists_bytes(&part)
            }
            Payload::Pixels(r) => {
                let p = self
                    .pixels
                    .iter()
                    .find(|p| p.rect == r)
                    .ok_or(ExecError::Sequence("sender holds no such pixels"))?;
                codec.encode_pixels(p, &mut bytes);
                raw_pixels_bytes(p)
            }
        };
        Ok((bytes, raw_bytes))
    }

    /// The start of a lists round: keep only the lists of `keep`.
    pub fn keep(&mut self, keep: Option<Rect>) {
        self.lists = match (self.lists.take(), keep) {
            (Some(l), Some(k)) if l.rect() == k => Some(l),
            (Some(l), Some(k)) => Some(l.sub(k)),
            _ => None,
        };
    }

    /// A composite round: the lists held become pixels.
    pub fn composite(&mut self) {
        if let Some(l) = self.lists.take() {
            self.pixels.push(l.composite());
        }
    }

    /// Decodes message `m` (sent to this rank) and applies it: lists are
    /// merged into the lists kept, pixels are stored. Counts into `st`.
    pub fn apply(
        &mut self,
        codec: &dyn Codec,
        opts: &ExecOptions,
        m: &Message,
        st: &mut RoundStats,
    ) -> Result<(), ExecError> {
        st.bytes += m.bytes.len() as u64;
        st.bytes_uncompressed += m.raw_bytes;
        match m.what {
            Payload::Lists(_) => {
                let got = codec
                    .decode_lists(&m.bytes, &opts.limits)
                    .map_err(|source| ExecError::Decode {
                        from: m.from,
                        to: m.to,
                        source,
                    })?;
                st.segments += got.segments().len() as u64;
                let mine = self
                    .lists
                    .as_mut()
                    .ok_or(ExecError::Sequence("receiver keeps no lists"))?;
                let (merges, removed) =
                    mine.merge(&got, opts.partial)
                        .map_err(|source| ExecError::Region {
                            from: m.from,
                            to: m.to,
                            source,
                        })?;
                st.merges += merges;
                st.segments_merged += removed;
            }
            Payload::Pixels(_) => {
                let got = codec
                    .decode_pixels(&m.bytes, &opts.limits)
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
                self.pixels.push(got);
            }
        }
        Ok(())
    }
}

/// The image `img` assembled from the root's `pixels`, over `background`;
/// an error unless they cover it exactly.
pub fn assemble(
    img: Rect,
    pixels: &[RegionPixels],
    background: [f32; 3],
) -> Result<Image, ExecError> {
    let mut image = Image::new(img.width(), img.height());
    let mut covered = 0;
    for p in pixels {
        let w = p.rect.width() as usize;
        for (k, c) in p.px.iter().enumerate() {
            let (x, y) = (
                p.rect.x0 as usize + k % w.max(1),
                p.rect.y0 as usize + k / w.max(1),
            );
            image.pixels[(y - img.y0 as usize) * img.width() as usize + x - img.x0 as usize] =
                over_background(*c, background);
        }
        covered += area(&p.rect);
    }
    if covered != area(&img) {
        return Err(ExecError::Sequence(
            "the root did not receive the whole image",
        ));
    }
    Ok(image)
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
        let nodes = node_lists.into_iter().map(NodeState::new).collect();
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
            let (bytes, raw_bytes) = self.nodes[e.from].encode_payload(self.codec, e.what)?;
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
                    node.keep(*keep);
                }
                for m in &messages {
                    self.nodes[m.to].apply(self.codec, &self.opts, m, &mut st)?;
                }
            }
            RoundKind::Composite => self.nodes.iter_mut().for_each(NodeState::composite),
            RoundKind::Gather => {
                for m in &messages {
                    self.nodes[m.to].apply(self.codec, &self.opts, m, &mut st)?;
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
        let image = assemble(
            self.schedule.image,
            &self.nodes[self.schedule.root].pixels,
            self.opts.background,
        )?;
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
