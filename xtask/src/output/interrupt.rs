//! Interrupts leave no partial output: SIGINT, SIGTERM and SIGHUP are taken by one thread
//! (blocked in every other thread, so they can arrive at any moment without interrupting a
//! write half-way), which waits for a commit in progress ([`hold`]) to finish, removes every
//! registered temporary folder and exits with status 128 + the signal number.
//!
//! [`install`] must run before the program starts any other thread (threads inherit the
//! blocked signals). The program must not start child processes after it: they would inherit
//! the blocked signals too. Without [`install`] (tests, other commands), the registry still
//! removes staged folders on drop; signals then act as usual.

use std::path::{Path, PathBuf};
use std::sync::{Mutex, MutexGuard, PoisonError};

/// Temporary folders to remove on a signal.
static STAGED: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());
/// Held while staged folders are moved into place; the signal thread waits for it.
static COMMIT: Mutex<()> = Mutex::new(());

fn lock<T>(m: &'static Mutex<T>) -> MutexGuard<'static, T> {
    m.lock().unwrap_or_else(PoisonError::into_inner)
}

/// Registers a temporary folder to be removed if the process is interrupted.
pub fn register(path: &Path) {
    lock(&STAGED).push(path.to_path_buf());
}

/// Removes a registered temporary folder now and forgets it.
pub fn discard(path: &Path) {
    let mut staged = lock(&STAGED);
    remove_all(path);
    staged.retain(|p| p != path);
}

/// Forgets a registered folder (it has been moved into place).
pub fn forget(path: &Path) {
    lock(&STAGED).retain(|p| p != path);
}

/// Holds signals off (their cleanup and exit wait) while the guard lives.
pub fn hold() -> MutexGuard<'static, ()> {
    lock(&COMMIT)
}

/// `remove_dir_all`, retried while another thread of ours may still be creating files in it.
fn remove_all(path: &Path) {
    for _ in 0..20 {
        match std::fs::remove_dir_all(path) {
            Err(e) if e.kind() != std::io::ErrorKind::NotFound && path.exists() => {
                std::thread::sleep(std::time::Duration::from_millis(5))
            }
            _ => return,
        }
    }
}

/// The signal thread's work: wait for a commit to end, remove every staged folder, exit.
fn clean_up_and_exit(signal: i32) -> ! {
    let _commit = lock(&COMMIT);
    let staged = lock(&STAGED);
    for p in staged.iter() {
        remove_all(p);
    }
    eprintln!(
        "\ninterrupted (signal {signal}): removed {} unfinished output folder(s); every \
         destination is as it was",
        staged.len()
    );
    std::process::exit(128 + signal);
}

/// Whether this process inherited `signal` as ignored (`nohup` ignores SIGHUP; a shell without
/// job control starts background commands with SIGINT ignored).
#[cfg(unix)]
fn inherited_ignored(signal: libc::c_int) -> bool {
    // SAFETY: queries the disposition only (null new action) into a zeroed `sigaction`.
    unsafe {
        let mut old: libc::sigaction = std::mem::zeroed();
        libc::sigaction(signal, std::ptr::null(), &mut old) == 0
            && old.sa_sigaction == libc::SIG_IGN
    }
}

/// Blocks SIGINT, SIGTERM and SIGHUP in this (the main) thread and starts the thread that
/// handles them. Call first thing in `main`, before any other thread exists.
///
/// A signal the process inherited as ignored stays ignored: Linux queues a blocked signal even
/// when its action is "ignore", so blocking it would turn `nohup cargo xtask eval` into a run
/// that a hang-up still stops.
#[cfg(unix)]
pub fn install() {
    let taken: Vec<libc::c_int> = [libc::SIGINT, libc::SIGTERM, libc::SIGHUP]
        .into_iter()
        .filter(|&s| !inherited_ignored(s))
        .collect();
    if taken.is_empty() {
        return;
    }
    // SAFETY: plain libc calls on a zero-initialised `sigset_t` owned by this function.
    let set = unsafe {
        let mut set: libc::sigset_t = std::mem::zeroed();
        libc::sigemptyset(&mut set);
        for &s in &taken {
            libc::sigaddset(&mut set, s);
        }
        libc::pthread_sigmask(libc::SIG_BLOCK, &set, std::ptr::null_mut());
        set
    };
    std::thread::spawn(move || {
        loop {
            let mut signal: libc::c_int = 0;
            // SAFETY: `set` is a valid signal set; `signal` is a valid out-pointer.
            if unsafe { libc::sigwait(&set, &mut signal) } == 0 {
                clean_up_and_exit(signal);
            }
        }
    });
}

/// Without Unix signals: nothing to install (staged folders are still removed on drop).
#[cfg(not(unix))]
pub fn install() {}
