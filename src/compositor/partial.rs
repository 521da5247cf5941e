//! One rank's side of a compositing [`Schedule`](super::Schedule), for
//! either partial kind: segment lists ([`ListRank`]) or visibility-ranked
//! RGBA layers ([`super::layer::rank::LayerRank`]). Phase 2 worker to
//! worker (`cluster::remote::phase2`) runs a schedule over this interface
//! only, so one executor serves both kinds:
//!
//! ```text
//! lists round   encode(Lists(r)) for each send · keep(keep[k]) · merge(received, sender order)
//! composite     composite()
//! gather        encode(Pixels(r)) for each send (None: nothing composited, nothing sent) · root: handoff()
//! ```

use crate::base::Rect;

use super::codec::Codec;
use super::exec::{ExecOptions, Message, NodeState, RoundStats};
use super::schedule::Payload;

/// One encoded payload.
#[derive(Debug, Clone)]
pub struct Encoded {
    /// The codec's bytes.
    pub bytes: Vec<u8>,
    /// Its size under the raw codec.
    pub raw_bytes: u64,
    /// Pixels it carries (blend work at the receiver; layers only, 0 for lists).
    pub pixels: u64,
}

/// What one rank merged in one lists round.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct MergeCounts {
    /// Segments received (lists).
    pub segments: u64,
    /// Pixel lists merged (lists).
    pub merges: u64,
    /// Entries removed by partial composition (lists).
    pub segments_merged: u64,
    /// Pixels blended merging adjacent layers early (layers, radix-k).
    pub blended: u64,
}

/// One rank's compositing state.
pub trait RankPartial {
    /// The bytes this rank sends for `what` (lists of a rectangle in a
    /// lists round, its composited pixels in a gather); `None`: nothing to
    /// send (a rank that composited nothing).
    fn encode(&self, what: Payload) -> anyhow::Result<Option<Encoded>>;
    /// Keeps only the region `keep` (`None`: nothing).
    fn keep(&mut self, keep: Option<Rect>);
    /// Decodes and merges one round's messages addressed to this rank (in
    /// sender order). Called every lists round, with or without messages.
    fn merge(&mut self, got: &[Message]) -> anyhow::Result<MergeCounts>;
    /// Composites what it holds; `(pixels, entries)` it blended, `None`
    /// when it held nothing.
    fn composite(&mut self) -> anyhow::Result<Option<(u64, u64)>>;
    /// The root's own composited pixels for the coordinator: `(rect,
    /// bytes)` per piece, in the kind's hand-off form.
    fn handoff(&mut self) -> Vec<(Rect, Vec<u8>)>;
}

/// A rank of the segment-list kind: [`NodeState`] under a codec.
pub struct ListRank<'a> {
    /// The state.
    pub state: NodeState,
    /// The list codec.
    pub codec: &'a dyn Codec,
    /// Executor options (partial composition, limits).
    pub opts: &'a ExecOptions,
}

impl RankPartial for ListRank<'_> {
    fn encode(&self, what: Payload) -> anyhow::Result<Option<Encoded>> {
        let (bytes, raw_bytes) = self.state.encode_payload(self.codec, what)?;
        Ok(Some(Encoded {
            bytes,
            raw_bytes,
            pixels: 0,
        }))
    }

    fn keep(&mut self, keep: Option<Rect>) {
        self.state.keep(keep);
    }

    fn merge(&mut self, got: &[Message]) -> anyhow::Result<MergeCounts> {
        let mut st = RoundStats::default();
        for m in got {
            self.state.apply(self.codec, self.opts, m, &mut st)?;
        }
        Ok(MergeCounts {
            segments: st.segments,
            merges: st.merges,
            segments_merged: st.segments_merged,
            blended: 0,
        })
    }

    fn composite(&mut self) -> anyhow::Result<Option<(u64, u64)>> {
        let held = self
            .state
            .lists
            .as_ref()
            .map(|l| (l.pixels() as u64, l.segments().len() as u64));
        self.state.composite();
        Ok(held)
    }

    fn handoff(&mut self) -> Vec<(Rect, Vec<u8>)> {
        std::mem::take(&mut self.state.pixels)
            .into_iter()
            .map(|p| {
                let mut bytes = Vec::new();
                self.codec.encode_pixels(&p, &mut bytes);
                (p.rect, bytes)
            })
            .collect()
    }
}
