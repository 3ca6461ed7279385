//! The analytic Jacobian against central finite differences (property test), and its
//! consistency with `predict`.
#![allow(clippy::needless_range_loop)]

use crate::harness;

use harness::*;
use lwpr::{Kernel, Lwpr, LwprBuilder};
use proptest::prelude::{prop_assert, proptest};
use std::sync::OnceLock;

fn models() -> &'static [Lwpr] {
    static M: OnceLock<Vec<Lwpr>> = OnceLock::new();
    M.get_or_init(|| {
        let (x, y) = cross_samples(8, 3000, 0.05);
        let builders = [
            LwprBuilder::new(2, 2)
                .init_d_spherical(50.0)
                .init_alpha(250.0)
                .w_gen(0.2)
                .norm_in(&[2.0, 0.5])
                .norm_out(&[1.0, 4.0]),
            LwprBuilder::new(2, 2)
                .init_d_spherical(25.0)
                .diag_only(false)
                .meta(true)
                .w_gen(0.2),
            LwprBuilder::new(2, 2)
                .init_d_spherical(10.0)
                .kernel(Kernel::BiSquare)
                .w_gen(0.2),
        ];
        builders
            .into_iter()
            .map(|b| {
                let mut m = b.build().unwrap();
                for (a, t) in x.chunks(2).zip(&y) {
                    m.update(a, &[*t, (3.0 * a[0]).sin() * a[1]]).unwrap();
                }
                m
            })
            .collect()
    })
}

proptest! {
    #![proptest_config(crate::seeded(64))]
    #[test]
    fn jacobian_matches_central_differences(k in 0usize..3, a in -0.9f64..0.9, b in -0.9f64..0.9) {
        let m = &models()[k];
        // Cutoff 0 keeps the prediction smooth (no field switches on or off between the
        // difference points).
        let p = m.predict_with_jacobian(&[a, b], 0.0).unwrap();
        let y = m.predict(&[a, b], 0.0).unwrap();
        for o in 0..2 {
            prop_assert!((p.y[o] - y[o]).abs() <= 1e-12 * (1.0 + y[o].abs()));
        }
        let h = 1e-6;
        for j in 0..2 {
            let mut xp = [a, b];
            let mut xm = [a, b];
            xp[j] += h;
            xm[j] -= h;
            let (yp, ym) = (m.predict(&xp, 0.0).unwrap(), m.predict(&xm, 0.0).unwrap());
            for o in 0..2 {
                let fd = (yp[o] - ym[o]) / (2.0 * h);
                let an = p.jacobian[(o, j)];
                prop_assert!((fd - an).abs() <= 1e-5 * (1.0 + an.abs()), "model {} d y{}/d x{}: analytic {} fd {}", k, o, j, an, fd);
            }
        }
    }
}

/// A noise-free linear map is learned with its slope (two inputs, so the two initial PLS
/// directions span the input space).
#[test]
fn jacobian_of_a_linear_function_is_its_slope() {
    let mut m = LwprBuilder::new(2, 2)
        .init_d_spherical(2.0)
        .w_gen(0.3)
        .build()
        .unwrap();
    let mut rng = Rng::new(3);
    for _ in 0..4000 {
        let x = [rng.uniform(), rng.uniform()];
        m.update(&x, &[2.0 * x[0] - x[1], 0.5 * x[1] - 3.0 * x[0]])
            .unwrap();
    }
    let p = m.predict_with_jacobian(&[0.5, 0.5], 0.001).unwrap();
    let expected = [[2.0, -1.0], [-3.0, 0.5]];
    for (o, row) in expected.iter().enumerate() {
        for (j, e) in row.iter().enumerate() {
            assert!(
                (p.jacobian[(o, j)] - e).abs() < 1e-2,
                "J[{o},{j}] = {}",
                p.jacobian[(o, j)]
            );
        }
    }
    assert!(
        (p.y[0] - 0.5).abs() < 1e-2 && (p.y[1] + 1.25).abs() < 1e-2,
        "{:?}",
        p.y
    );
}
