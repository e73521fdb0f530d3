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
        radix_sort_hi32(&mut self.a, &mut self.b);
        order.clear();
        order.extend(self.a.iter().map(|&x| x as u32));
        Ok(SortStats::default())
    }
}

/// Stable LSD radix sort of `v` by its high 32 bits; `tmp` is scratch.
pub(crate) fn radix_sort_hi32(v: &mut Vec<u64>, tmp: &mut Vec<u64>) {
    let n = v.len();
    let mut hist = [[0usize; BUCKETS]; PASSES];
    for &x in v.iter() {
        let k = (x >> 32) as u32;
        for (p, h) in hist.iter_mut().enumerate() {
            h[((k >> (BITS * p as u32)) as usize) & (BUCKETS - 1)] += 1;
        }
    }
    tmp.clear();
    tmp.resize(n, 0);
    for (p, h) in hist.iter_mut().enumerate() {
        if h.contains(&n) {
            continue; // every key has the same digit: the pass would not move anything
        }
        let mut sum = 0;
        for c in h.iter_mut() {
            let x = *c;
            *c = sum;
            sum += x;
        }
        let shift = 32 + BITS * p as u32;
        for &x in v.iter() {
            let d = ((x >> shift) as usize) & (BUCKETS - 1);
            tmp[h[d]] = x;
            h[d] += 1;
        }
        std::mem::swap(v, tmp);
    }
}
