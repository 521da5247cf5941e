//! Per-pixel ray-segment lists with partial composition (paper §2.1).
//!
//! A list holds the segments of one pixel sorted by `z_front`. Inserting a
//! segment that touches its predecessor (`pred.z_back == new.z_front`) or
//! successor (`new.z_back == succ.z_front`) merges them with the "over"
//! operator instead of storing it: *partial composition*. Merging never loses
//! light (over is associative), keeps lists short, and a merged segment's alpha
//! only grows — which is what early ray termination feeds on.

use super::watch::TerminationWatch;
use crate::base::segment::{touches, Rgba, Segment};

/// The ray-segment lists of a rectangle of pixels (a screen tile).
#[derive(Debug, Clone, Default)]
pub struct SegmentLists {
    /// Width of the rectangle in pixels.
    pub width: u32,
    /// Height of the rectangle in pixels.
    pub height: u32,
    lists: Vec<Vec<Segment>>,
    /// Whether insertions record the pixels they change (early ray termination).
    track: bool,
    /// Per pixel: changed since the last [`SegmentLists::drain_changed`].
    changed_flag: Vec<bool>,
    /// The changed pixels, each once.
    changed: Vec<u32>,
    /// With [`SegmentLists::track_terminations`]: which changes to record
    /// (else every one).
    watch: Option<TerminationWatch>,
}

/// What one insertion did.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Inserted {
    /// Stored as a new list entry.
    New,
    /// Merged with one neighbour.
    Merged,
    /// Merged with both neighbours (the list got one entry shorter).
    MergedBoth,
}

impl SegmentLists {
    /// Empty lists for a `width x height` rectangle.
    pub fn new(width: u32, height: u32) -> SegmentLists {
        SegmentLists {
            width,
            height,
            lists: vec![Vec::new(); width as usize * height as usize],
            ..Default::default()
        }
    }

    /// From now on, record which pixels' lists change (for the incremental
    /// rebuild of the early-ray-termination structures). Off by default, so a
    /// render without ERT pays one predictable branch per insertion.
    pub fn track_changes(&mut self) {
        self.track = true;
        self.changed_flag = vec![false; self.lists.len()];
    }

    /// From now on, record only the changes of lists that can have reached
    /// `threshold` (below 1), as the ERT scan's drain needs them: see
    /// [`TerminationWatch`]. Lists far from terminating are neither
    /// listed nor walked, and the depths drained are the same as with
    /// [`SegmentLists::track_changes`]. Lists that hold segments already
    /// and may have crossed are recorded as changed.
    pub fn track_terminations(&mut self, threshold: f32) {
        self.track_changes();
        let Self {
            lists,
            changed_flag,
            changed,
            ..
        } = self;
        let watch = TerminationWatch::new(lists, threshold, |i| {
            record_change(changed_flag, changed, i)
        });
        self.watch = Some(watch);
    }

    /// Calls `f(idx, list)` for every pixel whose list changed since the last
    /// call (or since tracking began), then forgets them.
    pub fn drain_changed(&mut self, mut f: impl FnMut(usize, &[Segment])) {
        for &idx in &self.changed {
            let idx = idx as usize;
            self.changed_flag[idx] = false;
            f(idx, &self.lists[idx]);
        }
        self.changed.clear();
    }

    /// After inserting a segment of opacity `alpha` into pixel `idx`:
    /// records the change (see [`SegmentLists::track_terminations`]).
    #[inline(always)]
    fn noted(&mut self, idx: usize, alpha: f32) {
        let record = match &mut self.watch {
            _ if !self.track => false,
            Some(w) => w.inserted(idx, alpha),
            None => true,
        };
        if record {
            record_change(&mut self.changed_flag, &mut self.changed, idx);
        }
    }

    /// Whether inserting the queued segments of pixels `idx`, `len[l]`
    /// world units long, of optical depth at most `depth(len[l])`, may
    /// record a change, or changes wait to be drained: if not, they can
    /// stay queued past the next drain. Always true unless tracking
    /// terminations; see [`TerminationWatch::may_record`].
    pub fn may_record(
        &mut self,
        idx: &[u32],
        len: &[f32],
        depth: impl Fn(f32) -> f32,
        queued_max: usize,
    ) -> bool {
        match &mut self.watch {
            Some(w) if self.changed.is_empty() => w.may_record(idx, len, depth, queued_max),
            _ => true,
        }
    }

