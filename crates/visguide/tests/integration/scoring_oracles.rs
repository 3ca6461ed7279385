//! Independent oracles for the scoring glue: the overlap error against a fine-grid area count
//! written here from the ellipses' quadratic forms (rotated, elongated, offset ellipses in every
//! normalisation and offset mode; concentric scaled copies against the closed form), and the
//! precision–recall sweep against counting from its definitions (ties, ratios on the grid,
//! nothing existing), and the linearised mapping of an ellipse, exact under an affine map
//! (shears and mirrors included: the mapped boundary is the image of the boundary) and undone
//! by the inverse homography. Random cases are drawn from a fixed seed.

use visguide::Homography;
use visguide::scoring::overlap::{
    Ellipse, Normalisation, Offset, map_linearised, overlap_error, radius,
};
use visguide::scoring::pr::{GRID_STEPS, PAPER_T_R, RECALL_LEVELS, Scored, sweep};

use crate::common::cases;
use cases::Rng;

/// The ellipse with semi-axes `r1`, `r2`, the first at angle `theta`, about `(u, v)`:
/// `M = R diag(1/r1², 1/r2²) Rᵀ`.
fn rotated(u: f64, v: f64, r1: f64, r2: f64, theta: f64) -> Ellipse {
    let (c, s) = (theta.cos(), theta.sin());
    let (l1, l2) = (1.0 / (r1 * r1), 1.0 / (r2 * r2));
    Ellipse {
        u,
        v,
        a: l1 * c * c + l2 * s * s,
        b: (l1 - l2) * c * s,
        c: l1 * s * s + l2 * c * c,
    }
}

/// Inside `(x, y)ᵀ M (x, y) < 1` for `M` of `e` (centre ignored).
fn inside(e: &Ellipse, x: f64, y: f64) -> bool {
    e.a * x * x + 2.0 * e.b * x * y + e.c * y * y < 1.0
}

/// The largest semi-axis `1/√λ_min(M)`.
fn major(e: &Ellipse) -> f64 {
    let (t, d) = (e.a + e.c, e.a * e.c - e.b * e.b);
    let lmin = 0.5 * t - (0.25 * t * t - d).max(0.0).sqrt();
    1.0 / lmin.sqrt()
}

/// `1 − |A ∩ B| / |A ∪ B|` counted on an `n × n` grid over a square holding both, with A at the
/// origin and B at `offset`, in the ellipses' own pixel frame. The normalisations of the
/// benchmark scale both shapes by `k` and (`Offset::Scaled`) the offset by `k`, or
/// (`Offset::Faithful`) not: the same picture as B's centre at `offset / k` unscaled, and the
/// area ratio does not depend on the scale.
fn brute_force_error(a: &Ellipse, b: &Ellipse, offset: (f64, f64), n: usize) -> f64 {
    let reach = major(a)
        .max(offset.0.abs() + major(b))
        .max(offset.1.abs() + major(b));
    let step = 2.0 * reach / n as f64;
    let (mut inter, mut union) = (0u64, 0u64);
    for i in 0..n {
        let x = -reach + (i as f64 + 0.5) * step;
        for j in 0..n {
            let y = -reach + (j as f64 + 0.5) * step;
            let (ia, ib) = (inside(a, x, y), inside(b, x - offset.0, y - offset.1));
            inter += (ia && ib) as u64;
            union += (ia || ib) as u64;
        }
    }
    1.0 - inter as f64 / union as f64
}

