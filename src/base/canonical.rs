//! Canonical composition: one pixel value per *set* of ray segments, however
//! the segments were spread over nodes, inserted, and merged.
//!
//! # The problem
//!
//! "Over" is associative in real arithmetic but not in `f32`:
//! `(a over b) over c` and `a over (b over c)` differ in the last bits. Partial
//! composition merges touching segments *as they arrive*, so the stored value
//! of a merged run depends on the insertion order, and in a cluster on which
//! node held which cell. Compositing the nodes' merged lists then gives an
//! image that differs from the sequential render in the last bits, and the
//! difference depends on the node count.
//!
//! # The canonical form
//!
//! Merge order is fixed by the *depths*, not by arrival:
//!
//! - Two segments **join** when `front.z_back == back.z_front` exactly (the
//!   bit-identical depths of a shared face). A *chain* is a maximal run of
//!   joined segments. Segments with `rgba == 0` are dropped: they are the
//!   identity of over, and zero-length segments are always clear.
//! - Every depth `z` has a pseudo-random *key* `depth_key(z)` (a bijective
//!   hash of its bits). The boundary between joined `f` and `b` has key
//!   `min(key(f.z_back), key(b.z_front))`.
//! - The value of a chain is the *treap* over its boundaries: split at the
//!   boundary with the smallest key (leftmost on ties), evaluate both halves
//!   the same way, and combine them with one over. The pixel value is the
//!   front-to-back over of its chains.
//!
//! The tree depends only on the set of segments in the pixel, never on the
//! node count. A node that holds a run of joined segments can merge a sub-run
//! early when the sub-run is a subtree of the global treap *whatever the
//! other nodes hold*. The test is local: every inner boundary key must be
//! greater than the keys of the sub-run's two ends. An end that turns out to
//! be a chain end acts like key `-inf`, and one whose partner lies elsewhere
//! gets key `min(own, partner's) <= own`, so the test can only get easier.
//! A merged piece is evaluated by the same treap rule, so its bits are the
//! ones the global evaluation would produce for that subtree.
//!
//! [`insert`] and [`merge`] keep a list in this form: sorted by
//! [`order`], with every chain cut into its *maximal* early-mergeable
//! pieces. [`composite`] evaluates any such list, with or without partial
//! composition, into the same bits.
//!
//! # Costs
//!
//! A chain of `k` segments whose ends are unknown is stored as `O(log k)`
//! pieces (expected, for random keys) instead of 1: the maximal subtrees of a
//! treap that cover a range. Only whole-chain knowledge (the final
//! composite) collapses it to one value.
//!
//! # Why exact joins
//!
//! The renderer's `touches` accepts depths a few ulps apart (rays through an
//! edge or a vertex). That is not canonical: a node holding `A` and `C` but
//! not a thin `B` between them would see `A` touch `C` and merge them, while
//! the node holding all three would not. With exact equality, anything
//! between `A` and `C` has zero length, hence is clear, hence is dropped.

use std::cmp::Ordering;

use super::segment::{Rgba, Segment};

/// Pseudo-random priority of depth `z` as a merge boundary: MurmurHash3's
/// 32-bit finaliser of the bits of `z`, a bijection, so distinct depths get
/// distinct keys.
#[inline]
pub fn depth_key(z: f32) -> u32 {
    let mut h = z.to_bits();
    h ^= h >> 16;
    h = h.wrapping_mul(0x85eb_ca6b);
    h ^= h >> 13;
    h = h.wrapping_mul(0xc2b2_ae35);
    h ^ (h >> 16)
}

/// Whether `back` continues `front` along the ray (bit-identical shared depth).
#[inline]
pub fn joins(front: &Segment, back: &Segment) -> bool {
    front.z_back == back.z_front
}

/// Whether a segment is the identity of over (all four channels zero).
#[inline]
pub fn is_clear(s: &Segment) -> bool {
    s.rgba.a == 0.0 && s.rgba.rgb == [0.0; 3]
}

/// The canonical order of a list: by `z_front`, then `z_back`, then the bits
/// of the colour (a total order, so ties never depend on arrival).
pub fn order(a: &Segment, b: &Segment) -> Ordering {
    let bits = |s: &Segment| {
        [
            s.rgba.rgb[0].to_bits(),
            s.rgba.rgb[1].to_bits(),
            s.rgba.rgb[2].to_bits(),
            s.rgba.a.to_bits(),
        ]
    };
    a.z_front
        .total_cmp(&b.z_front)
        .then(a.z_back.total_cmp(&b.z_back))
        .then_with(|| bits(a).cmp(&bits(b)))
}

#[inline]
fn boundary_key(front: &Segment, back: &Segment) -> u32 {
    depth_key(front.z_back).min(depth_key(back.z_front))
}

/// Inserts `seg` into the canonical list `list`; with `partial`, re-merges the
/// chain it lands in into its maximal early-mergeable pieces. Returns how many
/// list entries the merge removed (0 without `partial`).
pub fn insert(list: &mut Vec<Segment>, seg: Segment, partial: bool) -> usize {
    if is_clear(&seg) {
        return 0;
    }
    let pos = match list.last() {
        Some(last) if order(last, &seg) != Ordering::Greater => list.len(),
        _ => list.partition_point(|s| order(s, &seg) != Ordering::Greater),
    };
    list.insert(pos, seg);
    if !partial {
        return 0;
    }
    let (mut l, mut r) = (pos, pos);
    while l > 0 && joins(&list[l - 1], &list[l]) {
        l -= 1;
    }
    while r + 1 < list.len() && joins(&list[r], &list[r + 1]) {
        r += 1;
    }
    if l == r {
        return 0;
    }
    let mut pieces = Vec::new();
    decompose(&list[l..=r], &mut pieces);
    let removed = (r + 1 - l) - pieces.len();
    list.splice(l..=r, pieces);
    removed
}

