//! Small utilities the renderers share: the counting allocator, heaviest-first scheduling,
//! checked 64-bit sizes and a cache prefetch hint.

pub mod alloc;
#[cfg(test)]
pub(crate) mod rng;
pub mod schedule;
pub mod size;

/// A hint to bring the cache line at `p` in (a no-op where there is no such instruction). `p`
/// need not point into anything: a prefetch never faults, so an index past an array (a link
/// to the boundary) may be passed as it is.
#[inline(always)]
pub(crate) fn prefetch<T>(p: *const T) {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: a prefetch has no architectural effect and never faults (SSE is baseline).
    unsafe {
        use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
        _mm_prefetch::<_MM_HINT_T0>(p.cast());
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = p;
}
