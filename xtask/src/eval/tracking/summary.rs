//! `summary.md` of the tracking study: per-set tables and who is best in how many sequences.

use crate::markdown::Table;
use std::fmt::Write;

use super::study::{SEEDS, SetResult, aggregate, head_to_head};

/// The tracker the paper's claim is about, and its reference.
pub const CBT: &str = "CBT 2nd order";
/// The particle filter CBT is compared with head to head.
pub const PF: &str = "PF 1000";

/// Renders the summary (numbers rounded, so the text is deterministic).
pub fn render(sets: &[SetResult], protocol: &str) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "# Paper B: Channel Based Tracking against Kalman and particle filters\n"
    );
    let _ = writeln!(s, "{protocol}\n");
    let _ = writeln!(
        s,
        "Every tracker starts from the first frame's truth; RMSE is the root mean square \
         Euclidean position error over the later frames with truth; *lost* is the share of \
         those frames whose error exceeds the set's track-loss radius; *best in* counts the \
         sequences where the tracker has the lowest RMSE (ties count for each).\n"
    );
    let _ = writeln!(
        s,
        "Random trackers (the particle filters) run with {SEEDS} seeds per sequence: their \
         per-sequence RMSE and loss are means over seeds (the *best in* count uses them), \
         *spread* is the standard deviation over seeds of the set's mean RMSE. CBT and Kalman \
         are deterministic (—).\n"
    );
    let _ = writeln!(
        s,
        "Time per frame is **not** in these fixtures (they must be reproducible byte for \
         byte): it is measured by `cargo xtask bench tracking` and reported, with the RMSE \
         against time per frame plot, in `docs/performance.md` (section `cbt-tracker`).\n"
    );
    let image: Vec<&SetResult> = sets.iter().filter(|r| r.calibration.is_some()).collect();
    if !image.is_empty() {
        let _ = writeln!(s, "## All image sequences ({} sets)\n", image.len());
        table(&mut s, &image);
        let (w, n) = head_to_head(&image, CBT, PF);
        if n > 0 {
            let _ = writeln!(
                s,
                "\n{CBT} is at least as accurate as {PF} in {w} of {n} image sequences.\n"
            );
        }
    }
    for r in sets {
        let _ = writeln!(s, "## {}\n", r.set);
        let _ = writeln!(s, "{}\n", r.description);
        let spacing: Vec<String> = r.spacing.iter().map(|v| format!("{v:.2}")).collect();
        let channels: Vec<String> = r.channels.iter().map(|v| v.to_string()).collect();
        let _ = writeln!(
            s,
            "CBT grid: {} channels per state axis, spacing {}; track-loss radius {}.",
            channels.join(" × "),
            spacing.join(" / "),
            r.loss_radius
        );
        if let Some(c) = r.calibration {
            let _ = writeln!(
                s,
                "Baselines calibrated on the training data: σ_a = {:.2}, σ_z = {:.2}, \
                 P_D = {:.3}, clutter {:.2} per frame.",
                c.accel_sigma, c.meas_sigma, c.p_detect, c.clutter_rate
            );
        }
        let rejected: usize = r
            .sequences
            .iter()
            .flat_map(|q| q.runs.iter().map(|x| x.rejected_frames))
            .sum();
        if rejected > 0 {
            let _ = writeln!(
                s,
                "Frames with detections off a CBT grid (those left out, the frame's others used): \
                 {rejected}."
            );
        }
        let _ = writeln!(s);
        table(&mut s, &[r]);
        let _ = writeln!(s);
    }
    s
}

fn table(s: &mut String, sets: &[&SetResult]) {
    let mut t = Table::new([
        "tracker",
        "mean RMSE",
        "spread over seeds",
        "median RMSE",
        "lost",
        "best in",
    ])
    .right(1..6);
    for a in aggregate(sets) {
        t.row([
            a.tracker,
            format!("{:.2}", a.mean_rmse),
            if a.spread > 0.0 {
                format!("± {:.2}", a.spread)
            } else {
                "—".into()
            },
            format!("{:.2}", a.median_rmse),
            format!("{:.1} %", 100.0 * a.mean_loss_share),
            format!("{} / {}", a.best_in, a.sequences),
        ]);
    }
    let _ = write!(s, "{t}");
}
