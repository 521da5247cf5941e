//! A reference composition of several nodes' whole-screen lists: per pixel,
//! all segments of all nodes sorted by `z_front` (stable: ties keep node
//! order, then list order), composited front to back with "over", then over
//! the background — the single-machine renderer's final composition
//! applied to the merged list. The paper merges the lists before the final
//! composition (§2.2, Fig. 4); merging by partial composition first would
//! only re-associate the same "over" products.
//!
//! This is for tests and checks (the image invariant of the node module);
//! the cluster's compositor (direct send, binary swap) lives elsewhere.

use crate::base::segment::{Rgba, Segment};
use crate::image::Image;
use crate::render::cell::list::SegmentLists;

/// Composites the union of `lists` (all `width x height`) over `background`.
pub fn composite_union(lists: &[&SegmentLists], background: [f64; 3]) -> Image {
    let (w, h) = lists.first().map(|l| (l.width, l.height)).unwrap_or((0, 0));
    assert!(
        lists.iter().all(|l| (l.width, l.height) == (w, h)),
        "all lists must cover the same image"
    );
    let bg = background.map(|c| c as f32);
    let mut image = Image::new(w, h);
    let mut merged: Vec<Segment> = Vec::new();
    for (idx, px) in image.pixels.iter_mut().enumerate() {
        merged.clear();
        for l in lists {
            merged.extend_from_slice(l.list(idx));
        }
        merged.sort_by(|a, b| a.z_front.total_cmp(&b.z_front));
        let c = merged.iter().fold(Rgba::CLEAR, |acc, s| acc.over(s.rgba));
        let keep = 1.0 - c.a;
        *px = [
            c.rgb[0] + keep * bg[0],
            c.rgb[1] + keep * bg[1],
            c.rgb[2] + keep * bg[2],
            c.a,
        ];
    }
    image
}
