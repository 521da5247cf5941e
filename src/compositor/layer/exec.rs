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
//! ([`merge_adjacent`]): the next round then sends one layer per chain.
//!
//! [`Strategy::merges_early`]: crate::compositor::Strategy::merges_early

use crate::compositor::codec::layers::{raw_bytes, LayerCodec};
use crate::compositor::codec::Limits;
use crate::compositor::region::area;
use crate::compositor::schedule::{RoundKind, Schedule};
use crate::image::Image;

use super::{composite, merge_adjacent, Layer};

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

/// A layer message: `u32 count`, then per layer `u32 length` and its
/// encoding under `codec`. Returns the bytes and their raw-codec size.
pub fn encode(codec: &dyn LayerCodec, layers: &[Layer]) -> (Vec<u8>, u64) {
    let mut out = Vec::new();
    out.extend_from_slice(&(layers.len() as u32).to_le_bytes());
    let mut raw = 4u64;
    for l in layers {
        let at = out.len();
        out.extend_from_slice(&[0; 4]);
        codec.encode(l, &mut out);
        let n = (out.len() - at - 4) as u32;
        out[at..at + 4].copy_from_slice(&n.to_le_bytes());
        raw += 4 + raw_bytes(l);
    }
    (out, raw)
}

/// Decodes a message written by [`encode`], strictly (errors name the byte).
pub fn decode(codec: &dyn LayerCodec, bytes: &[u8]) -> anyhow::Result<Vec<Layer>> {
    let word = |at: usize| -> anyhow::Result<usize> {
        let b = bytes
            .get(at..at + 4)
            .ok_or_else(|| anyhow::anyhow!("layer message truncated at byte {at}"))?;
        Ok(u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as usize)
    };
    let n = word(0)?;
    anyhow::ensure!(
        n <= bytes.len() / 4,
        "layer message: {n} layers in {} bytes",
        bytes.len()
    );
    let mut at = 4;
    let mut out = Vec::with_capacity(n);
    for _ in 0..n {
        let len = word(at)?;
        let body = bytes
            .get(at + 4..at + 4 + len)
            .ok_or_else(|| anyhow::anyhow!("layer message truncated at byte {}", at + 4))?;
        let lim = Limits {
            max_pixels: u32::MAX as u64,
            ..Limits::default()
        };
        out.push(
            codec
                .decode(body, &lim)
                .map_err(|e| anyhow::anyhow!("layer at byte {}: {e}", at + 4))?,
        );
        at += 4 + len;
    }
    anyhow::ensure!(
        at == bytes.len(),
        "layer message: {} trailing bytes",
        bytes.len() - at
    );
    Ok(out)
}

/// Runs `schedule` over `held[node]` (each node's layers); returns the image
/// at the root (over `background`) and the rounds' messages. With
/// `merge_early`, rank-adjacent layers are composited after each lists
/// round (see the module doc).
pub fn run(
    schedule: &Schedule,
    codec: &dyn LayerCodec,
    mut held: Vec<Vec<Layer>>,
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
    let mut pieces: Vec<Option<(crate::render::cell::scan::Rect, Vec<[f32; 4]>)>> = vec![None; n];
    let mut rounds = Vec::new();
    let mut out = vec![[0f32; 4]; area(&img)];
    let paste = |out: &mut Vec<[f32; 4]>, r: &crate::render::cell::scan::Rect, px: &[[f32; 4]]| {
        let w = img.width() as usize;
        for y in r.y0..r.y1 {
            for x in r.x0..r.x1 {
                out[(y - img.y0) as usize * w + (x - img.x0) as usize] =
                    px[((y - r.y0) * r.width() + (x - r.x0)) as usize];
            }
        }
    };
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
                let mut inbox: Vec<Vec<Layer>> = vec![Vec::new(); n];
                for e in &round.sends {
                    let r = e.what.rect();
                    let part: Vec<Layer> = held[e.from]
                        .iter()
                        .map(|l| l.crop(&r))
                        .filter(|l| area(&l.rect) > 0)
                        .collect();
                    let (bytes, raw) = encode(codec, &part);
                    lr.messages.push(LayerMessage {
                        from: e.from,
                        to: e.to,
                        bytes: bytes.len() as u64,
                        raw_bytes: raw,
                        pixels: part.iter().map(|l| l.px.len() as u64).sum(),
                    });
                    inbox[e.to].extend(decode(codec, &bytes)?);
                }
                for (k, h) in held.iter_mut().enumerate() {
                    *h = match round.keep.get(k).copied().flatten() {
                        Some(r) => h
                            .iter()
                            .map(|l| l.crop(&r))
                            .filter(|l| area(&l.rect) > 0)
                            .collect(),
                        None => Vec::new(),
                    };
                    h.append(&mut inbox[k]);
                    if merge_early {
                        let (m, px) =
                            merge_adjacent(std::mem::take(h)).map_err(|e| anyhow::anyhow!(e))?;
                        *h = m;
                        lr.merged[k] = px;
                    }
                }
            }
            RoundKind::Composite => {
                for k in 0..n {
                    if held[k].is_empty() {
                        continue; // nothing to blend: its region stays transparent
                    }
                    let Some(r) = keep_of(schedule, k) else {
                        continue;
                    };
                    let refs: Vec<&Layer> = held[k].iter().collect();
                    lr.blended[k] = refs.iter().map(|l| l.px.len() as u64).sum();
                    pieces[k] = Some((r, composite(&r, &refs).map_err(|e| anyhow::anyhow!(e))?));
                }
            }
            RoundKind::Gather => {
                for e in &round.sends {
                    let Some((r, px)) = pieces[e.from].take() else {
                        continue;
                    };
                    let l = Layer::quantize(r, 0, codec.depth(), &px);
                    let (bytes, raw) = encode(codec, std::slice::from_ref(&l));
                    lr.messages.push(LayerMessage {
                        from: e.from,
                        to: e.to,
                        bytes: bytes.len() as u64,
                        raw_bytes: raw,
                        pixels: l.px.len() as u64,
                    });
                    for got in decode(codec, &bytes)? {
                        paste(&mut out, &got.rect, &got.to_f32());
                    }
                }
                if let Some((r, px)) = pieces[schedule.root].take() {
                    paste(&mut out, &r, &px);
                }
            }
        }
        rounds.push(lr);
    }
    let mut image = Image::new(img.width(), img.height());
    for (o, p) in image.pixels.iter_mut().zip(out) {
        let t = 1.0 - p[3];
        *o = [
            p[0] + t * background[0],
            p[1] + t * background[1],
            p[2] + t * background[2],
            p[3],
        ];
    }
    Ok((image, rounds))
}

/// The region node `k` holds after the schedule's last lists round (the
/// whole screen if no round cut it).
fn keep_of(s: &Schedule, k: usize) -> Option<crate::render::cell::scan::Rect> {
    let mut r = Some(s.image);
    for round in &s.rounds {
        if round.kind == RoundKind::Lists {
            r = round.keep.get(k).copied().flatten();
        }
    }
    r
}

#[cfg(test)]
#[path = "exec_tests.rs"]
mod tests;
