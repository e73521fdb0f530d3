//! Binning of `cpu-pt`'s tets to tiles: a counting sort of the (tet, tile) pairs of one part of
//! the visibility order by tile, stable in the order, into one flat array (no per-tile `Vec`s).
//! The counts and offsets are 64-bit: a part's pairs are bounded by memory, not by 2³².

use rayon::prelude::*;

use super::project::TileRect;
use crate::util::schedule::heaviest_first;

/// The tets of every tile in visibility order, in one array (a counting sort of the
/// (tet, tile) pairs by tile, stable in the order): tile k's tets are
/// `items[start[k]..start[k + 1]]`, as places in the part.
#[derive(Default)]
pub(super) struct Bins {
    start: Vec<usize>,
    pub(super) items: Vec<u32>,
    /// Per chunk of the part, its running offset per tile.
    offsets: Vec<Vec<usize>>,
}

impl Bins {
    pub(super) fn bytes(&self) -> usize {
        self.start.capacity() * 8
            + self.items.capacity() * 4
            + self.offsets.iter().map(|o| o.capacity() * 8).sum::<usize>()
    }

    pub(super) fn tile(&self, k: usize) -> &[u32] {
        &self.items[self.start[k]..self.start[k + 1]]
    }

    /// `f(k, buf)` of each tile `k` that has tets, with its buffer `bufs[k]`, in parallel; the
    /// tiles are handed to the threads one at a time, those with the most tets first. Returns
    /// the sum of the results (the fragments drawn).
    pub(super) fn per_tile(
        &self,
        bufs: &mut [Vec<[f32; 4]>],
        f: impl Fn(usize, &mut [[f32; 4]]) -> u64 + Sync,
    ) -> u64 {
        let busy: Vec<(usize, &mut Vec<[f32; 4]>)> = bufs
            .iter_mut()
            .enumerate()
            .filter(|(k, _)| !self.tile(*k).is_empty())
            .collect();
        heaviest_first(busy, |_, (k, _)| self.tile(*k).len() as u64, |(k, b)| f(k, b))
            .into_iter()
            .sum()
    }

    /// Bins the places `0..rects.len()` of a part by their tile ranges: chunks of the part
    /// counted in parallel, offsets by a prefix sum over (tile, chunk), then each chunk writes
    /// its own disjoint ranges. A tile's items are the places, in the order.
    pub(super) fn build(&mut self, rects: &[TileRect], ntx: usize, ntiles: usize) {
        assert!(rects.len() <= u32::MAX as usize, "places of a part are 32-bit");
        let n = rects.len();
        let nchunks = (rayon::current_num_threads().max(1) * 4).min(n.max(1));
        let chunk = n.div_ceil(nchunks).max(1);
        let chunks: Vec<std::ops::Range<usize>> =
            (0..n).step_by(chunk).map(|a| a..(a + chunk).min(n)).collect();
        self.offsets.resize_with(chunks.len(), Vec::new);
        self.offsets.truncate(chunks.len());
        self.offsets
            .par_iter_mut()
            .zip(&chunks)
            .for_each(|(cnt, ids)| {
                // Four counters a tile, taken in turn by consecutive tets, then summed:
                // consecutive tets mostly fall in one tile, and a single counter made each
                // increment wait on the one before (~16 cycles a tet on post).
                cnt.clear();
                cnt.resize(ntiles * LANES, 0);
                for (m, i) in ids.clone().enumerate() {
                    let r = rects[i];
                    for ty in r[1]..r[3] + 1 {
                        let row = ty as usize * ntx;
                        for tx in r[0]..r[2] + 1 {
                            cnt[(row + tx as usize) * LANES + m % LANES] += 1;
                        }
                    }
                }
                for k in 0..ntiles {
                    cnt[k] = cnt[k * LANES..(k + 1) * LANES].iter().sum();
                }
                cnt.truncate(ntiles);
            });
        self.start.clear();
        self.start.resize(ntiles + 1, 0);
        let mut sum = 0usize;
        for k in 0..ntiles {
            self.start[k] = sum;
            for c in self.offsets.iter_mut() {
                let n = c[k];
                c[k] = sum;
                sum += n;
            }
        }
        self.start[ntiles] = sum;
        self.items.clear();
        self.items.resize(sum, 0);
        let out = SharedOut(self.items.as_mut_ptr());
        self.offsets
            .par_iter_mut()
            .zip(&chunks)
            .for_each(|(off, ids)| {
                let out = &out;
                for i in ids.clone() {
                    let r = rects[i];
                    for ty in r[1]..r[3] + 1 {
                        let row = ty as usize * ntx;
                        for tx in r[0]..r[2] + 1 {
                            let o = &mut off[row + tx as usize];
                            // SAFETY: chunk c's pairs of tile k go to
                            // [offset(k, c), offset(k, c + 1)), disjoint from every other
                            // (tile, chunk)'s range and inside `items` (sized to the total).
                            unsafe { out.0.add(*o).write(i as u32) };
                            *o += 1;
                        }
                    }
                }
            });
    }
}

/// Counters a tile in [`Bins::build`]'s counting pass.
const LANES: usize = 4;

/// The bins' output array, written by several threads at disjoint indices.
struct SharedOut(*mut u32);
// SAFETY: see `Bins::build`: every index is written by exactly one thread.
unsafe impl Sync for SharedOut {}

/// The pixel rectangle `[x0, y0, x1, y1]` (inclusive) of tile (tx, ty) in a `w`×`h` image.
pub(super) fn tile_clip(tx: u32, ty: u32, w: u32, h: u32) -> [i64; 4] {
    use super::TILE;
    let (x0, y0) = ((tx * TILE) as i64, (ty * TILE) as i64);
    [
        x0,
        y0,
        (x0 + TILE as i64 - 1).min(w as i64 - 1),
        (y0 + TILE as i64 - 1).min(h as i64 - 1),
    ]
}
