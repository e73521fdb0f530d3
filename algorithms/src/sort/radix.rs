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
use rayon::prelude::*;

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
        let key = |t: usize, c: &[f32; 3]| ((desc_bits(kf.key(c)) as u64) << 32) | t as u64;
        let n = self.centroids.len();
        let parts = rayon::current_num_threads().min(n / PAR_MIN_PART);
        if parts < 2 {
            self.a.clear();
            self.a.extend(self.centroids.iter().enumerate().map(|(t, c)| key(t, c)));
            radix_sort_hi32(&mut self.a, &mut self.b);
            order.clear();
            order.extend(self.a.iter().map(|&x| x as u32));
        } else {
            par_radix_sort_hi32(&self.centroids, key, parts, &mut self.a, &mut self.b);
            order.resize(n, 0);
            order.par_iter_mut().zip(&self.a).for_each(|(o, &x)| *o = x as u32);
        }
        Ok(SortStats::default())
    }
}

/// The least keys a part of the parallel sort takes: below 2 × this the sort runs on one thread
/// (on blunt's 187 K keys a split sort was 1.6× slower: the per-part counts and the threads'
/// start cost more than they save).
const PAR_MIN_PART: usize = 1 << 17;

/// Digit counts of every pass, fused in one read: `hist[p][d]`.
type Hist = [[usize; BUCKETS]; PASSES];

#[inline(always)]
fn count(h: &mut Hist, x: u64) {
    let k = (x >> 32) as u32;
    for (p, h) in h.iter_mut().enumerate() {
        h[((k >> (BITS * p as u32)) as usize) & (BUCKETS - 1)] += 1;
    }
}

/// Stable LSD radix sort of `v` by its high 32 bits; `tmp` is scratch.
pub(crate) fn radix_sort_hi32(v: &mut Vec<u64>, tmp: &mut Vec<u64>) {
    let n = v.len();
    let mut hist = [[0usize; BUCKETS]; PASSES];
    for &x in v.iter() {
        count(&mut hist, x);
    }
    // Every place of `tmp` is written by each pass: resized (and zeroed) only when `n` changed.
    if tmp.len() != n {
        tmp.clear();
        tmp.resize(n, 0);
    }
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

/// The same sort as [`radix_sort_hi32`] of the pairs `key(t, &items[t])`, split in `parts`
/// contiguous parts on rayon's threads: each part builds its keys and counts their digits in
/// one go; per pass each part scatters its keys into its own places of every digit's range
/// (part 0's first, so the sort stays stable), and counts the next pass's digits of its part of
/// the result. The places are disjoint `&mut` slices of `tmp`, so no two threads write one.
pub(crate) fn par_radix_sort_hi32<T: Sync>(
    items: &[T],
    key: impl Fn(usize, &T) -> u64 + Sync,
    parts: usize,
    v: &mut Vec<u64>,
    tmp: &mut Vec<u64>,
) {
    let n = items.len();
    let part = n.div_ceil(parts);
    for b in [&mut *v, &mut *tmp] {
        if b.len() != n {
            b.clear();
            b.resize(n, 0);
        }
    }
    let mut hists: Vec<Box<Hist>> = v
        .par_chunks_mut(part)
        .zip(items.par_chunks(part))
        .enumerate()
        .map(|(i, (out, it))| {
            let mut h = Box::new([[0usize; BUCKETS]; PASSES]);
            for (j, (o, x)) in out.iter_mut().zip(it).enumerate() {
                *o = key(i * part + j, x);
                count(&mut h, *o);
            }
            h
        })
        .collect();
    let mut total = [[0usize; BUCKETS]; PASSES];
    for h in &hists {
        for (t, h) in total.iter_mut().zip(h.iter()) {
            for (t, h) in t.iter_mut().zip(h) {
                *t += h;
            }
        }
    }
    let passes: Vec<usize> = (0..PASSES).filter(|&p| !total[p].contains(&n)).collect();
    for (i, &p) in passes.iter().enumerate() {
        if i > 0 {
            // The parts of `v` hold other keys now: count this pass's digits again.
            let shift = 32 + BITS * p as u32;
            v.par_chunks(part).zip(hists.par_iter_mut()).for_each(|(c, h)| {
                h[p] = [0; BUCKETS];
                for &x in c {
                    h[p][((x >> shift) as usize) & (BUCKETS - 1)] += 1;
                }
            });
        }
        // Digit d's range of `tmp`, cut into the parts' places in part order.
        let mut places: Vec<Vec<&mut [u64]>> = (0..hists.len()).map(|_| Vec::with_capacity(BUCKETS)).collect();
        let mut rest: &mut [u64] = tmp;
        for d in 0..BUCKETS {
            for (pl, h) in places.iter_mut().zip(&hists) {
                let (a, b) = std::mem::take(&mut rest).split_at_mut(h[p][d]);
                pl.push(a);
                rest = b;
            }
        }
        let shift = 32 + BITS * p as u32;
        v.par_chunks(part).zip(places.into_par_iter()).for_each(|(c, mut pl)| {
            for &x in c {
                let d = ((x >> shift) as usize) & (BUCKETS - 1);
                let (first, rest) = std::mem::take(&mut pl[d]).split_first_mut().expect("counted");
                *first = x;
                pl[d] = rest;
            }
        });
        std::mem::swap(v, tmp);
    }
}
