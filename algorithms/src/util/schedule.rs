//! Parallel work handed out heaviest first.
//!
//! rayon splits an indexed parallel iterator adaptively: with two threads, an image's tiles
//! or bands went half to each, and the thread whose half held less of the mesh waited for the
//! other (the ray caster on `post` at 512²: 257 against 304 ms). Stealing one piece at a time
//! in image order still ends with whichever piece is last, often one of the heaviest, running
//! alone. Handed out from one list sorted by a guess of their work, heaviest first (greedy
//! list scheduling, "longest processing time first"), the pieces left at the end are the
//! lightest, and the threads finish within about one light piece of each other.

use std::cmp::Reverse;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;

use rayon::prelude::*;

/// Runs `f` on every item on the current rayon pool, one item at a time per thread, in the
/// order of decreasing `weight` (ties in the items' order), and returns the results in the
/// items' order. The weights only order the work: the results do not depend on them.
pub fn heaviest_first<I, T, W, F>(items: Vec<I>, weight: W, f: F) -> Vec<T>
where
    I: Send,
    T: Send,
    W: Fn(usize, &I) -> u64,
    F: Fn(I) -> T + Sync,
{
    let n = items.len();
    let weights: Vec<u64> = items
        .iter()
        .enumerate()
        .map(|(i, it)| weight(i, it))
        .collect();
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by_key(|&i| Reverse(weights[i]));
    let slots: Vec<Mutex<Option<I>>> = items.into_iter().map(|it| Mutex::new(Some(it))).collect();
    let results: Vec<Mutex<Option<T>>> = (0..n).map(|_| Mutex::new(None)).collect();
    let handed = AtomicUsize::new(0);
    // One worker per thread; each takes the next item until none is left.
    (0..rayon::current_num_threads().min(n).max(1))
        .into_par_iter()
        .for_each(|_| {
            while let Some(&i) = order.get(handed.fetch_add(1, Ordering::Relaxed)) {
                // Each slot is taken exactly once (the counter hands each index out once), so
                // neither lock is ever contended.
                let item = slots[i].lock().ok().and_then(|mut s| s.take());
                if let Some(item) = item {
                    let r = f(item);
                    if let Ok(mut out) = results[i].lock() {
                        *out = Some(r);
                    }
                }
            }
        });
    results
        .into_iter()
        .map(|m| {
            m.into_inner()
                .ok()
                .flatten()
                .expect("heaviest_first: every item is run once")
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_item_runs_once_and_results_keep_the_items_order() {
        let items: Vec<u64> = (0..100).map(|i| (i * 37) % 11).collect();
        let runs = AtomicUsize::new(0);
        let out = heaviest_first(
            items.clone(),
            |_, &w| w,
            |x| {
                runs.fetch_add(1, Ordering::Relaxed);
                x * 2
            },
        );
        assert_eq!(runs.load(Ordering::Relaxed), 100);
        assert_eq!(out, items.iter().map(|x| x * 2).collect::<Vec<_>>());
        assert!(heaviest_first(Vec::<u8>::new(), |_, _| 0, |x| x).is_empty());
    }

    #[test]
    fn one_thread_runs_the_heaviest_first_ties_in_order() {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap();
        let ran = Mutex::new(Vec::new());
        let weights = [3u64, 9, 0, 9, 5];
        pool.install(|| {
            heaviest_first(
                (0..5).collect(),
                |i, _| weights[i],
                |i: usize| ran.lock().unwrap().push(i),
            )
        });
        assert_eq!(ran.into_inner().unwrap(), vec![1, 3, 4, 0, 2]);
    }

    #[test]
    fn mutable_pieces_are_handed_out_apart() {
        let mut buf = vec![0u32; 64];
        let pieces: Vec<(usize, &mut [u32])> = buf.chunks_mut(8).enumerate().collect();
        let sums = heaviest_first(
            pieces,
            |i, _| i as u64,
            |(i, p)| {
                p.iter_mut().for_each(|v| *v = i as u32);
                p.len()
            },
        );
        assert_eq!(sums, vec![8; 8]);
        assert!(buf
            .chunks(8)
            .enumerate()
            .all(|(i, c)| c.iter().all(|&v| v == i as u32)));
    }
}
