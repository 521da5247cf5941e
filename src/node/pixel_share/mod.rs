//! Per-pixel opacity-level sharing: the cluster's ERT at the strength of the
//! sequential pyramid.
//!
//! ## Why
//!
//! The paper's manager keeps one `(terminated, deepest)` entry per `D x D`
//! subscreen and takes, per entry, the minimum `deepest` of the nodes whose
//! own entry is terminated. Two things cap it on data split over nodes:
//! an entry is terminated only when *every* pixel of it is, and only when
//! *one* node's segments alone reach the threshold. [`super::levels`]
//! removed the second cap per block; this module removes both: entries are
//! single pixels, and opacity composes across nodes.
//!
//! ## What a node sends
//!
//! For each of `L` levels `a_l = 1 - (1 - thr)^(l / L)` ([`level_alphas`](super::levels::level_alphas))
//! and each pixel, the depth `d_{k,l}(p)` at which node `k`'s *own* segments
//! (front to back, gaps allowed) first reach `a_l`: the `z_back` of the
//! segment where the running alpha crosses it (`+inf` if not yet). It is a
//! certificate: node `k`'s segments in front of `d_{k,l}` have transmittance
//! at most `(1 - thr)^(l / L)`, and segments are only ever added, so it never
//! expires; the node keeps per value the minimum over its updates and sends
//! only the pixels whose values changed since its last share
//! ([`PixelLevels`]).
//!
//! ## What the manager combines
//!
//! Different nodes' segments are disjoint (cells are), and transmittances of
//! disjoint stretches multiply, so at depth `z` a pixel's true transmittance
//! is at most `prod_k (1 - thr)^(c_k(z) / L)`, `c_k(z)` the number of levels
//! of node `k` certified at depths `<= z`. It is `<= 1 - thr` once
//! `sum_k c_k(z) >= L`: the pixel's certified termination depth is the
//! **`L`-th smallest** of all nodes' values `d_{k,l}(p)` ([`PixelStore`]).
//! That is the manager's entry in the paper's format — `terminated` (finite)
//! and `deepest` — at the granularity of one pixel. Since a node's new
//! values are never larger than its old ones, replacing them can only lower
//! the combination; the manager keeps the minimum anyway, so a faulty node
//! cannot raise an entry.
//!
//! ## What comes back
//!
//! The certified depths that changed since that node's last reply
//! ([`PixelDepths`], from a change log: `O(changes)` per reply, not
//! `O(pixels)`). The node lowers its per-pixel depths and its max-pyramid
//! tests cells against `min(own, shared)`: the sequential renderer's test.
//!
//! ## Bytes
//!
//! Depths travel as `u16` codes over the frame's depth range
//! ([`DepthQuant`]), always **rounded up** (a deeper certificate is still a
//! certificate), `u16::MAX` meaning "not reached". Pixel indices are
//! delta-coded LEB128 varints over ascending indices. A pixel-level share
//! costs about `1 + 2 L` bytes per changed pixel, a reply about 3 bytes per
//! changed entry.
//!
//! ## Error bound
//!
//! The same as the sequential renderer's: a cell is skipped only behind a
//! depth where the pixel's true accumulated opacity is provably at least the
//! threshold (up to `f32` rounding of the levels, as in [`super::levels`]).
//!
//! ## Files
//!
//! `quant.rs`: the depth codes; `wire.rs`: the share and reply messages and
//! their byte forms; `store.rs`: the manager's store and the `L`-th smallest
//! combination; `node.rs`: a node's side.

mod node;
mod quant;
mod store;
#[cfg(test)]
mod tests;
mod wire;

pub use node::NodePixelLevels;
pub use quant::{DepthQuant, NOT_REACHED};
pub use store::{lth_smallest, PixelStore, TILE};
pub(crate) use wire::{put_varint, Reader};
pub use wire::{PixelDepths, PixelLevels};
