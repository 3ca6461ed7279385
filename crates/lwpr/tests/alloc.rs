//! No heap allocation per update once the model has stopped growing, and none per
//! `predict_into` (counting global allocator).

#[path = "../peer/harness.rs"]
mod harness;

use harness::*;

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};

struct Counting;
static ALLOCS: AtomicUsize = AtomicUsize::new(0);

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, l: Layout) -> *mut u8 {
        ALLOCS.fetch_add(1, Ordering::SeqCst);
        unsafe { System.alloc(l) }
    }
    unsafe fn dealloc(&self, p: *mut u8, l: Layout) {
        unsafe { System.dealloc(p, l) }
    }
    unsafe fn realloc(&self, p: *mut u8, l: Layout, n: usize) -> *mut u8 {
        ALLOCS.fetch_add(1, Ordering::SeqCst);
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
            let before = ALLOCS.load(Ordering::SeqCst);
            for (a, b) in x.chunks(dim).zip(&y).take(2000) {
                m.update_into(a, &[*b], &mut out).unwrap();
                m.predict_into(a, 0.001, &mut out).unwrap();
            }
            let allocs = ALLOCS.load(Ordering::SeqCst) - before;
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
