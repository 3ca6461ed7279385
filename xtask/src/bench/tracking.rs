//! `cargo xtask bench tracking`: time per frame and accuracy of Channel Based Tracking
//! (second order, separable) against the particle filters and the Kalman filter, in one run
//! over the evaluation's sequences (`cargo xtask eval tracking`); also writes the
//! cost-accuracy plot `target/bench/tracking-rmse-vs-time.svg`.

use indicatif::ProgressBar;
use plotters::prelude::*;

use super::BenchArgs;
use crate::Result;
use crate::eval::tracking::study::{SetResult, run_set};
use crate::eval::tracking::{TEST_PER_LEVEL, pedestrians, synthetic_sets};
use crate::report::BenchRow;
use crate::workspace_root;

const CBT: &str = "CBT 2nd order";

/// Mean time per frame (µs) and mean RMSE of a tracker over sets.
fn stats(sets: &[SetResult], name: &str) -> (f64, f64) {
    let (mut secs, mut frames, mut rmse, mut n) = (0.0, 0usize, 0.0, 0usize);
    for s in sets {
        for q in &s.sequences {
            if let Some(r) = q.runs.iter().find(|r| r.tracker == name) {
                secs += r.seconds;
                frames += q.frames - 1;
                rmse += r.score.rmse;
                n += 1;
            }
        }
    }
    (secs / frames.max(1) as f64 * 1e6, rmse / n.max(1) as f64)
}

/// Rounds of the pedestrian study whose times are summed.
const PEDESTRIAN_ROUNDS: usize = 5;

/// Runs the bench.
pub fn run(args: &BenchArgs) -> Result<Vec<BenchRow>> {
    if let Some(d) = args.displacements {
        crate::eval::tracking::study::set_displacements(d.displacements());
        eprintln!(
            "bench tracking: CBT's displacements {d:?} (a candidate, not the default): time rows \
             only; its accuracy on these test sets is not shown (score a candidate with `eval \
             tracking --validation-only --out DIR` or `--rc-car-development`)"
        );
    }
    let specs = synthetic_sets(TEST_PER_LEVEL, 150, &[0, 1, 2, 3, 4])?;
    let pb = ProgressBar::new(specs.iter().map(|s| s.test.len() as u64).sum());
    let mut image = Vec::new();
    let mut ungm = Vec::new();
    for s in &specs {
        let r = run_set(s, &pb)?;
        if r.calibration.is_some() {
            image.push(r);
        } else {
            ungm.push(r);
        }
    }
    pb.finish_and_clear();
    let mut rows = Vec::new();
    let (cbt_t, cbt_e) = stats(&image, CBT);
    for peer in [
        "PF 100",
        "PF 1000",
        "PF 10000",
        "Kalman + NN",
        "CBT 1st order",
    ] {
        let (t, _) = stats(&image, peer);
        rows.push(BenchRow::lower_is_better(
            format!("image sets: time/frame, {CBT} vs {peer}"),
            cbt_t,
            t,
            "us/frame",
        ));
    }
    for peer in ["PF 1000", "PF 10000", "Kalman + NN"] {
        let (_, e) = stats(&image, peer);
        rows.push(BenchRow::lower_is_better(
            format!("image sets: mean RMSE, {CBT} vs {peer}"),
            cbt_e,
            e,
            "px",
        ));
    }
    for level in &image {
        let one = std::slice::from_ref(level);
        let (t, e) = stats(one, CBT);
        let (tp, ep) = stats(one, "PF 1000");
        rows.push(BenchRow::lower_is_better(
            format!("{}: time/frame, {CBT} vs PF 1000", level.set),
            t,
            tp,
            "us/frame",
        ));
        rows.push(BenchRow::lower_is_better(
            format!("{}: mean RMSE, {CBT} vs PF 1000", level.set),
            e,
            ep,
            "px",
        ));
    }
    let (ut, ue) = stats(&ungm, CBT);
    let (pt, pe) = stats(&ungm, "PF 1000");
    rows.push(BenchRow::lower_is_better(
        format!("UNGM: time/step, {CBT} vs PF 1000"),
        ut,
        pt,
        "us/step",
    ));
    rows.push(BenchRow::lower_is_better(
        format!("UNGM: mean RMSE, {CBT} vs PF 1000"),
        ue,
        pe,
        "",
    ));
    // The real-motion study's time per frame, when the pedestrian data is there: thread CPU
    // time of the steps, every fold one after the other on this thread, CBT and PF 1000
    // interleaved sequence by sequence on the same test sequences; the whole study timed
    // `PEDESTRIAN_ROUNDS` times and summed (one round times only about 0.04 s of CBT, so a
    // single round's ratio moved by several per cent from run to run).
    let data = args
        .data
        .clone()
        .or_else(|| std::env::var_os("VISGUIDE_DATA").map(std::path::PathBuf::from));
    if let Some(dir) = pedestrians::folder(data.as_deref()) {
        let scenes = pedestrians::load(&dir)?;
        let names = [CBT, "PF 1000", "CBT 2nd order online", "PF 10000"];
        let load = super::cpu::load_average();
        let mut times = pedestrians::cpu_times(&scenes, &names)?;
        for _ in 1..PEDESTRIAN_ROUNDS {
            for (sum, more) in times
                .iter_mut()
                .zip(pedestrians::cpu_times(&scenes, &names)?)
            {
                sum.1 += more.1;
                sum.2 += more.2;
            }
        }
        let per_frame = |k: usize| 1e6 * times[k].1 / times[k].2.max(1) as f64;
        for (k, (name, sec, frames)) in times.iter().enumerate() {
            eprintln!(
                "pedestrians: {name:<22} {:>9.1} µs per frame (thread CPU, {frames} frames, \
                 {sec:.2} s; load {load})",
                per_frame(k)
            );
        }
        for k in [0, 2] {
            rows.push(BenchRow::lower_is_better(
                format!("pedestrians: CPU time/frame, {} vs PF 1000", names[k]),
                per_frame(k),
                per_frame(1),
                "us/frame",
            ));
        }
    }
    if args.displacements.is_some() {
        // A candidate is timed here, never scored on the test sets.
        rows.retain(|r| r.unit.starts_with("us/"));
        return Ok(rows);
    }
    plot(
        &image,
        &workspace_root().join("target/bench/tracking-rmse-vs-time.svg"),
    )?;
    Ok(rows)
}

