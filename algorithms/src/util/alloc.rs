//! A counting global allocator: the harness installs it with `#[global_allocator]` and reads the
//! live heap bytes around a renderer's setup to measure `cpu_bytes_per_tet` (CONVENTIONS §7).
//!
//! Large buffers (images, per-frame scratch, a renderer's tables) are allocated through
//! [`try_vec`], [`try_vec_with_capacity`] and [`try_grow`]: when memory runs out (a batch
//! system's `ulimit -v`, a size too large for the machine) the allocation fails with an error
//! naming the size, which the caller turns into a failed measurement or one line, instead of
//! the process aborting as a plain `Vec` allocation does. Small allocations stay plain: they do
//! not decide whether a run fits.

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

/// A vector of `len` copies of `value`, or an error when memory cannot hold it (see the
/// module docs).
pub fn try_vec<T: Clone>(len: usize, value: T) -> crate::Result<Vec<T>> {
    let mut v = try_vec_with_capacity(len)?;
    v.resize(len, value);
    Ok(v)
}

/// An empty vector with room for `cap` elements (see [`try_vec`]).
pub fn try_vec_with_capacity<T>(cap: usize) -> crate::Result<Vec<T>> {
    let mut v = Vec::new();
    try_grow(&mut v, cap)?;
    Ok(v)
}

/// Makes room for `additional` more elements in `v` (see [`try_vec`]).
pub fn try_grow<T>(v: &mut Vec<T>, additional: usize) -> crate::Result<()> {
    v.try_reserve_exact(additional).map_err(|_| {
        let bytes = additional.saturating_mul(std::mem::size_of::<T>());
        crate::Error::Input(format!(
            "out of memory: {} for {additional} elements could not be allocated",
            human_bytes(bytes)
        ))
    })
}

/// `bytes` in the largest binary unit that keeps it at least 1.
pub fn human_bytes(bytes: usize) -> String {
    const UNITS: [&str; 5] = ["bytes", "KiB", "MiB", "GiB", "TiB"];
    let mut v = bytes as f64;
    let mut u = 0;
    while v >= 1024.0 && u + 1 < UNITS.len() {
        v /= 1024.0;
        u += 1;
    }
    if u == 0 {
        format!("{bytes} bytes")
    } else {
        format!("{v:.1} {}", UNITS[u])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_impossible_allocation_is_an_error_not_an_abort() {
        let e = try_vec::<[f32; 4]>(usize::MAX / 32, [0.0; 4]).unwrap_err();
        let e = e.to_string();
        assert!(e.starts_with("out of memory: ") && e.contains("TiB"), "{e}");
        assert_eq!(try_vec(3, 7u8).unwrap(), vec![7, 7, 7]);
        let mut v = vec![1u32];
        try_grow(&mut v, 10).unwrap();
        assert!(v.capacity() >= 11);
        assert_eq!(human_bytes(512), "512 bytes");
        assert_eq!(human_bytes(3 << 30), "3.0 GiB");
    }
}
