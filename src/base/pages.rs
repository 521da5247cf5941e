//! Giving a buffer's pages back to the kernel the moment it is done with,
//! whatever the allocator does with the freed block.
//!
//! A frame of a large mesh builds its bins from per-chunk buffers that it
//! reads once; freed, their memory may stay resident in the allocator's heap
//! while the bins fill, so the frame's peak holds both. [`release`] empties
//! the buffer's whole pages first (`MADV_DONTNEED` on private anonymous
//! memory: the pages are unmapped now and read as zeros if touched again),
//! then frees the buffer.

/// Page size assumed (4 KiB: the smallest on x86-64 and aarch64 Linux; a
/// larger real page only makes the advice cover fewer pages).
const PAGE: usize = 4096;

/// Frees `v`, first giving the pages wholly inside its allocation back to
/// the kernel (Linux; elsewhere, and below 64 KiB, just frees it).
pub fn release<T>(mut v: Vec<T>) {
    v.clear();
    let bytes = v.capacity() * std::mem::size_of::<T>();
    if bytes >= 16 * PAGE {
        let start = v.as_mut_ptr() as usize;
        let lo = start.next_multiple_of(PAGE);
        let hi = (start + bytes) / PAGE * PAGE;
        #[cfg(target_os = "linux")]
        if hi > lo {
            // SAFETY: `[lo, hi)` is page aligned and lies inside `v`'s
            // allocation, which holds no live value (cleared above) and is
            // freed next: nothing reads the zeroed pages as data (an
            // allocator writes its free-list links into a block when it is
            // freed, after this, and keeps nothing in a block in use).
            unsafe {
                libc::madvise(lo as *mut libc::c_void, hi - lo, libc::MADV_DONTNEED);
            }
        }
        #[cfg(not(target_os = "linux"))]
        let _ = (lo, hi);
    }
    drop(v);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn released_buffers_can_be_allocated_and_used_again() {
        for _ in 0..4 {
            let v: Vec<u64> = (0..100_000).collect();
            assert_eq!(v[99_999], 99_999);
            release(v);
            let w = vec![7u64; 100_000];
            assert!(w.iter().all(|&x| x == 7));
            release(w);
        }
        release(Vec::<u8>::new());
        release(vec![1u8; 10]);
    }
}
