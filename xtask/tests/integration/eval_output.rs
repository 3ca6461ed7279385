//! `cargo xtask eval` never loses what it did not write (issue 24): the reproductions
//! run against the built binary, and an eval interrupted at several moments leaves its output
//! folder byte-identical to before (or, interrupted during the final swap, to the complete new
//! output), with nothing left beside it. With `CI=true`, a missing data folder is an error.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::{Duration, Instant};

use crate::metadata::workspace_root;
use crate::walk::entries_below;

/// The xtask binary; `VISGUIDE_XTASK_BIN` overrides it (a target folder shared by several
/// checkouts holds one `debug/xtask`, whichever was linked last).
fn xtask_bin() -> String {
    std::env::var("VISGUIDE_XTASK_BIN").unwrap_or_else(|_| env!("CARGO_BIN_EXE_xtask").into())
}

/// A fresh scratch folder for one test.
fn scratch(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("visguide-eval-out-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Every entry below `dir` with its contents, sorted: a byte-exact picture of a folder.
fn snapshot(dir: &Path) -> Vec<(PathBuf, Option<Vec<u8>>)> {
    entries_below(dir)
        .into_iter()
        .map(|p| {
            let contents = (!p.is_dir()).then(|| std::fs::read(&p).unwrap());
            (p.strip_prefix(dir).unwrap().to_path_buf(), contents)
        })
        .collect()
}

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap() {
        let p = e.unwrap().path();
        let dest = to.join(p.file_name().unwrap());
        if p.is_dir() {
            copy_dir(&p, &dest);
        } else {
            std::fs::copy(&p, &dest).unwrap();
        }
    }
}

/// The xtask with `args`, in `cwd`, without the caller's data folder or CI flag.
fn xtask(cwd: &Path, args: &[&str]) -> Command {
    let mut c = Command::new(xtask_bin());
    c.args(args)
        .current_dir(cwd)
        .env_remove("VISGUIDE_DATA")
        .env_remove("CI");
    c
}

/// `xtask` with SIGINT, SIGTERM and SIGHUP set to `disposition` in the child, whatever this test
/// process inherited: a CI job started in the background of a non-interactive shell ignores
/// SIGINT, and the interrupt tests must not depend on how the harness was started.
fn xtask_with_signals(cwd: &Path, args: &[&str], disposition: libc::sighandler_t) -> Command {
    use std::os::unix::process::CommandExt;
    let mut c = xtask(cwd, args);
    // SAFETY: `signal` is async-signal-safe; nothing is allocated between fork and exec.
    unsafe {
        c.pre_exec(move || {
            for s in [libc::SIGINT, libc::SIGTERM, libc::SIGHUP] {
                libc::signal(s, disposition);
            }
            Ok(())
        });
    }
    c
}

fn run(mut c: Command) -> (bool, String) {
    let Output { status, stderr, .. } = c.output().unwrap();
    (
        status.success(),
        String::from_utf8_lossy(&stderr).into_owned(),
    )
}

/// Issue 24: `eval tracking --train EMPTY --test EMPTY --out DIR` wiped DIR and then failed.
/// Now a folder that is not ours is refused before anything runs, and a previous output of
/// ours survives the failed run unchanged.
#[test]
fn failed_inputs_leave_the_out_folder_alone() {
    let d = scratch("inputs");
    std::fs::create_dir_all(d.join("empty-train")).unwrap();
    std::fs::create_dir_all(d.join("empty-test")).unwrap();
    let out = d.join("out");
    std::fs::create_dir_all(&out).unwrap();
    std::fs::write(out.join("thesis.tex"), "precious").unwrap();
    let before = snapshot(&d);
    let args = |out: &Path| {
        [
            "eval",
            "tracking",
            "--train",
            "empty-train",
            "--test",
            "empty-test",
            "--out",
        ]
        .iter()
        .map(|s| s.to_string())
        .chain([out.display().to_string()])
        .collect::<Vec<_>>()
    };
    let mut c = xtask(&d, &[]);
    c.args(args(&out));
    let (ok, err) = run(c);
    assert!(!ok && err.contains("not an output of ours"), "{err}");
    assert!(
        err.contains(&out.display().to_string()),
        "names the path: {err}"
    );
    assert_eq!(snapshot(&d), before);
    // A previous output of ours: the run fails on its inputs and leaves it as it was.
    std::fs::write(out.join(".visguide-output"), "an earlier run\n").unwrap();
    let before = snapshot(&d);
    let mut c = xtask(&d, &[]);
    c.args(args(&out));
    let (ok, err) = run(c);
    assert!(!ok && err.contains("left unchanged"), "{err}");
    assert_eq!(snapshot(&d), before);
    std::fs::remove_dir_all(&d).unwrap();
}

/// Issue 24: `--out .` wiped the current folder. The current folder, the repository and the
/// folders above them are refused (single target or output root), and nothing changes.
#[test]
fn the_current_folder_and_the_repository_are_refused() {
    let d = scratch("cwd");
    std::fs::write(d.join("notes.txt"), "mine").unwrap();
    let before = snapshot(&d);
    let repo = workspace_root().display().to_string();
    for args in [
        vec!["eval", "chan-repr", "--out", "."],
        vec!["eval", "chan-repr", "--out", ".."],
        vec!["eval", "chan-repr", "--out", &repo],
        vec!["eval", "lwpr", "--out", "/"],
    ] {
        let (ok, err) = run(xtask(&d, &args));
        assert!(!ok, "{args:?} succeeded");
        assert!(
            err.contains("the current folder")
                || err.contains("the repository")
                || err.contains("root"),
            "{args:?}: {err}"
        );
        assert_eq!(snapshot(&d), before, "{args:?}");
    }
    std::fs::remove_dir_all(&d).unwrap();
}

/// With `CI=true`, a data folder that is not there is an error naming it (before anything is
/// written); locally it is a note and the synthetic target runs.
#[test]
fn strict_ci_fails_where_a_local_run_notes_and_skips() {
    let d = scratch("ci");
    let args = [
        "eval",
        "chan-repr",
        "--data",
        "no-such-data",
        "--out",
        "out",
    ];
    let mut c = xtask(&d, &args);
    c.env("CI", "true");
    let (ok, err) = run(c);
    assert!(
        !ok && err.contains("no-such-data") && err.contains("CI=true"),
        "{err}"
    );
    assert!(!d.join("out").exists());
    let (ok, err) = run(xtask(&d, &args));
    assert!(
        ok && err.contains("note: data folder no-such-data not found"),
        "{err}"
    );
    assert!(d.join("out/worked-example.json").is_file());
    // A plain run without the Oxford data: paper-a is skipped with a note locally, and under CI
    // the run fails before any target starts.
    let mut c = xtask(&d, &["eval", "--out", "all"]);
    c.env("CI", "true");
    let (ok, err) = run(c);
    assert!(!ok && err.contains("skip paper-a"), "{err}");
    assert!(!d.join("all").exists(), "nothing written");
    std::fs::remove_dir_all(&d).unwrap();
}

/// Sends SIGINT to a running process.
fn interrupt(child: &std::process::Child) {
    let pid = child.id() as libc::pid_t;
    // SAFETY: signalling a child process of ours by its id.
    assert_eq!(unsafe { libc::kill(pid, libc::SIGINT) }, 0);
}

/// When to interrupt a run.
#[derive(Debug, Clone, Copy)]
enum Moment {
    /// This fraction of an uninterrupted run's duration after the start.
    Fraction(f64),
    /// As soon as the staged folder beside the destination holds this many entries.
    Staged(usize),
}

/// `eval arm-sim --out COPY` on a copy of the committed `fixtures/arm-sim/` (about half a
/// second: frames rendered, PNG, JSON and SVG written), interrupted at the start, while its
/// staged folder is being written, at fractions of its run time and after it ended: the copy is
/// byte-identical to before (or to the complete new output, for a signal during the final
/// swap), and no temporary folder is left beside it.
#[test]
fn an_interrupted_eval_leaves_its_folder_as_it_was() {
    let d = scratch("sigint");
    let out = d.join("arm-sim");
    let committed = workspace_root().join("fixtures/arm-sim");
    copy_dir(&committed, &out);
    // A file only the old folder has: tells the old contents from a complete new run's.
    std::fs::write(out.join("from-an-earlier-run.txt"), "old\n").unwrap();
    let before = snapshot(&out);
    // Two uninterrupted runs into another folder: the shorter duration, the complete output.
    let fresh = d.join("fresh/arm-sim");
    let mut full = Duration::MAX;
    for _ in 0..2 {
        let t0 = Instant::now();
        let (ok, err) = run(xtask(
            &d,
            &["eval", "arm-sim", "--out", &fresh.display().to_string()],
        ));
        full = full.min(t0.elapsed());
        assert!(ok, "{err}");
    }
    let complete = snapshot(&fresh);
    assert!(complete != before);
    let moments = [
        Moment::Fraction(0.0),
        Moment::Staged(1),
        Moment::Staged(2),
        Moment::Fraction(0.1),
        Moment::Fraction(0.3),
        Moment::Fraction(0.5),
        Moment::Fraction(1.5),
    ];
    let mut outcomes = Vec::new();
    for m in moments {
        // Every moment starts from the old folder, even when the previous run completed.
        if snapshot(&out) != before {
            std::fs::remove_dir_all(&out).unwrap();
            copy_dir(&committed, &out);
            std::fs::write(out.join("from-an-earlier-run.txt"), "old\n").unwrap();
            assert!(snapshot(&out) == before);
        }
        let mut child =
            xtask_with_signals(&d, &["eval", "arm-sim", "--out", "arm-sim"], libc::SIG_DFL)
                .stderr(std::process::Stdio::null())
                .spawn()
                .unwrap();
        match m {
            Moment::Fraction(f) => {
                std::thread::sleep(full.mul_f64(f).max(Duration::from_millis(1)))
            }
            Moment::Staged(n) => {
                let staged = d.join(format!(".arm-sim.partial-{}", child.id()));
                let t0 = Instant::now();
                while std::fs::read_dir(&staged).map_or(0, |r| r.count()) < n {
                    assert!(t0.elapsed() < Duration::from_secs(60), "{m:?} never came");
                    std::thread::sleep(Duration::from_micros(200));
                }
            }
        }
        interrupt(&child);
        let status = child.wait().unwrap();
        let now = snapshot(&out);
        let names = |s: &[(PathBuf, Option<Vec<u8>>)]| -> Vec<PathBuf> {
            s.iter().map(|(p, _)| p.clone()).collect()
        };
        assert!(
            now == before || now == complete,
            "interrupted at {m:?} of {full:?} ({status}): the folder changed: {:?}",
            names(&now)
        );
        // Only the two folders we made: nothing staged or set aside is left.
        let mut beside: Vec<String> = std::fs::read_dir(&d)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        beside.sort();
        assert_eq!(beside, ["arm-sim", "fresh"], "at {m:?}");
        outcomes.push((m, status.code(), now == before));
    }
    eprintln!("uninterrupted: {full:?}; (moment, exit status, unchanged): {outcomes:?}");
    // The moments inside the write must have hit the running eval (exit status 130) and left
    // the folder as it was.
    for o in &outcomes[1..3] {
        assert_eq!((o.1, o.2), (Some(130), true), "{outcomes:?}");
    }
    std::fs::remove_dir_all(&d).unwrap();
}

/// A signal the caller ignores stays ignored (`nohup`, background jobs of a non-interactive
/// shell): the run is not stopped by it and completes.
#[test]
fn an_ignored_signal_does_not_stop_an_eval() {
    let d = scratch("ignored");
    let mut child = xtask_with_signals(&d, &["eval", "arm-sim", "--out", "out"], libc::SIG_IGN)
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let staged = d.join(format!(".out.partial-{}", child.id()));
    let t0 = Instant::now();
    while !staged.exists() && child.try_wait().unwrap().is_none() {
        assert!(
            t0.elapsed() < Duration::from_secs(60),
            "the run never staged"
        );
        std::thread::sleep(Duration::from_micros(200));
    }
    for s in [libc::SIGINT, libc::SIGHUP, libc::SIGINT] {
        // SAFETY: signalling a child process of ours by its id.
        unsafe { libc::kill(child.id() as libc::pid_t, s) };
    }
    let status = child.wait().unwrap();
    assert_eq!(status.code(), Some(0));
    assert!(d.join("out/summary.json").is_file());
    let beside: Vec<String> = std::fs::read_dir(&d)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert_eq!(beside, ["out"]);
    std::fs::remove_dir_all(&d).unwrap();
}