/// Merges two canonical lists of the same pixel into `out` (cleared first).
/// With `partial`, chains that now join are re-merged. Returns how many
/// entries the merge removed.
pub fn merge(a: &[Segment], b: &[Segment], partial: bool, out: &mut Vec<Segment>) -> usize {
    out.clear();
    let (mut i, mut j) = (0, 0);
    while i < a.len() && j < b.len() {
        if order(&a[i], &b[j]) != Ordering::Greater {
            out.push(a[i]);
            i += 1;
        } else {
            out.push(b[j]);
            j += 1;
        }
    }
    out.extend_from_slice(&a[i..]);
    out.extend_from_slice(&b[j..]);
    if partial {
        canonicalize(out)
    } else {
        0
    }
}

/// Re-merges every chain of a sorted list into its maximal early-mergeable
/// pieces. Returns how many entries that removed.
pub fn canonicalize(list: &mut Vec<Segment>) -> usize {
    let n = list.len();
    if n < 2 || !list.windows(2).any(|w| joins(&w[0], &w[1])) {
        return 0;
    }
    let src = std::mem::take(list);
    let mut start = 0;
    for end in 1..=n {
        if end == n || !joins(&src[end - 1], &src[end]) {
            decompose(&src[start..end], list);
            start = end;
        }
    }
    n - list.len()
}

/// Cuts one chain of pieces into its maximal early-mergeable sub-runs and
/// pushes their values onto `out`.
///
/// Boundaries `b_0..b_m` of `m` pieces: `b_0` and `b_m` are the chain's ends
/// (keys of its own depths, an upper bound of the truth), the others the
/// inner boundaries. Inner boundary `i` must stay a cut iff
/// `key_i <= max(min(keys left of i), min(keys right of i))`; otherwise the
/// nearest smaller keys on either side bound a sub-run containing it whose
/// inner keys all exceed both ends.
fn decompose(chain: &[Segment], out: &mut Vec<Segment>) {
    let m = chain.len();
    if m == 1 {
        out.push(chain[0]);
        return;
    }
    let mut keys = Vec::with_capacity(m + 1);
    keys.push(depth_key(chain[0].z_front));
    keys.extend(chain.windows(2).map(|w| boundary_key(&w[0], &w[1])));
    keys.push(depth_key(chain[m - 1].z_back));
    // suffix[i] = min(keys[i..]).
    let mut suffix = keys.clone();
    for i in (0..m).rev() {
        suffix[i] = suffix[i].min(suffix[i + 1]);
    }
    let mut prefix = keys[0];
    let mut start = 0;
    for i in 1..m {
        if keys[i] <= prefix.max(suffix[i + 1]) {
            out.push(evaluate(&chain[start..i], &keys[start + 1..i]));
            start = i;
        }
        prefix = prefix.min(keys[i]);
    }
    out.push(evaluate(&chain[start..], &keys[start + 1..m]));
}

/// The treap value of a run of joined pieces with inner boundary keys
/// `inner` (`inner.len() == run.len() - 1`): split at the smallest key,
/// leftmost on ties. Operator-precedence parsing makes it iterative: a higher
/// key binds tighter, equal keys associate to the right.
fn evaluate(run: &[Segment], inner: &[u32]) -> Segment {
    debug_assert_eq!(inner.len() + 1, run.len());
    if run.len() == 1 {
        return run[0];
    }
    let mut values: Vec<Segment> = Vec::with_capacity(run.len());
    let mut ops: Vec<u32> = Vec::with_capacity(inner.len());
    let reduce = |values: &mut Vec<Segment>| {
        let back = values.pop().expect("operand");
        let front = values.pop().expect("operand");
        values.push(front.merged_with(back));
    };
    values.push(run[0]);
    for (k, s) in inner.iter().zip(&run[1..]) {
        while ops.last().is_some_and(|top| top > k) {
            ops.pop();
            reduce(&mut values);
        }
        ops.push(*k);
        values.push(*s);
    }
    while ops.pop().is_some() {
        reduce(&mut values);
    }
    values[0]
}

/// The canonical pixel value of a sorted list (canonical pieces or raw
/// segments, with or without partial composition): each chain evaluated as a
/// whole by the treap rule, then the chains composited front to back.
///
/// This is the one function the sequential renderer and every compositor
/// call for final composition.
pub fn composite(list: &[Segment]) -> Rgba {
    let mut acc = Rgba::CLEAR;
    let mut chain: Vec<Segment> = Vec::new();
    let mut keys: Vec<u32> = Vec::new();
    for s in list.iter().filter(|s| !is_clear(s)) {
        if let Some(last) = chain.last() {
            if joins(last, s) {
                keys.push(boundary_key(last, s));
            } else {
                acc = acc.over(evaluate(&chain, &keys).rgba);
                chain.clear();
                keys.clear();
            }
        }
        chain.push(*s);
    }
    if !chain.is_empty() {
        acc = acc.over(evaluate(&chain, &keys).rgba);
    }
    acc
}

/// A final pixel over the background, exactly as the renderer writes it:
/// `rgb + (1 - a) * bg`, alpha kept.
#[inline]
pub fn over_background(c: Rgba, bg: [f32; 3]) -> [f32; 4] {
    let keep = 1.0 - c.a;
    [
        c.rgb[0] + keep * bg[0],
        c.rgb[1] + keep * bg[1],
        c.rgb[2] + keep * bg[2],
        c.a,
    ]
}

#[cfg(test)]
mod tests;