    /// Forgets what [`SegmentLists::may_record`] summed for the queued
    /// segments of pixels `idx` (being inserted).
    pub fn forget_queued(&mut self, idx: &[u32]) {
        if let Some(w) = &mut self.watch {
            w.forget_queued(idx);
        }
    }

    /// The list of local pixel `idx` (row-major in the rectangle).
    #[inline]
    pub fn list(&self, idx: usize) -> &[Segment] {
        &self.lists[idx]
    }

    /// All lists, row-major.
    pub fn lists(&self) -> &[Vec<Segment>] {
        &self.lists
    }

    /// Inserts `seg` into the list of local pixel `idx`, merging with touching
    /// neighbours when `partial` is on.
    #[inline]
    pub fn insert(&mut self, idx: usize, seg: Segment, partial: bool) -> Inserted {
        let done = insert_sorted(&mut self.lists[idx], seg, partial);
        self.noted(idx, seg.rgba.a);
        done
    }

    /// Inserts the segments `(idx[l], z_front[l], z_back[l], rgba(l))` in
    /// turn with partial composition, as [`SegmentLists::insert`] would;
    /// returns how many merges that made. The renderer's common case (cells
    /// in front-to-back order: a segment lands after its list's last one
    /// and usually touches it) skips the general insertion's search and
    /// checks.
    #[inline]
    pub fn insert_partial_run(
        &mut self,
        idx: &[u32],
        z_front: &[f32],
        z_back: &[f32],
        rgba: impl Fn(usize) -> Rgba,
    ) -> u64 {
        let Self {
            lists,
            track,
            changed_flag,
            changed,
            watch,
            ..
        } = self;
        let mut record = |i: usize| record_change(changed_flag, changed, i);
        // One loop for each way of recording, so none decides per segment.
        let run = (idx, z_front, z_back);
        match (*track, watch) {
            (false, _) => partial_run(lists, run, rgba, |_, _| {}),
            (true, None) => partial_run(lists, run, rgba, |i, _| record(i)),
            (true, Some(w)) => {
                let mut w = w.recorder(lists.len());
                partial_run(lists, run, rgba, |i, a| {
                    if w.inserted(i, a) {
                        record(i)
                    }
                })
            }
        }
    }

    /// Inserts `seg` into the list of local pixel `idx` in canonical form
    /// ([`crate::base::canonical::insert`]). Returns how many entries partial
    /// composition removed.
    #[inline]
    pub fn insert_canonical(&mut self, idx: usize, seg: Segment, partial: bool) -> usize {
        let removed = crate::base::canonical::insert(&mut self.lists[idx], seg, partial);
        self.noted(idx, seg.rgba.a);
        removed
    }
}

/// Records that pixel `i`'s list changed (once until the next drain).
#[inline(always)]
fn record_change(flag: &mut [bool], changed: &mut Vec<u32>, i: usize) {
    if !flag[i] {
        flag[i] = true;
        changed.push(i as u32);
    }
}

/// [`SegmentLists::insert_partial_run`] into `lists`, calling
/// `after(pixel, alpha)` after each segment.
#[inline(always)]
fn partial_run(
    lists: &mut [Vec<Segment>],
    (idx, z_front, z_back): (&[u32], &[f32], &[f32]),
    rgba: impl Fn(usize) -> Rgba,
    mut after: impl FnMut(usize, f32),
) -> u64 {
    let mut merged = 0;
    for (l, ((&i, &zf), &zb)) in idx.iter().zip(z_front).zip(z_back).enumerate() {
        let i = i as usize;
        let seg = Segment {
            z_front: zf,
            z_back: zb,
            rgba: rgba(l),
        };
        let list = &mut lists[i];
        match list.last_mut() {
            Some(last) if last.z_front <= zf => {
                if touches(last.z_back, zf) {
                    *last = last.merged_with(seg);
                    merged += 1;
                } else {
                    list.push(seg);
                }
            }
            _ => {
                merged += match insert_sorted(list, seg, true) {
                    Inserted::New => 0,
                    Inserted::Merged => 1,
                    Inserted::MergedBoth => 2,
                }
            }
        }
        after(i, seg.rgba.a);
    }
    merged
}

