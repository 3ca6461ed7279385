//! The fast prediction (`predict`, `predict_into`, `predict_batch`, `predict_with_max_activation`:
//! distance from the triangular factor, cached slopes, compiled per input dimension 1–4 and for
//! any `n`) against independent computations, for every input dimension the compiled variants
//! serve, both kernels, diagonal and full metrics, one and two outputs, normalised inputs and
//! outputs, and cutoffs from negative to large:
//! - the prediction against `predict_with_confidence` and `predict_with_jacobian`, which
//!   recompute each field's distance as `(x−c)ᵀD(x−c)` and its local model through the PLS
//!   projections, as the reference library does (the confidence bound itself is checked
//!   against the C library in `tests/xml.rs`);
//! - the largest activation against a brute-force sum over the public field views (centre,
//!   metric `D`);
//! - the Jacobian against central finite differences of `predict` (`tests/jacobian.rs` covers
//!   n = 2 only).
#![allow(clippy::needless_range_loop)]

use lwpr::{Kernel, Lwpr, LwprBuilder};

/// A small LCG: uniform values in `[-1, 1]`.
struct Lcg(u64);

impl Lcg {
    fn next(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    }
}

/// A model trained on a smooth target over `[-1, 1]^n` (two outputs: the second scaled by 5).
fn trained(n: usize, m: usize, diag: bool, kernel: Kernel, seed: u64) -> Lwpr {
    let norm_in: Vec<f64> = (0..n).map(|i| 1.0 + 0.5 * i as f64).collect();
    let mut model = LwprBuilder::new(n, m)
        .init_d_spherical(if kernel == Kernel::BiSquare { 1.0 } else { 4.0 })
        .init_alpha(100.0)
        .w_gen(0.3)
        .diag_only(diag)
        .meta(!diag)
        .kernel(kernel)
        .norm_in(&norm_in)
        .norm_out(&vec![2.0; m])
        .build()
        .unwrap();
    let mut rng = Lcg(seed);
    for _ in 0..400 {
        let x: Vec<f64> = (0..n).map(|_| rng.next()).collect();
        let t = (2.0 * x[0]).sin() + x[n / 2] * x[n - 1];
        let y: Vec<f64> = (0..m).map(|k| t * (1.0 + 4.0 * k as f64)).collect();
        model.update(&x, &y).unwrap();
    }
    model
}

/// The activation of a field at raw input `x`, from its public view: `q = (x−c)ᵀD(x−c)` in
/// normalised units.
fn activation(model: &Lwpr, field: &lwpr::RfView<'_>, x: &[f64]) -> f64 {
    let n = model.n_in();
    let norm = &model.params().norm_in;
    let c = field.centre();
    let d = field.metric();
    let z: Vec<f64> = (0..n).map(|i| (x[i] - c[i]) / norm[i]).collect();
    let mut q = 0.0;
    for i in 0..n {
        for j in 0..n {
            q += z[i] * d[i + j * n] * z[j];
        }
    }
    match model.params().kernel {
        Kernel::Gaussian => (-0.5 * q).exp(),
        Kernel::BiSquare => {
            if q < 4.0 {
                (1.0 - 0.25 * q).powi(2)
            } else {
                0.0
            }
        }
    }
}

fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol * (1.0 + a.abs().max(b.abs()))
}

