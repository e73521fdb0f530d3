//! A counting global allocator: the harness installs it with `#[global_allocator]` and reads the
//! live heap bytes around a renderer's setup to measure `cpu_bytes_per_tet` (CONVENTIONS §7).

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicIsize, Ordering};

static LIVE: AtomicIsize = AtomicIsize::new(0);
static PEAK: AtomicIsize = AtomicIsize::new(0);

/// Wraps the system allocator and counts live bytes.
pub struct CountingAlloc;

unsafe impl GlobalAlloc for CountingAlloc {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        let p = unsafe { System.alloc(layout) };
        if !p.is_null() {
            add(layout.size() as isize);
        }
        p
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        let p = unsafe { System.alloc_zeroed(layout) };
        if !p.is_null() {
            add(layout.size() as isize);
        }
        p
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) };
        LIVE.fetch_sub(layout.size() as isize, Ordering::Relaxed);
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        let p = unsafe { System.realloc(ptr, layout, new_size) };
        if !p.is_null() {
            add(new_size as isize - layout.size() as isize);
        }
        p
    }
}

#[inline]
fn add(n: isize) {
    let now = LIVE.fetch_add(n, Ordering::Relaxed) + n;
    PEAK.fetch_max(now, Ordering::Relaxed);
}

/// Live heap bytes now (0 when the counting allocator is not installed).
pub fn live_bytes() -> isize {
    LIVE.load(Ordering::Relaxed)
}

/// Whether the counting allocator is installed (anything has been counted).
pub fn is_counting() -> bool {
    PEAK.load(Ordering::Relaxed) > 0
}

/// Runs `f` and returns its result with the heap bytes it left allocated (its retained memory)
/// and the peak above the starting point while it ran.
pub fn measure<T>(f: impl FnOnce() -> T) -> (T, isize, isize) {
    let before = live_bytes();
    PEAK.store(before, Ordering::Relaxed);
    let out = f();
    let after = live_bytes();
    (out, after - before, PEAK.load(Ordering::Relaxed) - before)
}
