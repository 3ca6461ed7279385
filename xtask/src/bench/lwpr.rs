//! `cargo xtask bench lwpr`: our LWPR against the reference C library (LWPR 1.2.6, built from
//! `../shared/peers/lwpr` into `target/peers/lwpr` in the same run) on identical sample streams:
//! updates/s, predictions/s, receptive fields and nMSE for the 2-D cross function (setting A of
//! docs/methods.md § LWPR, seeds 1–3) and its rotation into 25 dimensions (both pruning rules; the
//! default and the exact arithmetic), plus the learning curve and the largest prediction difference
//! (faithfulness).

// Included by both the bench and the eval module (it is also the tests' harness).
#[allow(clippy::duplicate_mod)]
#[path = "../../../crates/lwpr/peer/harness.rs"]
mod harness;

use std::time::Instant;

use harness::*;
use lwpr::{Arithmetic, Lwpr, PruneRule};

use super::BenchArgs;
use crate::report::{BenchRow, median};
use crate::{Result, workspace_root};

const RUNS: usize = 5;

struct Measured {
    updates_per_s: f64,
    predictions_per_s: f64,
    n_rf: usize,
    nmse: f64,
    pred: Vec<f64>,
}

/// One timed run of ours: trains a fresh copy, then times repeated passes of `predict_into`
/// over the test set for at least 0.25 s (as the reference driver does).
fn run_ours(fresh: &Lwpr, x: &[f64], y: &[f64], tx: &[f64], ty: &[f64]) -> (f64, f64, Lwpr) {
    let n = fresh.n_in();
    let mut model = fresh.clone();
    let mut out = [0.0];
    let t0 = Instant::now();
    for (a, b) in x.chunks(n).zip(y) {
        model
            .update_into(a, std::slice::from_ref(b), &mut out)
            .expect("valid sample");
    }
    let updates_per_s = y.len() as f64 / t0.elapsed().as_secs_f64();
    let mut count = 0usize;
    let mut sink = 0.0;
    let t0 = Instant::now();
    while t0.elapsed().as_secs_f64() < 0.25 || count < 3 * ty.len() {
        for p in tx.chunks(n) {
            model.predict_into(p, 0.001, &mut out).expect("valid input");
            sink += out[0];
        }
        count += ty.len();
    }
    assert!(sink.is_finite());
    (
        updates_per_s,
        count as f64 / t0.elapsed().as_secs_f64(),
        model,
    )
}

/// `RUNS` alternating runs of ours and the reference on the same samples (so that the load of
/// the shared machine hits both alike); medians of the rates.
fn measure(
    driver: &std::path::Path,
    fresh: &Lwpr,
    x: &[f64],
    y: &[f64],
    tx: &[f64],
    ty: &[f64],
) -> Result<(Measured, Measured)> {
    let (mut ou, mut op, mut pu, mut pp) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let mut last = None;
    for _ in 0..RUNS {
        let (u, p, model) = run_ours(fresh, x, y, tx, ty);
        ou.push(u);
        op.push(p);
        let run = run_peer(driver, &PeerSettings::of(fresh), x, y, tx, &[y.len()])?;
        pu.push(y.len() as f64 / run.update_seconds);
        pp.push(run.predictions_per_second);
        last = Some((model, run));
    }
    let (model, run) = last.expect("RUNS > 0");
    let pred = model.predict_batch(tx, 0.001)?;
    let (nrf, peer_pred) = run.checkpoints.into_iter().next().expect("one checkpoint");
    let ours = Measured {
        updates_per_s: median(&mut ou),
        predictions_per_s: median(&mut op),
        n_rf: model.num_rfs()[0],
        nmse: nmse(&pred, ty),
        pred,
    };
    let peer = Measured {
        updates_per_s: median(&mut pu),
        predictions_per_s: median(&mut pp),
        n_rf: nrf[0],
        nmse: nmse(&peer_pred, ty),
        pred: peer_pred,
    };
    Ok((ours, peer))
}