/// Inserts `seg` into `list` (sorted by `z_front`), with partial composition if `partial`.
#[inline]
pub fn insert_sorted(list: &mut Vec<Segment>, seg: Segment, partial: bool) -> Inserted {
    // Front-to-back cell order makes "after the last one" the common case.
    let pos = match list.last() {
        Some(last) if last.z_front <= seg.z_front => list.len(),
        _ => list.partition_point(|s| s.z_front <= seg.z_front),
    };
    if partial {
        if pos > 0 && touches(list[pos - 1].z_back, seg.z_front) {
            let merged = list[pos - 1].merged_with(seg);
            if pos < list.len() && touches(merged.z_back, list[pos].z_front) {
                list[pos - 1] = merged.merged_with(list[pos]);
                list.remove(pos);
                return Inserted::MergedBoth;
            }
            list[pos - 1] = merged;
            return Inserted::Merged;
        }
        if pos < list.len() && touches(seg.z_back, list[pos].z_front) {
            list[pos] = seg.merged_with(list[pos]);
            return Inserted::Merged;
        }
    }
    list.insert(pos, seg);
    Inserted::New
}

/// Composites a sorted list front to back: the pixel's premultiplied colour and alpha.
#[inline]
pub fn composite(list: &[Segment]) -> Rgba {
    list.iter().fold(Rgba::CLEAR, |acc, s| acc.over(s.rgba))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn seg(zf: f32, zb: f32, a: f32) -> Segment {
        Segment {
            z_front: zf,
            z_back: zb,
            rgba: Rgba {
                rgb: [a * 0.5, a * 0.25, a],
                a,
            },
        }
    }

    #[test]
    fn merges_touching_neighbours() {
        let mut l = Vec::new();
        assert_eq!(
            insert_sorted(&mut l, seg(0.0, 1.0, 0.2), true),
            Inserted::New
        );
        assert_eq!(
            insert_sorted(&mut l, seg(2.0, 3.0, 0.3), true),
            Inserted::New
        );
        assert_eq!(
            insert_sorted(&mut l, seg(1.0, 2.0, 0.4), true),
            Inserted::MergedBoth
        );
        assert_eq!(l.len(), 1);
        assert_eq!((l[0].z_front, l[0].z_back), (0.0, 3.0));
        let want = 1.0 - 0.8 * 0.6 * 0.7;
        assert!((l[0].rgba.a - want).abs() < 1e-6);
    }

    proptest::proptest! {
        /// The batched fast path makes the same lists and counts as
        /// inserting one segment at a time: in order, touching, out of
        /// order, with gaps, into several pixels.
        #[test]
        fn partial_run_equals_one_by_one(
            segs in proptest::collection::vec((0u32..3, 0u8..6, 1u8..3, 0.0f32..1.0), 1..40)
        ) {
            let (mut one, mut run) = (SegmentLists::new(3, 1), SegmentLists::new(3, 1));
            let mut merged_one = 0u64;
            let (mut idx, mut zf, mut zb, mut rgba) = (vec![], vec![], vec![], vec![]);
            for &(px, z, len, a) in &segs {
                let s = seg(z as f32, (z + len) as f32, a);
                merged_one += match one.insert(px as usize, s, true) {
                    Inserted::New => 0,
                    Inserted::Merged => 1,
                    Inserted::MergedBoth => 2,
                };
                idx.push(px);
                zf.push(s.z_front);
                zb.push(s.z_back);
                rgba.push(s.rgba);
            }
            let merged_run = run.insert_partial_run(&idx, &zf, &zb, |l| rgba[l]);
            proptest::prop_assert_eq!(merged_run, merged_one);
            proptest::prop_assert_eq!(run.lists(), one.lists());
        }
    }

    #[test]
    fn keeps_gaps_and_order_without_partial() {
        let mut l = Vec::new();
        for s in [seg(2.0, 3.0, 0.3), seg(0.0, 1.0, 0.2), seg(1.0, 2.0, 0.4)] {
            insert_sorted(&mut l, s, false);
        }
        assert_eq!(
            l.iter().map(|s| s.z_front).collect::<Vec<_>>(),
            vec![0.0, 1.0, 2.0]
        );
    }
}
