//! Work over many items on rayon's pool whose outcome, errors included, does not depend on the
//! number of threads.
//!
//! Results gathered in the items' order do not depend on the scheduling; errors may. rayon's
//! `collect::<Result<Vec<_>, _>>()` returns the error whichever thread met one first, and a run
//! that stops starting items once any has failed can skip an earlier item because a later one
//! failed first. Here an item is skipped only if one **before it** has failed: the first failing
//! item in order (only a failure before it could stop it) is therefore always run, and its error
//! is the one a run on one thread reports. The run still stops early: once an item has failed,
//! no later item starts. Used by `visguide regions` and by the xtask's studies.

use std::sync::atomic::{AtomicUsize, Ordering};

use rayon::prelude::*;

/// `f` over `items` on rayon's pool, in the items' order: `Some` outcome of every item that
/// ran, `None` for an item not started because an item before it had failed. Every item runs
/// when none fails; the first `Err` in order is the first failing item's, at any thread count.
pub fn map_until_failure<T, R, E, F>(items: &[T], f: F) -> Vec<Option<Result<R, E>>>
where
    T: Sync,
    R: Send,
    E: Send,
    F: Fn(&T) -> Result<R, E> + Sync,
{
    let first_failed = AtomicUsize::new(usize::MAX);
    items
        .par_iter()
        .enumerate()
        .map(|(i, item)| {
            if i > first_failed.load(Ordering::Relaxed) {
                return None;
            }
            let outcome = f(item);
            if outcome.is_err() {
                first_failed.fetch_min(i, Ordering::Relaxed);
            }
            Some(outcome)
        })
        .collect()
}

/// `f` over `items` on rayon's pool: every result in the items' order, or the error of the
/// first item in that order that failed ([`map_until_failure`]).
pub fn try_map<T, R, E, F>(items: &[T], f: F) -> Result<Vec<R>, E>
where
    T: Sync,
    R: Send,
    E: Send,
    F: Fn(&T) -> Result<R, E> + Sync,
{
    map_until_failure(items, f).into_iter().flatten().collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::atomic::AtomicBool;
    use std::time::{Duration, Instant};

    fn pool(threads: usize) -> rayon::ThreadPool {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
    }

    #[test]
    fn results_come_in_the_items_order() {
        let jobs: Vec<u32> = (0..100).collect();
        for threads in [1, 2, 4] {
            let got = pool(threads).install(|| try_map(&jobs, |&j| Ok::<_, String>(j * 3)));
            assert_eq!(got.unwrap(), jobs.iter().map(|j| j * 3).collect::<Vec<_>>());
        }
        let none: [u32; 0] = [];
        assert!(try_map(&none, |&j| Ok::<_, String>(j)).unwrap().is_empty());
    }

    /// Items 3 and 7 fail; on several threads item 7 is made to fail first (items 0 to 3 wait,
    /// for at most a second, until item 7 has failed), so that item 3 has not started when it
    /// does. The error is item 3's at every thread count, as on one thread. rayon's own
    /// `collect` returned item 7's here, and so did skipping every item once any had failed.
    #[test]
    fn the_error_is_the_first_failing_item_in_order() {
        let jobs: Vec<usize> = (0..10).collect();
        for threads in [1, 2, 4] {
            let wait = Duration::from_secs(u64::from(threads > 1));
            for _ in 0..3 {
                let seven_failed = AtomicBool::new(false);
                let got = pool(threads).install(|| {
                    try_map(&jobs, |&j| match j {
                        0..=3 => {
                            let start = Instant::now();
                            while !seven_failed.load(Ordering::SeqCst) && start.elapsed() < wait {
                                std::thread::yield_now();
                            }
                            if j == 3 {
                                Err(format!("job {j}"))
                            } else {
                                Ok(j)
                            }
                        }
                        7 => {
                            seven_failed.store(true, Ordering::SeqCst);
                            Err(format!("job {j}"))
                        }
                        _ => Ok(j),
                    })
                });
                assert_eq!(got.unwrap_err(), "job 3", "{threads} threads");
            }
        }
    }

    /// Once an item has failed, no later item starts (on one thread: none after it at all), and
    /// every item before it has its outcome.
    #[test]
    fn no_item_after_a_failure_starts_on_one_thread() {
        let jobs: Vec<usize> = (0..50).collect();
        let ran = AtomicUsize::new(0);
        let got = pool(1).install(|| {
            map_until_failure(&jobs, |&j| {
                ran.fetch_add(1, Ordering::SeqCst);
                if j == 4 { Err(j) } else { Ok(j) }
            })
        });
        assert_eq!(ran.load(Ordering::SeqCst), 5);
        assert_eq!(got.len(), 50);
        assert!(got[..4].iter().all(|o| matches!(o, Some(Ok(_)))));
        assert!(matches!(got[4], Some(Err(4))));
        assert!(got[5..].iter().all(Option::is_none));
    }
}