/// Rotated, elongated ellipses of different sizes at offsets inside the distance gate, in every
/// mode, against the fine-grid count. The method counts on a grid of about 51 samples along the
/// window's shorter side (docs/methods.md § Overlap error, step 4), so it may differ from the
/// exact area ratio by a little; a wrong sign of the cross term, a swapped axis or a wrong
/// window clips or mirrors an ellipse and differs by far more.
#[test]
fn overlap_error_is_the_area_ratio_of_rotated_offset_ellipses_in_every_mode() {
    let mut rng = Rng::seeded(0x5EED_0001);
    let modes = [
        (Normalisation::Repeatability, Offset::Faithful),
        (Normalisation::Repeatability, Offset::Scaled),
        (Normalisation::Descriptor, Offset::Faithful),
        (Normalisation::Descriptor, Offset::Scaled),
        (Normalisation::Unscaled, Offset::Faithful),
        (Normalisation::Unscaled, Offset::Scaled),
    ];
    let mut worst: f64 = 0.0;
    let mut compared = 0;
    for case in 0..48 {
        let r1 = rng.uniform(3.0, 25.0);
        let a = rotated(
            rng.uniform(-50.0, 50.0),
            rng.uniform(-50.0, 50.0),
            r1,
            r1 / rng.uniform(1.0, 2.5),
            rng.uniform(-3.2, 3.2),
        );
        let s = rng.uniform(0.75, 1.35);
        let r1b = r1 * s;
        let (du, dv) = (rng.uniform(-0.4, 0.4) * r1, rng.uniform(-0.4, 0.4) * r1);
        let b = rotated(
            a.u + du,
            a.v + dv,
            r1b,
            r1b / rng.uniform(1.0, 2.5),
            rng.uniform(-3.2, 3.2),
        );
        let (norm, offset) = modes[case % modes.len()];
        let k = match norm {
            Normalisation::Repeatability => 30.0 / radius(&a),
            Normalisation::Descriptor => 3.0,
            Normalisation::Unscaled => 1.0,
        };
        // In a's own pixel frame, B's centre sits at the offset over k when only the shapes
        // are magnified.
        let shown = match offset {
            Offset::Scaled => (du, dv),
            Offset::Faithful => (du / k, dv / k),
        };
        let want = brute_force_error(&a, &b, shown, 500);
        let got = overlap_error(&a, &b, norm, offset);
        assert!(
            (0.0..=1.0).contains(&got),
            "case {case}: {got} outside [0, 1]"
        );
        let diff = (got - want).abs();
        assert!(
            diff < 0.03,
            "case {case} ({norm:?}, {offset:?}): got {got}, area ratio {want}; a {a:?}, b {b:?}"
        );
        worst = worst.max(diff);
        compared += 1;
    }
    assert_eq!(compared, 48);
    // The grid's own error is small on these sizes; a gross disagreement is a defect.
    assert!(worst < 0.03, "worst {worst}");
}

/// A concentric copy scaled by `s` (any rotation, any elongation): `ε = 1 − 1/s²` in closed
/// form; identical ellipses overlap exactly (ε = 0) in every mode.
#[test]
fn concentric_scaled_copies_have_the_closed_form_error() {
    let mut rng = Rng::seeded(0x5EED_0002);
    for case in 0..24 {
        let (r1, theta) = (rng.uniform(2.0, 40.0), rng.uniform(-3.2, 3.2));
        let r2 = r1 / rng.uniform(1.0, 3.0);
        let (u, v) = (rng.uniform(0.0, 800.0), rng.uniform(0.0, 600.0));
        let a = rotated(u, v, r1, r2, theta);
        let s = rng.uniform(1.05, 1.9);
        let big = rotated(u, v, r1 * s, r2 * s, theta);
        let want = 1.0 - 1.0 / (s * s);
        for norm in [
            Normalisation::Repeatability,
            Normalisation::Descriptor,
            Normalisation::Unscaled,
        ] {
            for offset in [Offset::Faithful, Offset::Scaled] {
                assert_eq!(overlap_error(&a, &a, norm, offset), 0.0, "case {case}");
                for (x, y) in [(&a, &big), (&big, &a)] {
                    let got = overlap_error(x, y, norm, offset);
                    assert!(
                        (got - want).abs() < 0.03,
                        "case {case} ({norm:?}, {offset:?}): got {got}, want {want} (s = {s})"
                    );
                }
            }
        }
    }
}

/// Swapping the image axes (x ↔ y in both ellipses and the offset) is a reflection: the area
/// ratio is the same, and so is the method's grid count, which is symmetric in the two axes.
#[test]
fn overlap_error_is_symmetric_under_swapping_the_axes() {
    let mut rng = Rng::seeded(0x5EED_0003);
    let swap = |e: &Ellipse| Ellipse {
        u: e.v,
        v: e.u,
        a: e.c,
        b: e.b,
        c: e.a,
    };
    for case in 0..32 {
        let r1 = rng.uniform(3.0, 20.0);
        let a = rotated(
            10.0,
            20.0,
            r1,
            r1 / rng.uniform(1.0, 3.0),
            rng.uniform(-3.2, 3.2),
        );
        let r1b = r1 * rng.uniform(0.7, 1.4);
        let b = rotated(
            10.0 + rng.uniform(-0.5, 0.5) * r1,
            20.0 + rng.uniform(-0.5, 0.5) * r1,
            r1b,
            r1b / rng.uniform(1.0, 3.0),
            rng.uniform(-3.2, 3.2),
        );
        for norm in [
            Normalisation::Repeatability,
            Normalisation::Descriptor,
            Normalisation::Unscaled,
        ] {
            let got = overlap_error(&a, &b, norm, Offset::Faithful);
            let mirrored = overlap_error(&swap(&a), &swap(&b), norm, Offset::Faithful);
            assert!(
                (got - mirrored).abs() < 1e-12,
                "case {case} ({norm:?}): {got} vs mirrored {mirrored}"
            );
        }
    }
}