#[test]
fn fast_prediction_agrees_with_the_reference_style_computations() {
    let mut checked_nonzero = 0;
    let mut far_max = 0;
    for (case, (n, m, diag, kernel)) in [
        (1, 1, false, Kernel::Gaussian),
        (1, 2, false, Kernel::BiSquare),
        (2, 1, true, Kernel::Gaussian),
        (3, 2, false, Kernel::Gaussian),
        (3, 1, true, Kernel::BiSquare),
        (4, 1, false, Kernel::BiSquare),
        (4, 2, false, Kernel::Gaussian),
        (5, 1, false, Kernel::Gaussian),
        (6, 2, true, Kernel::Gaussian),
        (7, 1, false, Kernel::BiSquare),
    ]
    .into_iter()
    .enumerate()
    {
        let label = format!("n = {n}, m = {m}, diag_only = {diag}, {kernel:?}");
        let model = trained(n, m, diag, kernel, 11 + case as u64);
        let mut rng = Lcg(1000 + case as u64);
        // Points inside the training region, and beyond it (scale 2.5), where only the tails
        // of the fields (or none) reach.
        let points: Vec<Vec<f64>> = (0..40)
            .map(|k| {
                let s = if k % 4 == 3 { 2.5 } else { 1.0 };
                (0..n).map(|_| s * rng.next()).collect()
            })
            .collect();
        for cutoff in [-1.0, 0.0, 0.001, 0.5] {
            let flat: Vec<f64> = points.concat();
            let batch = model.predict_batch(&flat, cutoff).unwrap();
            for (p, x) in points.iter().enumerate() {
                let y = model.predict(x, cutoff).unwrap();
                let mut into = vec![f64::NAN; m];
                model.predict_into(x, cutoff, &mut into).unwrap();
                let (y_max, w_max) = model.predict_with_max_activation(x, cutoff).unwrap();
                let conf = model.predict_with_confidence(x, cutoff).unwrap();
                let jac = model.predict_with_jacobian(x, cutoff).unwrap();
                for o in 0..m {
                    let what = format!("{label}, cutoff {cutoff}, x = {x:?}, output {o}");
                    assert_eq!(y[o].to_bits(), into[o].to_bits(), "{what}: predict_into");
                    assert_eq!(y[o].to_bits(), batch[p * m + o].to_bits(), "{what}: batch");
                    assert_eq!(y[o].to_bits(), y_max[o].to_bits(), "{what}: with max");
                    assert!(
                        close(y[o], conf.y[o], 1e-11),
                        "{what}: predict {} vs confidence path {}",
                        y[o],
                        conf.y[o]
                    );
                    assert!(
                        close(y[o], jac.y[o], 1e-11),
                        "{what}: predict {} vs Jacobian path {}",
                        y[o],
                        jac.y[o]
                    );
                    checked_nonzero += usize::from(y[o] != 0.0);
                    let brute = model
                        .receptive_fields(o)
                        .iter()
                        .map(|f| activation(&model, f, x))
                        .fold(0.0, f64::max);
                    assert!(
                        close(w_max[o], brute, 1e-11),
                        "{what}: largest activation {} vs brute force {brute}",
                        w_max[o]
                    );
                    far_max += usize::from(brute > 0.0 && brute < 0.001);
                }
            }
        }
        assert!(
            model.num_rfs().iter().all(|&k| k > 1),
            "{label}: several fields ({:?})",
            model.num_rfs()
        );
    }
    assert!(
        checked_nonzero > 500,
        "{checked_nonzero} nonzero predictions"
    );
    assert!(far_max > 0, "some largest activations below 0.001 checked");
}

/// The analytic Jacobian against central differences of `predict` for the input dimensions and
/// options `tests/jacobian.rs` (n = 2) does not reach.
#[test]
fn jacobian_matches_central_differences_in_every_dimension() {
    let h = 1e-6;
    for (case, (n, m, diag, kernel)) in [
        (1, 2, false, Kernel::Gaussian),
        (3, 1, true, Kernel::BiSquare),
        (4, 2, false, Kernel::Gaussian),
        (5, 1, false, Kernel::Gaussian),
        (6, 1, true, Kernel::Gaussian),
    ]
    .into_iter()
    .enumerate()
    {
        let model = trained(n, m, diag, kernel, 50 + case as u64);
        let mut rng = Lcg(77 + case as u64);
        let mut nonzero = 0;
        for _ in 0..20 {
            let x: Vec<f64> = (0..n).map(|_| 0.9 * rng.next()).collect();
            // Cutoff 0: no field switches on or off between the difference points.
            let an = model.predict_with_jacobian(&x, 0.0).unwrap();
            for j in 0..n {
                let (mut xp, mut xm) = (x.clone(), x.clone());
                xp[j] += h;
                xm[j] -= h;
                let (yp, ym) = (
                    model.predict(&xp, 0.0).unwrap(),
                    model.predict(&xm, 0.0).unwrap(),
                );
                for o in 0..m {
                    let fd = (yp[o] - ym[o]) / (2.0 * h);
                    let a = an.jacobian[(o, j)];
                    assert!(
                        (fd - a).abs() <= 1e-5 * (1.0 + a.abs()),
                        "n = {n}, {kernel:?}, diag_only = {diag}: d y{o}/d x{j} at {x:?}: \
                         analytic {a}, differences {fd}"
                    );
                    nonzero += usize::from(a.abs() > 1e-3);
                }
            }
        }
        assert!(nonzero > 5, "n = {n}: {nonzero} nonzero derivatives");
    }
}