/// Mean RMSE against mean time per frame, one point per tracker (image sets). Drawn in memory
/// and written atomically ([`crate::output::write_svg`]): a failed drawing or write leaves the
/// previous picture, never a part of one.
fn plot(image: &[SetResult], path: &std::path::Path) -> Result<()> {
    let names = image[0].trackers.clone();
    let pts: Vec<(String, f64, f64)> = names
        .iter()
        .map(|n| {
            let (t, e) = stats(image, n);
            (n.clone(), t.max(1e-3), e)
        })
        .collect();
    let (tmin, tmax) = pts
        .iter()
        .fold((f64::INFINITY, 0.0f64), |a, p| (a.0.min(p.1), a.1.max(p.1)));
    let (emin, emax) = pts
        .iter()
        .fold((f64::INFINITY, 0.0f64), |a, p| (a.0.min(p.2), a.1.max(p.2)));
    crate::output::write_svg(path, (720, 480), |root| {
        root.fill(&WHITE)?;
        let mut chart = ChartBuilder::on(root)
            .caption(
                "Cost against accuracy (all synthetic image sets)",
                ("sans-serif", 16),
            )
            .margin(10)
            .x_label_area_size(35)
            .y_label_area_size(50)
            .build_cartesian_2d(
                (tmin * 0.5..tmax * 2.0).log_scale(),
                (emin * 0.8..emax * 1.25).log_scale(),
            )?;
        chart
            .configure_mesh()
            .x_desc("time per frame (µs, this machine, under load)")
            .y_desc("mean RMSE (px)")
            .draw()?;
        for (i, (name, t, e)) in pts.iter().enumerate() {
            let c = crate::palette::series(i).to_rgba();
            chart.draw_series(std::iter::once(Circle::new((*t, *e), 5, c.filled())))?;
            chart.draw_series(std::iter::once(Text::new(
                name.clone(),
                (*t * 1.1, *e),
                ("sans-serif", 12),
            )))?;
        }
        Ok(())
    })
}
