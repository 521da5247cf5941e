//! A stable least-significant-digit radix sort of `(key, value)` pairs by a
//! 32-bit key: four counting passes of one byte each, skipping a pass whose
//! byte is the same for every key (common for the high byte of depths).
//!
//! Used to put a frame's cells in front-to-back order once, before binning:
//! O(n) where a comparison sort needs O(n log n), and stable, so cells with
//! equal keys stay in the order they came in (cell id order), which makes the
//! result identical to sorting by `(key, cell id)`.

/// Sorts `items` by `key`, stably. `scratch` is reused between calls; the
/// result is always in `items`' own buffer (after an odd number of passes
/// it is copied back rather than the buffers swapped: swapping would hand
/// each sorted bin the scratch's buffer and leave its own, once freed, as
/// resident garbage the size of every bin).
pub fn sort_by_key_u32<T: Copy + Default>(
    items: &mut Vec<T>,
    scratch: &mut Vec<T>,
    key: impl Fn(&T) -> u32,
) {
    let n = items.len();
    if n < 2 {
        return;
    }
    // One histogram per byte, all filled in a single pass over the keys.
    let mut counts = [[0usize; 256]; 4];
    for it in items.iter() {
        let k = key(it);
        for (b, c) in counts.iter_mut().enumerate() {
            c[((k >> (8 * b)) & 0xff) as usize] += 1;
        }
    }
    scratch.clear();
    scratch.resize(n, T::default());
    let mut swapped = false;
    for (b, c) in counts.iter().enumerate() {
        // Every key has the same byte here: this pass would not move anything.
        if c.contains(&n) {
            continue;
        }
        let mut offsets = [0usize; 256];
        let mut sum = 0;
        for (o, &m) in offsets.iter_mut().zip(c.iter()) {
            *o = sum;
            sum += m;
        }
        let shift = 8 * b;
        for &it in items.iter() {
            let d = ((key(&it) >> shift) & 0xff) as usize;
            scratch[offsets[d]] = it;
            offsets[d] += 1;
        }
        std::mem::swap(items, scratch);
        swapped = !swapped;
    }
    if swapped {
        scratch.copy_from_slice(items);
        std::mem::swap(items, scratch);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #[test]
        fn equals_a_stable_comparison_sort(keys in proptest::collection::vec(any::<u32>(), 0..2000),
                                           narrow in any::<bool>()) {
            // `narrow` keeps the keys in a small range so that ties and
            // skipped passes both occur.
            let items: Vec<(u32, u32)> = keys
                .iter()
                .enumerate()
                .map(|(i, &k)| (if narrow { k % 7 + 0x3f00_0000 } else { k }, i as u32))
                .collect();
            let mut expect = items.clone();
            expect.sort_by_key(|&(k, _)| k);
            let mut got = items;
            sort_by_key_u32(&mut got, &mut Vec::new(), |it| it.0);
            prop_assert_eq!(got, expect);
        }
    }
}
