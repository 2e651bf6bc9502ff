//! densepack: dense random packings of hard particles.
#![warn(missing_docs)]

pub mod analysis;
pub mod bench;
pub mod boundary;
pub mod geometry;
pub mod io;
pub mod kernel;
pub mod memory;
pub mod protocol;
pub mod queue;
pub mod run;
pub mod shape;
pub mod spatial;
pub mod verify;

/// Hints the processor to load the cache lines of `value` (a no-op where there is no
/// prefetch instruction). Written here: no maintained crate offers a portable prefetch.
///
/// One hint per 64 bytes from the start, plus one for the last byte unless `T` is aligned
/// to whole lines: a value that does not start on a line boundary touches one line more
/// than its size suggests. The count is a compile-time constant, so the hints unroll
/// without a branch (counting the lines the address actually touches costs a
/// data-dependent loop per partner).
#[inline(always)]
pub(crate) fn prefetch<T>(value: &T) {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
        let start = value as *const T as *const i8;
        let size = std::mem::size_of::<T>();
        let mut offset = 0;
        while offset < size {
            // SAFETY: prefetching never faults, and the address lies inside `value`.
            unsafe { _mm_prefetch::<_MM_HINT_T0>(start.wrapping_add(offset)) };
            offset += 64;
        }
        if !std::mem::align_of::<T>().is_multiple_of(64) {
            let last = start.wrapping_add(size.saturating_sub(1));
            // SAFETY: as above.
            unsafe { _mm_prefetch::<_MM_HINT_T0>(last) };
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = value;
}
