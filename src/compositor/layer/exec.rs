//! Runs a compositing [`Schedule`] over RGBA layers in-process, with real
//! bytes: the same schedules as segment lists (`Lists(rect)` now means "my
//! layers cropped to `rect`"), so strategies stay schedules for both
//! partial kinds. A message is `u32 count`, then per layer `u32 length` and
//! its encoding under the layer codec; the receiver decodes it strictly.
//! The composite round blends each node's layers in rank order (ordered
//! compositing: ranks never overlap, so the order is the visibility order
//! whichever node held what); the gather sends the composited piece as one
//! layer.
//!
//! With `merge_early` (radix-k, [`Strategy::merges_early`]), after every
//! lists round each rank composites the layers it holds whose ranks chain
//! (`merge_adjacent`): the next round then sends one layer per chain.
//!
//! [`Strategy::merges_early`]: crate::compositor::Strategy::merges_early

use crate::compositor::codec::layers::LayerCodec;
use crate::compositor::exec::Message;
use crate::compositor::partial::RankPartial;
use crate::compositor::schedule::{RoundKind, Schedule};
use crate::image::Image;

pub use super::message::{decode, decode_within, encode};
use super::rank::{LayerGather, LayerRank};
use super::Layer;

/// One message of a round.
#[derive(Debug, Clone)]
pub struct LayerMessage {
    /// Sender.
    pub from: usize,
    /// Receiver.
    pub to: usize,
    /// Encoded size, bytes.
    pub bytes: u64,
    /// Size under the raw codec.
    pub raw_bytes: u64,
    /// Pixels carried (blend work at the receiver).
    pub pixels: u64,
}

/// One round of the run.
#[derive(Debug, Clone, Default)]
pub struct LayerRound {
    /// The round's label.
    pub label: String,
    /// Whether this is the composite round.
    pub composite: bool,
    /// Per node, pixels blended in the composite round.
    pub blended: Vec<u64>,
    /// Per node, pixels blended merging adjacent layers after this (lists)
    /// round's messages arrived (`merge_early` only).
    pub merged: Vec<u64>,
    /// The messages.
    pub messages: Vec<LayerMessage>,
}

/// Runs `schedule` over `held[node]` (each node's layers); returns the image
/// at the root (over `background`) and the rounds' messages. With
/// `merge_early`, rank-adjacent layers are composited after each lists
/// round (see the module doc). Each rank is a [`LayerRank`] and the root's
/// image a [`LayerGather`], the steps phase 2 worker to worker runs.
pub fn run(
    schedule: &Schedule,
    codec: &dyn LayerCodec,
    held: Vec<Vec<Layer>>,
    background: [f32; 3],
    merge_early: bool,
) -> anyhow::Result<(Image, Vec<LayerRound>)> {
    schedule.validate().map_err(|e| anyhow::anyhow!(e))?;
    let n = schedule.nodes;
    anyhow::ensure!(
        held.len() == n,
        "{} nodes' layers for {n} ranks",
        held.len()
    );
    let img = schedule.image;
    let bricks = held
        .iter()
        .flatten()
        .map(|l| l.ranks[1] + 1)
        .max()
        .unwrap_or(0);
    let mut ranks: Vec<LayerRank> = held
        .into_iter()
        .map(|h| LayerRank::new(codec, img, h, bricks, merge_early))
        .collect();
    let mut gather = LayerGather::new(codec, img);
    let mut rounds = Vec::new();
    for round in &schedule.rounds {
        let mut lr = LayerRound {
            label: round.label.clone(),
            composite: round.kind == RoundKind::Composite,
            blended: vec![0; n],
            merged: vec![0; n],
            messages: Vec::new(),
        };
        match round.kind {
            RoundKind::Lists => {
                let mut inbox: Vec<Vec<Message>> = vec![Vec::new(); n];
                for e in &round.sends {
                    let enc = ranks[e.from]
                        .encode(e.what)?
                        .ok_or_else(|| anyhow::anyhow!("rank {} has no layers to send", e.from))?;
                    lr.messages.push(LayerMessage {
                        from: e.from,
                        to: e.to,
                        bytes: enc.bytes.len() as u64,
                        raw_bytes: enc.raw_bytes,
                        pixels: enc.pixels,
                    });
                    inbox[e.to].push(Message {
                        from: e.from,
                        to: e.to,
                        what: e.what,
                        bytes: enc.bytes,
                        raw_bytes: enc.raw_bytes,
                    });
                }
                for (k, r) in ranks.iter_mut().enumerate() {
                    r.keep(round.keep.get(k).copied().flatten());
                    inbox[k].sort_by_key(|m| m.from);
                    lr.merged[k] = r.merge(&inbox[k])?.blended;
                }
            }
            RoundKind::Composite => {
                for (k, r) in ranks.iter_mut().enumerate() {
                    if let Some((px, _)) = r.composite()? {
                        lr.blended[k] = px;
                    }
                }
            }
            RoundKind::Gather => {
                for e in &round.sends {
                    let Some(enc) = ranks[e.from].encode(e.what)? else {
                        continue;
                    };
                    lr.messages.push(LayerMessage {
                        from: e.from,
                        to: e.to,
                        bytes: enc.bytes.len() as u64,
                        raw_bytes: enc.raw_bytes,
                        pixels: enc.pixels,
                    });
                    gather.take(e.what.rect(), &enc.bytes)?;
                }
                for (r, bytes) in ranks[schedule.root].handoff() {
                    gather.take_handoff(r, &bytes)?;
                }
            }
        }
        rounds.push(lr);
    }
    Ok((gather.image(background), rounds))
}

#[cfg(test)]
#[path = "exec_tests.rs"]
mod tests;
