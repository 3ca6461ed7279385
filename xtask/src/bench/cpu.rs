//! CPU time for speed ratios on a shared machine: the kernel's per-thread and per-process CPU
//! clocks (`clock_gettime`, nanoseconds), which other processes competing for the cores disturb
//! far less than wall time, and interleaved repeats of the two sides of a comparison, so that
//! a slow phase of the machine hits both.
//!
//! Not `/proc/.../schedstat`: the kernel adds a running thread's time to it only at a scheduler
//! tick or a context switch, so a read inside a run lags by up to one tick (4 ms at 250 Hz).
//! On runs of about 10 ms that quantised every time to whole ticks (12 / 24 / 28 ms) and moved
//! ratios by ±20 %; the clocks below are exact at the moment they are read.

use crate::Result;
use crate::report::median;

/// Seconds of one of the kernel's CPU clocks (`None` where `clock_gettime` fails).
fn cpu_clock(id: libc::clockid_t) -> Option<f64> {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `ts` is a valid, writable timespec for the duration of the call.
    let rc = unsafe { libc::clock_gettime(id, &mut ts) };
    (rc == 0).then_some(ts.tv_sec as f64 + ts.tv_nsec as f64 * 1e-9)
}

/// CPU time of the calling thread in seconds (`CLOCK_THREAD_CPUTIME_ID`).
pub fn thread_seconds() -> Option<f64> {
    cpu_clock(libc::CLOCK_THREAD_CPUTIME_ID)
}

/// CPU time of the whole process in seconds (`CLOCK_PROCESS_CPUTIME_ID`): every thread, those
/// that have exited included, for work spread over a thread pool.
pub fn process_seconds() -> Option<f64> {
    cpu_clock(libc::CLOCK_PROCESS_CPUTIME_ID)
}

/// The machine's load averages over 1, 5 and 15 minutes as printed by `uptime` (Linux;
/// "unknown" elsewhere), so that a printed figure says how busy the cores were.
pub fn load_average() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .ok()
        .map(|s| s.split_whitespace().take(3).collect::<Vec<_>>().join(" "))
        .unwrap_or_else(|| "unknown".into())
}

/// Which clock [`interleaved`] reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Clock {
    /// [`thread_seconds`]: for work on the calling thread.
    Thread,
    /// [`process_seconds`]: for work spread over a thread pool.
    Process,
    /// Wall time: for parallel speed-ups, which CPU time cannot show.
    Wall,
}

impl Clock {
    fn now(self, t0: std::time::Instant) -> Result<f64> {
        match self {
            Clock::Thread => thread_seconds().ok_or_else(|| "no thread CPU clock".into()),
            Clock::Process => process_seconds().ok_or_else(|| "no process CPU clock".into()),
            Clock::Wall => Ok(t0.elapsed().as_secs_f64()),
        }
    }

    /// How the clock is named in printed notes.
    pub fn name(self) -> &'static str {
        match self {
            Clock::Thread => "thread CPU time",
            Clock::Process => "process CPU time",
            Clock::Wall => "wall time",
        }
    }
}

/// Runs `a` and `b` alternately, `warmup` times each unmeasured and then `rounds` times each,
/// and returns the median time of one call of each (seconds of `clock`).
pub fn interleaved(
    clock: Clock,
    warmup: usize,
    rounds: usize,
    mut a: impl FnMut(),
    mut b: impl FnMut(),
) -> Result<(f64, f64)> {
    for _ in 0..warmup {
        a();
        b();
    }
    let origin = std::time::Instant::now();
    let (mut ta, mut tb) = (Vec::new(), Vec::new());
    for _ in 0..rounds.max(1) {
        let t0 = clock.now(origin)?;
        a();
        let t1 = clock.now(origin)?;
        b();
        let t2 = clock.now(origin)?;
        ta.push(t1 - t0);
        tb.push(t2 - t1);
    }
    Ok((median(&mut ta), median(&mut tb)))
}
