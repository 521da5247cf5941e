//! A parallel, stable counting sort ("bucket scatter") of an enumeration
//! that is split into chunks: the sparse orders' output stage.
//!
//! An [`Enumerate`] lists items chunk by chunk; each item carries a bucket
//! `b < buckets`. The output is every item, mapped by `emit`, sorted by
//! bucket and, within a bucket, in enumeration order (chunk `0` first, each
//! chunk in its own order): exactly what the serial stable counting sort of
//! the concatenated enumeration gives. Two parallel passes over the chunks:
//!
//! 1. count `n[c][b]`, the items of chunk `c` in bucket `b`;
//! 2. with `start[c][b] = Σ_{(b', c') < (b, c)} n[c'][b']` (bucket-major,
//!    chunk-minor prefix sums, a serial loop over `buckets x chunks` counts),
//!    chunk `c` writes its items of bucket `b` to `start[c][b] ..
//!    start[c][b] + n[c][b]`, in its own order.
//!
//! The ranges are disjoint, so the chunks write without locks; every write
//! is checked to stay inside its own range, and each chunk must end every
//! range exactly full (the two passes enumerate the same items), so every
//! slot is written exactly once before the length is set.

use rayon::prelude::*;

/// Items listed chunk by chunk, each with a bucket.
pub trait Enumerate<I>: Sync {
    /// Calls `f(bucket, item)` for every item of chunk `c`, in order. Must
    /// list the same items each time it is called.
    fn each(&self, c: usize, f: impl FnMut(usize, I));
}

/// The output buffer, shared by the writing chunks.
struct Dst<S>(*mut S);

// SAFETY: the chunks write disjoint slots (module doc), each chunk from one
// thread; `S: Send` lets the values cross threads.
unsafe impl<S: Send> Sync for Dst<S> {}
unsafe impl<S: Send> Send for Dst<S> {}

impl<S> Dst<S> {
    /// The pointer (a method, so that closures capture the whole `Dst`).
    fn ptr(&self) -> *mut S {
        self.0
    }
}

/// Appends `e`'s items of chunks `0 .. chunks`, mapped by `emit`, to `out`,
/// sorted stably by bucket (`< buckets`); module doc. Returns where each
/// bucket starts in `out` (`buckets + 1` entries, the last `out.len()`).
pub fn scatter<I, S, E>(
    e: &E,
    chunks: usize,
    buckets: usize,
    emit: &(impl Fn(I) -> S + Sync),
    out: &mut Vec<S>,
) -> Vec<usize>
where
    E: Enumerate<I>,
    S: Send,
{
    let counts: Vec<Vec<usize>> = (0..chunks)
        .into_par_iter()
        .map(|c| {
            let mut n = vec![0usize; buckets];
            e.each(c, |b, _| n[b] += 1);
            n
        })
        .collect();
    let base = out.len();
    let mut starts = counts.clone();
    let mut bucket_starts = Vec::with_capacity(buckets + 1);
    let mut acc = base;
    for b in 0..buckets {
        bucket_starts.push(acc);
        for (st, n) in starts.iter_mut().zip(&counts) {
            st[b] = acc;
            acc += n[b];
        }
    }
    bucket_starts.push(acc);
    let total = acc - base;
    out.reserve(total);
    crate::render::splat::mem::advise_huge(out);
    let dst = Dst(out.as_mut_ptr());
    let full = starts
        .into_par_iter()
        .zip(counts.par_iter())
        .enumerate()
        .map(|(c, (mut next, n))| {
            let ends: Vec<usize> = next.iter().zip(n).map(|(s, n)| s + n).collect();
            e.each(c, |b, item| {
                let k = next[b];
                assert!(
                    k < ends[b],
                    "scatter: chunk {c} listed more items than it counted"
                );
                // SAFETY: `k` is inside chunk c's own range of bucket b
                // (checked), inside the reserved capacity (`ends <= base +
                // total`), and written once (`next[b]` only grows).
                unsafe { dst.ptr().add(k).write(emit(item)) };
                next[b] = k + 1;
            });
            next == ends
        })
        .collect::<Vec<bool>>();
    assert!(
        full.iter().all(|&f| f),
        "scatter: a chunk listed fewer items than it counted"
    );
    // SAFETY: every slot `base .. base + total` was written exactly once
    // (each chunk filled each of its ranges, and the ranges tile the slots).
    unsafe { out.set_len(base + total) };
    bucket_starts
}

#[cfg(test)]
mod tests {
    use super::*;

    struct Items(Vec<Vec<(usize, u32)>>);

    impl Enumerate<u32> for Items {
        fn each(&self, c: usize, mut f: impl FnMut(usize, u32)) {
            self.0[c].iter().for_each(|&(b, x)| f(b, x));
        }
    }

    /// The scatter equals the serial stable sort by bucket of the
    /// concatenated chunks, appended after what `out` held.
    #[test]
    fn scatter_is_the_stable_counting_sort() {
        let mut seed = 12345u64;
        let mut rnd = |m: u64| {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 33) % m
        };
        for (chunks, buckets) in [(1, 1), (3, 1), (1, 5), (7, 13), (16, 40)] {
            let items = Items(
                (0..chunks)
                    .map(|_| {
                        let n = rnd(30) as usize;
                        (0..n)
                            .map(|_| (rnd(buckets as u64) as usize, rnd(1000) as u32))
                            .collect()
                    })
                    .collect(),
            );
            let mut want: Vec<(usize, u32)> = items.0.concat();
            want.sort_by_key(|x| x.0);
            let mut out = vec![(usize::MAX, 7u32)];
            let starts = scatter(&items, chunks, buckets, &|x: u32| (0usize, x), &mut out);
            assert_eq!(out.len(), want.len() + 1);
            assert_eq!(starts.len(), buckets + 1);
            assert_eq!((starts[0], starts[buckets]), (1, out.len()));
            for (b, range) in starts.windows(2).enumerate() {
                let n = want.iter().filter(|x| x.0 == b).count();
                assert_eq!(range[1] - range[0], n, "bucket {b}");
            }
            assert_eq!(out[0], (usize::MAX, 7));
            let got: Vec<u32> = out[1..].iter().map(|x| x.1).collect();
            let want: Vec<u32> = want.iter().map(|x| x.1).collect();
            assert_eq!(got, want, "{chunks} chunks, {buckets} buckets");
        }
    }
}
