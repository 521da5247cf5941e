//! Binary swap over segment lists, with *folding* for node counts that are
//! not powers of two.
//!
//! With `p = 2^k` nodes, round `i` pairs rank `r` with `r XOR 2^i`. Partners
//! hold the same region (it depends only on bits `0..i` of the rank); they
//! cut it in half across its longer side, the lower rank keeps the first
//! half, the higher the second, each sends the other half's lists to its
//! partner and merges what it receives. After `k` rounds each node holds
//! `1/p` of the screen with every node's segments in it, composites it, and
//! the root gathers the pieces.
//!
//! # Non-powers of two: fold first
//!
//! With `n = p + e` (`0 < e < p`), the `e` extra ranks `p..n` first send
//! *all* their lists to rank `r - p`, which merges them and then runs the
//! power-of-two swap as usual; the extras are idle afterwards (IceT's
//! approach, as the brief suggests). For `n = 6`:
//!
//! ```text
//! fold     swap 0        swap 1        composite + gather
//! 4 ──► 0   0 ◄─► 1       0 ◄─► 2       0,1,2,3 ──► 0
//! 5 ──► 1   2 ◄─► 3       1 ◄─► 3
//! ```
//!
//! Why this and not the 2-3 swap (Yu et al., 2008), which keeps every node
//! busy? With segment lists, merging is exact whatever the grouping, so any
//! scheme is correct; folding keeps the schedule the textbook one (easy to
//! check against the papers' binary swap), costs exactly one extra round of
//! `e` full-screen messages, and spatially coherent data keeps those
//! messages sparse (the RLE codec sends a covered pixel's lists, not the
//! screen). The price is that `e` nodes idle during the swaps.
//!
//! # Why not swap composited images
//!
//! Classic binary swap composites locally first and swaps RGBA images,
//! blending the halves in visibility order. That needs each node's data to
//! lie entirely in front of or behind its partner's along every ray. With
//! cells placed "where the simulation produced them", two nodes' cells
//! interleave along a ray (a node's sub-volume is not convex, or the
//! per-node bounding boxes overlap, as in the paper's view B), so no order of
//! the two images is right. Keeping lists until the last round keeps the
//! result exact for any placement.

use crate::base::Rect;

use super::super::region::halves;
use super::super::schedule::{Exchange, Payload, Round, RoundKind, Schedule};
use super::Strategy;

/// Binary swap (see the module doc).
#[derive(Debug, Clone, Copy, Default)]
pub struct BinarySwap;

impl Strategy for BinarySwap {
    fn name(&self) -> &'static str {
        "binary-swap"
    }

    fn preserves_order(&self) -> bool {
        true
    }

    fn schedule(&self, nodes: usize, image: Rect) -> Schedule {
        let p = 1usize << (usize::BITS - 1 - nodes.max(1).leading_zeros());
        let mut rounds = Vec::new();
        let mut held: Vec<Option<Rect>> = vec![Some(image); nodes];
        if nodes > p {
            for r in held.iter_mut().skip(p) {
                *r = None;
            }
            rounds.push(Round {
                kind: RoundKind::Lists,
                label: "fold".into(),
                sends: (p..nodes)
                    .map(|r| Exchange {
                        from: r,
                        to: r - p,
                        what: Payload::Lists(image),
                    })
                    .collect(),
                keep: held.clone(),
            });
        }
        let mut bit = 1;
        while bit < p {
            let mut sends = Vec::new();
            let mut keep = held.clone();
            for r in 0..p {
                let region = held[r].expect("power-of-two ranks hold a region");
                let (first, second) = halves(&region);
                let (mine, theirs) = if r & bit == 0 {
                    (first, second)
                } else {
                    (second, first)
                };
                keep[r] = Some(mine);
                sends.push(Exchange {
                    from: r,
                    to: r ^ bit,
                    what: Payload::Lists(theirs),
                });
            }
            rounds.push(Round {
                kind: RoundKind::Lists,
                label: format!("swap {}", bit.trailing_zeros()),
                sends,
                keep: keep.clone(),
            });
            held = keep;
            bit <<= 1;
        }
        rounds.push(super::composite());
        let owned: Vec<Rect> = held
            .iter()
            .map(|h| {
                h.unwrap_or(Rect {
                    x0: 0,
                    y0: 0,
                    x1: 0,
                    y1: 0,
                })
            })
            .collect();
        rounds.push(super::gather(&owned, 0));
        Schedule {
            nodes,
            image,
            root: 0,
            rounds,
        }
    }
}
