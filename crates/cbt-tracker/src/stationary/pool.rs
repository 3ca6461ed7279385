//! Large work buffers recycled across the stationary trackers of a thread.
//!
//! A wide posterior (parts far apart, tens of thousands of cells) needs buffers of a few
//! hundred kilobytes. Freshly allocated, such a buffer costs a page fault on every page it
//! first touches — on the evaluation's sequences, most of a wide step's time. A tracker
//! keeps its buffers from step to step; this pool also hands the buffers of a dropped
//! tracker to the next one created on the same thread (the evaluation tracks each sequence
//! with a new tracker). Buffers hold no state: every user overwrites what it reads, so
//! results do not depend on where a buffer came from.

use std::cell::RefCell;

/// Buffers below this many cells are left to the allocator.
const MIN_CELLS: usize = 4096;

/// At most this many buffers wait in a thread's pool.
const MAX_POOLED: usize = 16;

thread_local! {
    static POOL: RefCell<Vec<Vec<f64>>> = const { RefCell::new(Vec::new()) };
}

/// An empty buffer with room for at least `n` cells: a pooled one when one is large enough
/// (the smallest such), else a new one (large ones with room to spare).
pub(crate) fn take(n: usize) -> Vec<f64> {
    if n >= MIN_CELLS {
        let pooled = POOL.with(|p| {
            let mut p = p.borrow_mut();
            let best = (0..p.len())
                .filter(|&i| p[i].capacity() >= n)
                .min_by_key(|&i| p[i].capacity())?;
            Some(p.swap_remove(best))
        });
        if let Some(v) = pooled {
            return v;
        }
        // Room to the next power of two: a slightly wider posterior later reuses it (pages
        // never touched cost nothing).
        return Vec::with_capacity(n.next_power_of_two());
    }
    Vec::with_capacity(n)
}

/// Gives a buffer back (emptied); small ones are dropped, and so is any beyond the pool's
/// size.
pub(crate) fn give(mut v: Vec<f64>) {
    if v.capacity() >= MIN_CELLS {
        v.clear();
        // During thread teardown the pool may be gone: the buffer is then simply dropped.
        let _ = POOL.try_with(|p| {
            let mut p = p.borrow_mut();
            if p.len() < MAX_POOLED {
                p.push(v);
            }
        });
    }
}

/// Clears `v` and fills it with `n` copies of `x`. A buffer too small is exchanged for a
/// pooled or new one rather than grown (growing would copy its stale contents).
pub(crate) fn refill(v: &mut Vec<f64>, n: usize, x: f64) {
    if v.capacity() < n {
        give(std::mem::replace(v, take(n)));
    }
    v.clear();
    v.resize(n, x);
}

/// Clears `v`, exchanging it for a pooled or new buffer when it cannot hold `n` cells.
pub(crate) fn reserve_empty(v: &mut Vec<f64>, n: usize) {
    if v.capacity() < n {
        give(std::mem::replace(v, take(n)));
    }
    v.clear();
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn large_buffers_come_back_small_ones_do_not() {
        let big = vec![1.0; MIN_CELLS * 2];
        let ptr = big.as_ptr();
        give(big);
        let again = take(MIN_CELLS + 1);
        assert_eq!(again.as_ptr(), ptr, "the pooled buffer is reused");
        assert!(again.is_empty() && again.capacity() > MIN_CELLS);
        give(vec![0.0; 10]);
        let small = take(5);
        assert!(small.capacity() >= 5);
        let mut v = Vec::new();
        refill(&mut v, MIN_CELLS, 0.5);
        assert_eq!(v.len(), MIN_CELLS);
        assert!(v.iter().all(|&x| x == 0.5));
        reserve_empty(&mut v, 3 * MIN_CELLS);
        assert!(v.is_empty() && v.capacity() >= 3 * MIN_CELLS);
    }
}