/// Counts of matches with ratio below `t` and correct among them, by counting.
fn below(scored: &[Scored], t: f64) -> (usize, usize) {
    let m = scored.iter().filter(|s| s.ratio < t).count();
    let c = scored.iter().filter(|s| s.ratio < t && s.correct).count();
    (m, c)
}

/// The sweep against its definitions, counted directly: the grid points (the first, those where
/// the counts change, and 1.00), the point at `T_r = 0.5`, the step-integral AUC over the exact
/// curve (one step per distinct ratio, ties together), precision at the first distinct ratio
/// whose recall reaches each level, and the largest recall. Ratios are drawn on a coarse set
/// (ties, values exactly on grid points and at 0.5, ratios above 1), and `existing` may be 0.
#[test]
fn sweep_agrees_with_counting_from_the_definitions() {
    let mut rng = Rng::seeded(0x5EED_0004);
    for case in 0..200 {
        let n = rng.below(14) as usize;
        let scored: Vec<Scored> = (0..n)
            .map(|_| Scored {
                ratio: rng.below(25) as f64 * 0.05,
                correct: rng.below(2) == 1,
            })
            .collect();
        let correct_total = scored.iter().filter(|s| s.correct).count();
        let existing = if rng.below(6) == 0 {
            0
        } else {
            correct_total.max(1) + rng.below(5) as usize
        };
        let curve = sweep(&scored, existing);
        assert_eq!(curve.existing, existing, "case {case}");
        assert_eq!(curve.candidates, n, "case {case}");

        // Grid points.
        let mut want_points = Vec::new();
        let mut prev = None;
        for k in 1..=GRID_STEPS {
            let t = k as f64 / GRID_STEPS as f64;
            let counts = below(&scored, t);
            if prev != Some(counts) || k == GRID_STEPS {
                want_points.push((t, counts));
            }
            prev = Some(counts);
        }
        let got_points: Vec<(f64, (usize, usize))> = curve
            .points
            .iter()
            .map(|p| (p.t_r, (p.matches, p.correct)))
            .collect();
        assert_eq!(got_points, want_points, "case {case}: {scored:?}");
        for p in &curve.points {
            assert_eq!(
                p.precision,
                (p.matches > 0).then(|| p.correct as f64 / p.matches as f64)
            );
            assert_eq!(
                p.recall,
                (existing > 0).then(|| p.correct as f64 / existing as f64)
            );
        }

        // The operating point.
        let (m, c) = below(&scored, PAPER_T_R);
        let half = curve.summary.at_paper_threshold;
        assert_eq!((half.t_r, half.matches, half.correct), (PAPER_T_R, m, c));

        // Exact curve: at each distinct ratio r, everything with ratio ≤ r is reported.
        let mut distinct: Vec<f64> = scored.iter().map(|s| s.ratio).collect();
        distinct.sort_by(f64::total_cmp);
        distinct.dedup();
        let (mut auc, mut prev_recall) = (0.0, 0.0);
        let mut at = [None; 3];
        if existing > 0 {
            for &r in &distinct {
                let reported = scored.iter().filter(|s| s.ratio <= r).count();
                let good = scored.iter().filter(|s| s.ratio <= r && s.correct).count();
                let (precision, recall) =
                    (good as f64 / reported as f64, good as f64 / existing as f64);
                auc += precision * (recall - prev_recall);
                prev_recall = recall;
                for (slot, level) in at.iter_mut().zip(RECALL_LEVELS) {
                    if slot.is_none() && recall >= level {
                        *slot = Some(precision);
                    }
                }
            }
        }
        assert!(
            (curve.summary.auc - auc).abs() < 1e-12,
            "case {case}: auc {} vs {auc}",
            curve.summary.auc
        );
        assert_eq!(curve.summary.precision_at_recall, at, "case {case}");
        assert_eq!(
            curve.summary.max_recall,
            (existing > 0).then(|| correct_total as f64 / existing as f64),
            "case {case}"
        );
    }
}

