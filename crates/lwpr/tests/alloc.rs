//! No heap allocation per update once the model has stopped growing, and none per
//! `predict_into` up to the documented `n ≤ 32` inputs (a global allocator that counts each
//! thread's allocations, so that the test harness's threads and the other test are not
//! counted; updates and `predict_into` run on the calling thread).

#[path = "../peer/harness.rs"]
mod harness;

use harness::*;

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

use lwpr::LwprBuilder;

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

#[test]
fn grown_model_updates_and_predicts_without_allocating() {
    // n = 6 with a full metric runs the vectorised path (`Arithmetic::Fast`).
    for (dim, diag, meta) in [(2, true, false), (2, false, true), (6, false, true)] {
        let (x2, y) = cross_samples(1, 6000, 0.1);
        let x = if dim == 2 {
            x2
        } else {
            embed(&x2, &random_rotation(dim, 7), dim)
        };
        let mut m = setting_a_builder(dim)
            .diag_only(diag)
            .meta(meta)
            .build()
            .unwrap();
        train(&mut m, &x, &y).unwrap();
        // Replay seen inputs until a whole pass adds neither fields nor PLS directions.
        let dims = |m: &lwpr::Lwpr| {
            m.receptive_fields(0)
                .iter()
                .map(|r| r.pls_dims())
                .sum::<usize>()
        };
        let mut out = [0.0];
        let mut checked = false;
        for _pass in 0..10 {
            let (rfs, pls) = (m.num_rfs(), dims(&m));
            let before = allocs();
            for (a, b) in x.chunks(dim).zip(&y).take(2000) {
                m.update_into(a, &[*b], &mut out).unwrap();
                m.predict_into(a, 0.001, &mut out).unwrap();
            }
            let allocs = allocs() - before;
            if (m.num_rfs(), dims(&m)) == (rfs, pls) {
                assert_eq!(
                    allocs, 0,
                    "allocations in 2000 updates + predictions (n {dim}, diag {diag}, meta {meta})"
                );
                checked = true;
                break;
            }
        }
        assert!(checked, "the model never stopped growing");
    }
}

/// The widest models that predict on the stack buffer (`n` 31 and 32).
#[test]
fn predict_into_allocates_nothing_up_to_32_inputs() {
    for n in [31, 32] {
        let mut m = LwprBuilder::new(n, 1)
            .init_d_spherical(0.5)
            .build()
            .unwrap();
        let xs: Vec<Vec<f64>> = (0..60)
            .map(|i| {
                (0..n)
                    .map(|j| ((i * 7 + j * 3) % 11) as f64 / 11.0)
                    .collect()
            })
            .collect();
        for x in &xs {
            m.update(x, &[x.iter().sum::<f64>()]).unwrap();
        }
        assert!(m.num_rfs()[0] > 0);
        let mut out = [0.0];
        let before = allocs();
        for x in &xs {
            m.predict_into(x, 0.001, &mut out).unwrap();
        }
        let allocs = allocs() - before;
        assert_eq!(
            allocs,
            0,
            "allocations in {} predictions with n = {n}",
            xs.len()
        );
    }
}
