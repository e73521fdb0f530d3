//! Binning of `cpu-pt`'s tets to tiles: a counting sort of the (tet, tile) pairs by tile, stable
//! in the visibility order, into one flat array (no per-tile `Vec`s).

use rayon::prelude::*;

use super::project::TileRect;
use crate::util::schedule::heaviest_first;

/// The tets of every tile in visibility order, in one array (a counting sort of the
/// (tet, tile) pairs by tile, stable in the order): tile k's tets are
/// `items[start[k]..start[k + 1]]`.
#[derive(Default)]
pub(super) struct Bins {
    start: Vec<u32>,
    pub(super) items: Vec<u32>,
    /// Per chunk of the order, its running offset per tile.
    offsets: Vec<Vec<u32>>,
}

impl Bins {
    pub(super) fn bytes(&self) -> usize {
        (self.start.capacity() + self.items.capacity()) * 4
            + self.offsets.iter().map(|o| o.capacity() * 4).sum::<usize>()
    }

    pub(super) fn tile(&self, k: usize) -> &[u32] {
        &self.items[self.start[k] as usize..self.start[k + 1] as usize]
    }

    /// `f` of each of the first `ntiles` tiles in parallel, the results in tile order: the
    /// tiles are handed to the threads one at a time, those with the most tets first.
    pub(super) fn per_tile<T: Send>(&self, ntiles: usize, f: impl Fn(usize) -> T + Sync) -> Vec<T> {
        heaviest_first((0..ntiles).collect(), |k, _| self.tile(k).len() as u64, f)
    }

    /// Bins the tets of `order` by their tile ranges, `rects[t]` for tet `t` (with `None`, the
    /// ids are `0..rects.len()`: records already in the order): chunks of the order counted in
    /// parallel, offsets by a prefix sum over (tile, chunk), then each chunk writes its own
    /// disjoint ranges. A tile's items are the ids, in the order.
    pub(super) fn build(
        &mut self,
        order: Option<&[u32]>,
        rects: &[TileRect],
        ntx: usize,
        ntiles: usize,
    ) {
        let n = order.map_or(rects.len(), |o| o.len());
        let id = |i: usize| order.map_or(i as u32, |o| o[i]);
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
                    let r = rects[id(i) as usize];
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
        let mut sum = 0u32;
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
        self.items.resize(sum as usize, 0);
        let out = SharedOut(self.items.as_mut_ptr());
        self.offsets
            .par_iter_mut()
            .zip(&chunks)
            .for_each(|(off, ids)| {
                let out = &out;
                for i in ids.clone() {
                    let t = id(i);
                    let r = rects[t as usize];
                    for ty in r[1]..r[3] + 1 {
                        let row = ty as usize * ntx;
                        for tx in r[0]..r[2] + 1 {
                            let o = &mut off[row + tx as usize];
                            // SAFETY: chunk c's pairs of tile k go to
                            // [offset(k, c), offset(k, c + 1)), disjoint from every other
                            // (tile, chunk)'s range and inside `items` (sized to the total).
                            unsafe { out.0.add(*o as usize).write(t) };
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
