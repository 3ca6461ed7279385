//! Parallel jobs whose outcome does not depend on the number of threads.
//!
//! The studies run their scenes, seeds and folds as jobs on rayon's pool and gather the results
//! in the jobs' order, so the figures do not depend on the number of threads. Their errors must
//! not either: rayon's `collect::<Result<Vec<_>, _>>()` returns the error whichever thread met
//! one first, so a run in which several jobs fail reports one or another of them from run to
//! run. [`try_map`] reports the error of the first failing job in the jobs' order, the one a run
//! on one thread reports, and still stops early: once a job has failed, no later job starts.

use std::sync::atomic::{AtomicUsize, Ordering};

use rayon::prelude::*;

/// `f` over `jobs` on rayon's pool: every result in the jobs' order, or the error of the first
/// job in that order that failed.
///
/// A job starts only if no job before it has failed yet. The first failing job in order is
/// therefore always run (only a failure before it could stop it), and its error is the one
/// returned, whatever the scheduling.
pub fn try_map<T, R, E, F>(jobs: &[T], f: F) -> Result<Vec<R>, E>
where
    T: Sync,
    R: Send,
    E: Send,
    F: Fn(&T) -> Result<R, E> + Sync,
{
    let first_failed = AtomicUsize::new(usize::MAX);
    let outcomes: Vec<Option<Result<R, E>>> = jobs
        .par_iter()
        .enumerate()
        .map(|(i, job)| {
            if i > first_failed.load(Ordering::Relaxed) {
                return None;
            }
            let outcome = f(job);
            if outcome.is_err() {
                first_failed.fetch_min(i, Ordering::Relaxed);
            }
            Some(outcome)
        })
        .collect();
    outcomes.into_iter().flatten().collect()
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
    fn results_come_in_the_jobs_order() {
        let jobs: Vec<u32> = (0..100).collect();
        for threads in [1, 2, 4] {
            let got = pool(threads).install(|| try_map(&jobs, |&j| Ok::<_, String>(j * 3)));
            assert_eq!(got.unwrap(), jobs.iter().map(|j| j * 3).collect::<Vec<_>>());
        }
        let none: [u32; 0] = [];
        assert!(try_map(&none, |&j| Ok::<_, String>(j)).unwrap().is_empty());
    }

    /// Jobs 3 and 7 fail; on several threads job 7 is made to fail first (job 3 waits, for at
    /// most a second, until job 7 has failed). The error is job 3's at every thread count, as on
    /// one thread. rayon's own `collect` returned job 7's here.
    #[test]
    fn the_error_is_the_first_failing_job_in_order() {
        let jobs: Vec<usize> = (0..10).collect();
        for threads in [1, 2, 4] {
            let wait = Duration::from_secs(u64::from(threads > 1));
            for _ in 0..3 {
                let seven_failed = AtomicBool::new(false);
                let got = pool(threads).install(|| {
                    try_map(&jobs, |&j| match j {
                        3 => {
                            let start = Instant::now();
                            while !seven_failed.load(Ordering::SeqCst) && start.elapsed() < wait {
                                std::thread::yield_now();
                            }
                            Err(format!("job {j}"))
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

    /// Once a job has failed, no later job starts (on one thread: none after it at all).
    #[test]
    fn no_job_after_a_failure_starts_on_one_thread() {
        let jobs: Vec<usize> = (0..50).collect();
        let ran = AtomicUsize::new(0);
        let got = pool(1).install(|| {
            try_map(&jobs, |&j| {
                ran.fetch_add(1, Ordering::SeqCst);
                if j == 4 { Err(j) } else { Ok(j) }
            })
        });
        assert_eq!(got.unwrap_err(), 4);
        assert_eq!(ran.load(Ordering::SeqCst), 5);
    }
}
