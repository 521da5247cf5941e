//! A stable least-significant-digit radix sort of `(key, value)` pairs by a
//! 32-bit key, in as few counting passes as the keys need: only the bits
//! that differ between keys are sorted on, in digits of at most 12 bits
//! (a 4096-entry histogram stays in the first-level cache). Depth keys of
//! one frame share their high bits, so a bin usually takes two passes where
//! byte digits took three.
//!
//! Used to put a frame's cells in front-to-back order once, before binning:
//! O(n) where a comparison sort needs O(n log n), and stable, so cells with
//! equal keys stay in the order they came in (cell id order), which makes the
//! result identical to sorting by `(key, cell id)`.

/// Widest digit sorted in one pass, bits.
const MAX_DIGIT: u32 = 12;

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
    // The bits in which some key differs from the first: only they order.
    let k0 = key(&items[0]);
    let differ = items.iter().fold(0, |m, it| m | (key(it) ^ k0));
    if differ == 0 {
        return;
    }
    let (low, high) = (differ.trailing_zeros(), 32 - differ.leading_zeros());
    let passes = (high - low).div_ceil(MAX_DIGIT);
    let width = (high - low).div_ceil(passes);
    let mask = (1u32 << width) - 1;
    // One histogram per digit, all filled in a single pass over the keys.
    let mut counts = vec![0usize; (passes as usize) << width];
    for it in items.iter() {
        let k = key(it) >> low;
        for (p, c) in counts.chunks_exact_mut(1 << width).enumerate() {
            c[((k >> (width * p as u32)) & mask) as usize] += 1;
        }
    }
    scratch.clear();
    scratch.resize(n, T::default());
    let mut swapped = false;
    for (p, c) in counts.chunks_exact_mut(1 << width).enumerate() {
        // Every key has the same digit here: this pass would not move anything.
        if c.contains(&n) {
            continue;
        }
        let mut sum = 0;
        for o in c.iter_mut() {
            let m = *o;
            *o = sum;
            sum += m;
        }
        let shift = low + width * p as u32;
        for &it in items.iter() {
            let d = ((key(&it) >> shift) & mask) as usize;
            scratch[c[d]] = it;
            c[d] += 1;
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
                                           spread in 0u32..4) {
            // Keys differing in a few low bits (ties, one pass), in 24
            // bits under a shared high byte (as depths do: two passes), in
            // a middle run of bits (low bits shared), or anywhere.
            let items: Vec<(u32, u32)> = keys
                .iter()
                .enumerate()
                .map(|(i, &k)| {
                    let k = match spread {
                        0 => k % 7 + 0x3f00_0000,
                        1 => (k & 0x00ff_ffff) | 0x3f00_0000,
                        2 => (k & 0x0ff0_0000) | 0x5,
                        _ => k,
                    };
                    (k, i as u32)
                })
                .collect();
            let mut expect = items.clone();
            expect.sort_by_key(|&(k, _)| k);
            let mut got = items;
            sort_by_key_u32(&mut got, &mut Vec::new(), |it| it.0);
            prop_assert_eq!(got, expect);
        }
    }
}
