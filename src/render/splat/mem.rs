//! Transparent huge pages for the frame's large buffers.
//!
//! A splatting frame writes a few hundred MB of fresh memory (the splat
//! list, 24 bytes per drawn voxel in orthographic views, 44 in perspective
//! ones: 91 or 166 MB at 23 % fill of 256^3; the mask payloads and the
//! band bins). With 4 KiB pages every first touch is a page fault (tens of
//! thousands per frame; 16 % of the samples of `perf record` at 23 % fill,
//! session 7). Where the kernel's transparent huge pages are in `madvise`
//! mode, advising the buffer's 2 MiB-aligned interior with `MADV_HUGEPAGE`
//! before it is written makes those faults 512 times fewer. Advice only:
//! where it is refused (other kernels, THP off) nothing changes but speed.

/// Huge page size on x86-64 and aarch64 Linux (2 MiB).
const HUGE: usize = 2 << 20;

/// Advises the kernel to back the not yet touched memory of `v`'s spare
/// capacity with huge pages (Linux; a no-op elsewhere or below 4 MiB).
pub fn advise_huge<T>(v: &mut Vec<T>) {
    let spare = v.spare_capacity_mut();
    let bytes = std::mem::size_of_val(spare);
    if bytes < 2 * HUGE {
        return;
    }
    let start = spare.as_mut_ptr() as usize;
    let lo = start.next_multiple_of(HUGE);
    let hi = (start + bytes) / HUGE * HUGE;
    if hi <= lo {
        return;
    }
    #[cfg(target_os = "linux")]
    // SAFETY: `[lo, hi)` lies inside `v`'s allocation (its spare capacity),
    // is page aligned, and MADV_HUGEPAGE changes no contents, only how the
    // pages are backed; the result is advisory and ignored.
    unsafe {
        libc::madvise(lo as *mut libc::c_void, hi - lo, libc::MADV_HUGEPAGE);
    }
}
