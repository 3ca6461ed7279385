//! Accuracy on the reference's benchmarks (docs/methods.md § LWPR): the cross function in settings
//! A and B, the reference's 1-D test and the cross function rotated into 25 dimensions. Thresholds
//! are the reference library's measured ranges (docs/methods.md § LWPR), not tuned values.

use crate::common;
use crate::harness;

use common::Cross25;
use harness::*;
use lwpr::{Lwpr, LwprBuilder};

/// Setting A: 20 000 fresh samples (the stream of the reference's `bench_cross.c`).
pub fn setting_a(seed: u64) -> (Lwpr, f64) {
    let (x, y) = cross_samples(seed, 20_000, 0.1);
    let mut m = setting_a_builder(2).build().unwrap();
    train(&mut m, &x, &y).unwrap();
    let (gx, gy) = cross_grid();
    let e = nmse(&m.predict_batch(&gx, 0.001).unwrap(), &gy);
    (m, e)
}

/// Setting B: 500 fixed samples, σ = 0.1, 20 shuffled epochs, full metric with meta learning.
pub fn setting_b(seed: u64) -> (Lwpr, f64) {
    let (x, y) = cross_samples(seed, 500, 0.1);
    let mut m = setting_b_builder().build().unwrap();
    let mut rng = Rng::new(seed ^ 0xB);
    let mut order: Vec<usize> = (0..500).collect();
    for _ in 0..20 {
        for i in (1..order.len()).rev() {
            let j = (rng.uniform() * (i + 1) as f64) as usize;
            order.swap(i, j);
        }
        for &k in &order {
            m.update(&x[2 * k..2 * k + 2], &[y[k]]).unwrap();
        }
    }
    let (gx, gy) = cross_grid();
    let e = nmse(&m.predict_batch(&gx, 0.001).unwrap(), &gy);
    (m, e)
}

#[test]
fn cross_setting_a_reaches_reference_accuracy() {
    for seed in [1, 2, 3] {
        let (m, e) = setting_a(seed);
        eprintln!("setting A seed {seed}: {} RFs, nMSE {e:.5}", m.num_rfs()[0]);
        assert!(e <= 0.025, "seed {seed}: nMSE {e}");
        assert!((50..=70).contains(&m.num_rfs()[0]));
    }
}

#[test]
fn cross_setting_b_reaches_reference_accuracy() {
    for seed in [1, 2] {
        let (m, e) = setting_b(seed);
        eprintln!("setting B seed {seed}: {} RFs, nMSE {e:.5}", m.num_rfs()[0]);
        assert!(e <= 0.042, "seed {seed}: nMSE {e}");
    }
}

/// nMSE of the reference on the same stream, if it can be built (else `None`, printed).
fn reference_nmse(m: &Lwpr, x: &[f64], y: &[f64], tx: &[f64], ty: &[f64]) -> Option<f64> {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let driver = peer_or_skip(&root, "reference comparison")?;
    let p = m.params();
    let s = PeerSettings::of(m);
    let run = run_peer(&driver, &s, x, y, tx, &[x.len() / p.n_in]).expect("reference run");
    Some(nmse(&run.checkpoints[0].1, ty))
}

/// The reference's 1-D test: `5 + 10 sin(7.8 ln(1+x)) / (1 + 0.1 x²)` on [0, 10] with
/// heteroscedastic noise `0.1·x·N(0,1)`, 500 points, `init_D = 20`, `init_alpha = 40`,
/// `penalty = 1e-4`, 20 epochs. Ours must be at least as accurate as the reference.
#[test]
fn one_d_test_function() {
    let f = |x: f64| 5.0 + 10.0 * (7.8 * (1.0 + x).ln()).sin() / (1.0 + 0.1 * x * x);
    let mut rng = Rng::new(11);
    let xs: Vec<f64> = (0..500).map(|_| 10.0 * rng.uniform()).collect();
    let ys: Vec<f64> = xs.iter().map(|&x| f(x) + 0.1 * x * rng.normal()).collect();
    let (x, y): (Vec<f64>, Vec<f64>) = (xs.repeat(20), ys.repeat(20));
    let mut m = LwprBuilder::new(1, 1)
        .init_d_spherical(20.0)
        .init_alpha(40.0)
        .penalty(1e-4)
        .build()
        .unwrap();
    let fresh = m.clone();
    for (a, b) in x.iter().zip(&y) {
        m.update(&[*a], &[*b]).unwrap();
    }
    let tx: Vec<f64> = (0..=1000).map(|i| i as f64 / 100.0).collect();
    let ty: Vec<f64> = tx.iter().map(|&x| f(x)).collect();
    let e = nmse(&m.predict_batch(&tx, 0.001).unwrap(), &ty);
    eprintln!("1-D: {} RFs, nMSE {e:.5}", m.num_rfs()[0]);
    assert!(e < 0.05, "nMSE {e}");
    if let Some(r) = reference_nmse(&fresh, &x, &y, &tx, &ty) {
        eprintln!("1-D reference nMSE {r:.5}");
        assert!(e <= r * (1.0 + 1e-9), "ours {e} vs reference {r}");
    }
}

/// The cross function rotated into 25 dimensions (`init_D = 0.25·I`, full metric,
/// `w_prune = 0.7`, meta learning; `init_alpha = 250`, `w_gen = 0.2` as in setting A),
/// 4 000 samples here (20 000 in `cargo xtask bench lwpr`). At least as accurate as the
/// reference with the reference's pruning rule (the default, stated explicitly here because
/// pruning fires in this setting; with the published rule accuracy is lower: see the crate
/// docs, "Pruning", and the bench).
#[test]
fn cross_in_25_dimensions() {
    let c = Cross25::new();
    let (x, y) = (&c.x, &c.y);
    let mut m = c.builder().build().unwrap();
    let fresh = m.clone();
    for (a, b) in x.chunks(c.dim).zip(y) {
        m.update(a, &[*b]).unwrap();
    }
    let (gx, gy) = cross_grid();
    let tx = c.embed(&gx);
    let e = nmse(&m.predict_batch(&tx, 0.001).unwrap(), &gy);
    eprintln!("25-D: {} RFs, nMSE {e:.5}", m.num_rfs()[0]);
    assert!(e < 0.1, "nMSE {e}");
    if let Some(r) = reference_nmse(&fresh, x, y, &tx, &gy) {
        eprintln!("25-D reference nMSE {r:.5}");
        assert!(e <= r * (1.0 + 1e-9), "ours {e} vs reference {r}");
    }
}
