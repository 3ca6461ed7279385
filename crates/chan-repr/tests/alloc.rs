//! What the docs promise allocates nothing: `SoftHistogram::add` after its first call, and the
//! bases' `for_each_active` (a global allocator that counts each thread's allocations, so that
//! the test harness's threads are not counted).

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

use chan_repr::{ChannelBasis, ChannelGrid, Kernel, PeriodicBasis, SoftHistogram};

struct Counting;

thread_local! {
    /// Allocations (and reallocations) made by this thread.
    static ALLOCS: Cell<usize> = const { Cell::new(0) };
}

/// Allocations made by this thread so far.
fn allocs() -> usize {
    ALLOCS.with(Cell::get)
}

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, l: Layout) -> *mut u8 {
        ALLOCS.with(|c| c.set(c.get() + 1));
        unsafe { System.alloc(l) }
    }
    unsafe fn dealloc(&self, p: *mut u8, l: Layout) {
        unsafe { System.dealloc(p, l) }
    }
    unsafe fn realloc(&self, p: *mut u8, l: Layout, n: usize) -> *mut u8 {
        ALLOCS.with(|c| c.set(c.get() + 1));
        unsafe { System.realloc(p, l, n) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

/// Allocations made by `f`.
fn allocations(f: impl FnOnce()) -> usize {
    let before = allocs();
    f();
    allocs() - before
}

#[test]
fn soft_histogram_add_allocates_nothing_after_the_first_call() {
    for kernel in [
        Kernel::BSpline2,
        Kernel::Cos2 { m: 3 },
        Kernel::Gaussian { sigma: 0.8 },
    ] {
        let b = ChannelBasis::integer(40, kernel).unwrap();
        let mut h =
            SoftHistogram::new(ChannelGrid::new(vec![b.clone(), b.clone(), b]).unwrap()).unwrap();
        h.add(&[20.0, 20.0, 20.0], 1.0).unwrap();
        let n = allocations(|| {
            for k in 0..500 {
                let x = 2.0 + (k as f64 * 0.773) % 36.0;
                h.add(&[x, 40.0 - x, 0.5 * x + 2.0], 0.5).unwrap();
            }
        });
        assert_eq!(n, 0, "{kernel:?}");
        assert!((h.total_weight() - 251.0).abs() < 1e-9);
    }
}

#[test]
fn for_each_active_allocates_nothing() {
    let b = ChannelBasis::integer(30, Kernel::Cos2 { m: 3 }).unwrap();
    let p = PeriodicBasis::new(360.0, 24, Kernel::BSpline2).unwrap();
    let mut sum = 0.0;
    let n = allocations(|| {
        for k in 0..300 {
            let t = k as f64 * 0.1;
            b.for_each_active(t, |_, v| sum += v);
            p.for_each_active(t % 24.0, |_, v| sum += v);
        }
    });
    assert_eq!(n, 0);
    assert!(sum > 0.0);
}