fn rows_for(case: &str, ours: &Measured, peer: &Measured, rows: &mut Vec<BenchRow>) {
    let diff = max_abs_diff(&ours.pred, &peer.pred);
    println!(
        "{case}: RFs {} vs {}, nMSE {:.6} vs {:.6}, largest prediction difference {diff:.2e}",
        ours.n_rf, peer.n_rf, ours.nmse, peer.nmse
    );
    rows.push(BenchRow::higher_is_better(
        format!("{case}: updates"),
        ours.updates_per_s,
        peer.updates_per_s,
        "updates/s",
    ));
    rows.push(BenchRow::higher_is_better(
        format!("{case}: predictions"),
        ours.predictions_per_s,
        peer.predictions_per_s,
        "pred/s",
    ));
    rows.push(BenchRow::lower_is_better(
        format!("{case}: receptive fields"),
        ours.n_rf as f64,
        peer.n_rf as f64,
        "RFs",
    ));
    rows.push(BenchRow::lower_is_better(
        format!("{case}: test nMSE"),
        ours.nmse,
        peer.nmse,
        "nMSE",
    ));
}

/// Runs the bench.
pub fn run(_args: &BenchArgs) -> Result<Vec<BenchRow>> {
    let driver = match build_peer(&workspace_root()) {
        Ok(d) => d,
        Err(reason) => {
            println!("lwpr bench SKIPPED: {reason}");
            return Ok(Vec::new());
        }
    };
    let mut rows = Vec::new();
    let (gx, gy) = cross_grid();

    // 2-D cross, setting A (the reference's bench_cross.c stream).
    for seed in [1u64, 2, 3] {
        let (x, y) = cross_samples(seed, 20_000, 0.1);
        let fresh = setting_a_builder(2).build()?;
        let (ours, peer) = measure(&driver, &fresh, &x, &y, &gx, &gy)?;
        rows_for(&format!("cross 2-D seed {seed}"), &ours, &peer, &mut rows);
    }

    // Learning curve, seed 1 (the fixture holds ours only; this prints both).
    let (x, y) = cross_samples(1, 20_000, 0.1);
    let checkpoints = [250usize, 500, 1000, 2000, 5000, 10_000, 20_000];
    let mut model = setting_a_builder(2).build()?;
    let run = run_peer(
        &driver,
        &PeerSettings::of(&model),
        &x,
        &y,
        &gx,
        &checkpoints,
    )?;
    println!("learning curve, cross 2-D seed 1 (samples: RFs ours/ref, nMSE ours/ref)");
    let mut done = 0;
    for (k, &c) in checkpoints.iter().enumerate() {
        for (a, b) in x[2 * done..2 * c].chunks(2).zip(&y[done..c]) {
            model.update(a, &[*b])?;
        }
        done = c;
        let e = nmse(&model.predict_batch(&gx, 0.001)?, &gy);
        let (nrf, pred) = &run.checkpoints[k];
        println!(
            "  {c:>6}: {:>3}/{:<3} {e:.5}/{:.5}",
            model.num_rfs()[0],
            nrf[0],
            nmse(pred, &gy)
        );
    }

    // 25-D: the cross function rotated into 25 dimensions.
    let dim = 25;
    let q = random_rotation(dim, 7);
    let (x2, y) = cross_samples(5, 20_000, 0.1);
    let x = embed(&x2, &q, dim);
    let tx = embed(&gx, &q, dim);
    // The default arithmetic (vectorised for n ≥ 5) with both pruning rules, and the
    // reference's order of operations (bit-identical to the C library) for comparison.
    for (label, rule, arithmetic) in [
        ("published pruning", PruneRule::Published, Arithmetic::Fast),
        ("reference pruning", PruneRule::ReferenceC, Arithmetic::Fast),
        (
            "reference pruning, exact arithmetic",
            PruneRule::ReferenceC,
            Arithmetic::Reference,
        ),
    ] {
        let fresh = setting_25d(dim)
            .prune_rule(rule)
            .arithmetic(arithmetic)
            .build()?;
        let (ours, peer) = measure(&driver, &fresh, &x, &y, &tx, &gy)?;
        rows_for(&format!("cross 25-D, {label}"), &ours, &peer, &mut rows);
    }
    Ok(rows)
}