/// Under an affine `H` the local affine approximation is `H` itself: every boundary point of
/// the ellipse maps onto the boundary of the mapped ellipse, for shears, anisotropic scales and
/// mirrors (negative determinant). Under a projective `H` the inverse homography's mapping
/// gives the ellipse back (its Jacobian at `H(c)` is the inverse of `H`'s at `c`).
#[test]
fn mapping_an_ellipse_is_exact_under_affine_maps_and_undone_by_the_inverse() {
    let mut rng = Rng::seeded(0x5EED_0005);
    for case in 0..40 {
        let r1 = rng.uniform(2.0, 30.0);
        let e = rotated(
            rng.uniform(0.0, 640.0),
            rng.uniform(0.0, 480.0),
            r1,
            r1 / rng.uniform(1.0, 4.0),
            rng.uniform(-3.2, 3.2),
        );
        let mirror = if case % 2 == 0 { 1.0 } else { -1.0 };
        let m = [
            mirror * rng.uniform(0.5, 2.0),
            rng.uniform(-0.6, 0.6),
            rng.uniform(-100.0, 100.0),
            rng.uniform(-0.6, 0.6),
            rng.uniform(0.5, 2.0),
            rng.uniform(-100.0, 100.0),
        ];
        let affine =
            Homography::from_row_major(&[m[0], m[1], m[2], m[3], m[4], m[5], 0.0, 0.0, 1.0])
                .unwrap();
        let mapped = map_linearised(&e, &affine).expect("an affine map keeps every ellipse");
        // Boundary points c + R diag(r1, r2) (cos t, sin t): the semi-axes from M's eigenvectors.
        let (t, d) = (e.a + e.c, e.a * e.c - e.b * e.b);
        let disc = (0.25 * t * t - d).max(0.0).sqrt();
        let (l1, l2) = (0.5 * t - disc, 0.5 * t + disc);
        // Eigenvector of l1: (b, l1 − a), or (1, 0) when M is diagonal.
        let (vx, vy) = if e.b.abs() > 1e-15 {
            (e.b, l1 - e.a)
        } else if e.a <= e.c {
            (1.0, 0.0)
        } else {
            (0.0, 1.0)
        };
        let n = vx.hypot(vy);
        let (ux, uy) = (vx / n, vy / n);
        for k in 0..16 {
            let s = k as f64 * std::f64::consts::TAU / 16.0;
            let (p, q) = (s.cos() / l1.sqrt(), s.sin() / l2.sqrt());
            let (x, y) = (e.u + p * ux - q * uy, e.v + p * uy + q * ux);
            let inside = e.a * (x - e.u).powi(2)
                + 2.0 * e.b * (x - e.u) * (y - e.v)
                + e.c * (y - e.v).powi(2);
            assert!(
                (inside - 1.0).abs() < 1e-9,
                "case {case}: not on e ({inside})"
            );
            let (mx, my) = affine.map(x, y).unwrap();
            let (dx, dy) = (mx - mapped.u, my - mapped.v);
            let on = mapped.a * dx * dx + 2.0 * mapped.b * dx * dy + mapped.c * dy * dy;
            assert!(
                (on - 1.0).abs() < 1e-8,
                "case {case}: the image of a boundary point gives {on}"
            );
        }
        // A projective map and back.
        let h = Homography::from_row_major(&[
            m[0],
            m[1],
            m[2],
            m[3],
            m[4],
            m[5],
            rng.uniform(-4e-4, 4e-4),
            rng.uniform(-4e-4, 4e-4),
            1.0,
        ])
        .unwrap();
        let there = map_linearised(&e, &h).expect("away from the horizon");
        let back = map_linearised(&there, &h.inverse()).expect("and back");
        for (got, want, scale) in [
            (back.u, e.u, 1e3),
            (back.v, e.v, 1e3),
            (back.a, e.a, 1e-3),
            (back.b, e.b, 1e-3),
            (back.c, e.c, 1e-3),
        ] {
            assert!(
                (got - want).abs() < 1e-10 * scale,
                "case {case}: {got} vs {want}"
            );
        }
    }
}
