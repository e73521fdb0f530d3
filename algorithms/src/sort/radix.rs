//! `centroid-radix`: a stable LSD radix sort of the centroid keys.
//!
//! Written here rather than taken from a crate: it sorts `(key bits, tet)` pairs packed in a u64
//! by the 32 key bits only, three passes of 11 bits, skipping a pass whose digit is the same for
//! every key. The key bits are [`desc_bits`], whose ascending order is the key's descending
//! IEEE total order, and the pairs start in index order, so stability breaks ties by index: the
//! same order as `centroid`.

use super::{centroids, check_prepared, desc_bits, KeyFn, Sort, SortInfo, SortStats};
use crate::camera::Camera;
use crate::error::Result;
use crate::mesh::Mesh;

const BITS: u32 = 11;
const BUCKETS: usize = 1 << BITS;
const PASSES: usize = 3;
/// Sets of digit counts the counting pass keeps (see `radix_sort_into`).
const COPIES: usize = 4;

#[derive(Debug, Default)]
pub struct RadixSort {
    centroids: Vec<[f32; 3]>,
    a: Vec<u64>,
    b: Vec<u64>,
}

/// `centroid-radix`.
pub const CENTROID_RADIX: SortInfo = SortInfo {
    name: "centroid-radix",
    description: "the centroid order by a stable LSD radix sort of the keys' bits, O(n)",
    params: &[],
    lattice_only: false,
    make: |_| Ok(Box::new(RadixSort::default())),
};

impl Sort for RadixSort {
    fn name(&self) -> String {
        "centroid-radix".into()
    }

    fn prepare(&mut self, mesh: &Mesh) -> Result<()> {
        self.centroids = centroids(mesh);
        self.a = Vec::with_capacity(self.centroids.len());
        self.b = Vec::with_capacity(self.centroids.len());
        Ok(())
    }

    fn sort(&mut self, mesh: &Mesh, camera: &Camera, order: &mut Vec<u32>) -> Result<SortStats> {
        check_prepared(&self.name(), self.centroids.len(), mesh)?;
        let kf = KeyFn::for_camera(camera);
        self.a.clear();
        self.a.extend(
            self.centroids
                .iter()
                .enumerate()
                .map(|(t, c)| ((desc_bits(kf.key(c)) as u64) << 32) | t as u64),
        );
        radix_sort_into(&mut self.a, &mut self.b, Some(order));
        Ok(SortStats::default())
    }
}

/// Stable LSD radix sort of `v` by its high 32 bits; `tmp` is scratch.
#[cfg(test)]
pub(crate) fn radix_sort_hi32(v: &mut Vec<u64>, tmp: &mut Vec<u64>) {
    radix_sort_into(v, tmp, None);
}

/// Stable LSD radix sort of `v` by its high 32 bits (`tmp` is scratch); with `order`, the
/// sorted pairs' low 32 bits go there, written by the last pass that moves anything (one
/// pass over the keys fewer than sorting `v` and then copying them out; `v` is then left as
/// that pass found it).
pub(super) fn radix_sort_into(v: &mut Vec<u64>, tmp: &mut Vec<u64>, mut order: Option<&mut Vec<u32>>) {
    let n = v.len();
    // The digit counts, in `COPIES` sets taken by consecutive keys in turn and summed after:
    // neighbouring tets have nearly the same depth, so their high digits mostly repeat, and a
    // single set made each count wait on the one before (the counting pass was 0.7 ms of
    // post's 3.9 ms sort).
    // (Taken whole sets of `COPIES` keys at a time: `sets[i % COPIES]` cost ~9 % more of the
    // sort's instructions.)
    let count = |set: &mut [[u32; BUCKETS]; PASSES], x: u64| {
        let k = (x >> 32) as u32;
        for (p, h) in set.iter_mut().enumerate() {
            h[((k >> (BITS * p as u32)) as usize) & (BUCKETS - 1)] += 1;
        }
    };
    let mut sets = vec![[[0u32; BUCKETS]; PASSES]; COPIES];
    let mut keys = v.chunks_exact(COPIES);
    for xs in &mut keys {
        for (set, &x) in sets.iter_mut().zip(xs) {
            count(set, x);
        }
    }
    for &x in keys.remainder() {
        count(&mut sets[0], x);
    }
    let mut hist = [[0usize; BUCKETS]; PASSES];
    for set in &sets {
        for (h, c) in hist.iter_mut().zip(set) {
            for (a, &b) in h.iter_mut().zip(c) {
                *a += b as usize;
            }
        }
    }
    // A pass whose digit is the same for every key would not move anything.
    let moves = |h: &[usize; BUCKETS]| !h.contains(&n);
    let last = (0..PASSES).rev().find(|&p| moves(&hist[p]));
    tmp.clear();
    tmp.resize(n, 0);
    for (p, h) in hist.iter_mut().enumerate() {
        if !moves(h) {
            continue;
        }
        let mut sum = 0;
        for c in h.iter_mut() {
            let x = *c;
            *c = sum;
            sum += x;
        }
        let shift = 32 + BITS * p as u32;
        let digit = |x: u64| ((x >> shift) as usize) & (BUCKETS - 1);
        match order.as_deref_mut() {
            Some(o) if Some(p) == last => {
                o.clear();
                o.resize(n, 0);
                for &x in v.iter() {
                    let d = digit(x);
                    o[h[d]] = x as u32;
                    h[d] += 1;
                }
                return;
            }
            _ => {
                for &x in v.iter() {
                    let d = digit(x);
                    tmp[h[d]] = x;
                    h[d] += 1;
                }
                std::mem::swap(v, tmp);
            }
        }
    }
    // No pass moved anything (or no order was asked for): the pairs are sorted in `v`.
    if let Some(o) = order {
        o.clear();
        o.extend(v.iter().map(|&x| x as u32));
    }
}
