//! Independent oracles for the geometry glue on inputs the docs allow but the unit tests do not
//! meet: the corner error in closed form on non-square, one-pixel and empty images; the DLT
//! and the robust fit recovering exactly a known homography that reverses orientation or has
//! `h₃₃ = 0`, from the minimal four points and from many; the transfer error in closed form.

use nalgebra::Matrix3;
use visguide::geometry::fit::{Point, dlt, transfer_error};
use visguide::{Homography, RansacConfig, fit_homography};

fn project(h: &Matrix3<f64>, p: Point) -> Point {
    let w = h[(2, 0)] * p.0 + h[(2, 1)] * p.1 + h[(2, 2)];
    (
        (h[(0, 0)] * p.0 + h[(0, 1)] * p.1 + h[(0, 2)]) / w,
        (h[(1, 0)] * p.0 + h[(1, 1)] * p.1 + h[(1, 2)]) / w,
    )
}

/// The largest entry difference of two matrices after scaling each to unit Frobenius norm with
/// the sign of its largest-magnitude entry (a homography is defined up to scale).
fn projective_distance(a: &Matrix3<f64>, b: &Matrix3<f64>) -> f64 {
    let unit = |m: &Matrix3<f64>| {
        let big = m
            .iter()
            .copied()
            .fold(0.0f64, |x, v| if v.abs() > x.abs() { v } else { x });
        m / (m.norm() * big.signum())
    };
    (unit(a) - unit(b)).abs().max()
}

/// Homographies the tests recover: a general one, a mirror (negative determinant) and one with
/// `h₃₃ = 0` (it sends the origin to infinity; the points used stay away from that line).
fn truths() -> [Matrix3<f64>; 3] {
    [
        Matrix3::new(1.1, 0.2, 30.0, -0.1, 0.9, -12.0, 2e-4, -1e-4, 1.0),
        Matrix3::new(-1.0, 0.05, 640.0, 0.02, 1.0, 4.0, 1e-4, 0.0, 1.0),
        Matrix3::new(0.0, 1.0, 5.0, 1.0, 0.0, 7.0, 1e-3, 1e-3, 0.0),
    ]
}

fn source_points() -> Vec<Point> {
    let mut s = Vec::new();
    for i in 0..6 {
        for j in 0..5 {
            // An irregular grid in the first quadrant, away from x + y = 0.
            s.push((
                40.0 + 95.0 * i as f64 + 7.0 * (j % 2) as f64,
                30.0 + 80.0 * j as f64 + 3.0 * i as f64,
            ));
        }
    }
    s
}

#[test]
fn dlt_recovers_mirrors_and_homographies_with_a_zero_corner_entry() {
    for (t, h) in truths().iter().enumerate() {
        let src = source_points();
        let dst: Vec<Point> = src.iter().map(|&p| project(h, p)).collect();
        let all = dlt(&src, &dst).expect("a fit");
        assert!(projective_distance(&all, h) < 1e-9, "truth {t}: {all}");
        // The minimal sample: four points, no three collinear.
        let idx = [0, 5, 24, 29];
        let (s4, d4): (Vec<Point>, Vec<Point>) = idx.iter().map(|&k| (src[k], dst[k])).unzip();
        let four = dlt(&s4, &d4).expect("a fit from four");
        assert!(projective_distance(&four, h) < 1e-9, "truth {t}: {four}");
        // Every correspondence maps exactly.
        for (&p, &q) in src.iter().zip(&dst) {
            assert!(transfer_error(&four, p, q) < 1e-7, "truth {t}");
        }
    }
}

#[test]
fn the_robust_fit_recovers_them_from_four_and_from_many_with_outliers() {
    let cfg = RansacConfig::default();
    for (t, h) in truths().iter().enumerate() {
        let src = source_points();
        let mut dst: Vec<Point> = src.iter().map(|&p| project(h, p)).collect();
        let idx = [0, 5, 24, 29];
        let (s4, d4): (Vec<Point>, Vec<Point>) = idx.iter().map(|&k| (src[k], dst[k])).unzip();
        let fit = fit_homography(&s4, &d4, &cfg).expect("four exact points");
        assert_eq!(fit.inlier_count, 4, "truth {t}");
        assert!(
            projective_distance(fit.homography.matrix(), h) < 1e-8,
            "truth {t}"
        );
        // Every fourth correspondence replaced by a gross outlier.
        for (k, q) in dst.iter_mut().enumerate() {
            if k % 4 == 1 {
                *q = (q.0 + 150.0 + 7.0 * k as f64, q.1 - 90.0);
            }
        }
        let fit = fit_homography(&src, &dst, &cfg).expect("a robust fit");
        let want: Vec<bool> = (0..src.len()).map(|k| k % 4 != 1).collect();
        assert_eq!(fit.inliers, want, "truth {t}");
        assert!(
            projective_distance(fit.homography.matrix(), h) < 1e-8,
            "truth {t}"
        );
        assert!(fit.rms < 1e-6, "truth {t}: rms {}", fit.rms);
    }
}

#[test]
fn transfer_error_is_the_distance_after_mapping() {
    // A translation by (3, 4) and a mirror x ↦ −x: closed-form distances.
    let shift = Matrix3::new(1.0, 0.0, 3.0, 0.0, 1.0, 4.0, 0.0, 0.0, 1.0);
    assert_eq!(transfer_error(&shift, (1.0, 1.0), (1.0, 1.0)), 5.0);
    assert_eq!(transfer_error(&shift, (1.0, 1.0), (4.0, 5.0)), 0.0);
    let mirror = Matrix3::new(-2.0, 0.0, 0.0, 0.0, 2.0, 0.0, 0.0, 0.0, 2.0);
    assert_eq!(transfer_error(&mirror, (3.0, 7.0), (0.0, 7.0)), 3.0);
    // A point on the line at infinity.
    let g = Matrix3::new(1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 1.0, 0.0, 0.0);
    assert_eq!(transfer_error(&g, (0.0, 5.0), (0.0, 0.0)), f64::INFINITY);
}

#[test]
fn corner_error_is_the_largest_corner_distance_on_any_image_size() {
    let id = Homography::from_row_major(&[1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]).unwrap();
    // Twice the size, about the origin: the far corner (w − 1, h − 1) moves by its own length.
    let double =
        Homography::from_row_major(&[2.0, 0.0, 0.0, 0.0, 2.0, 0.0, 0.0, 0.0, 1.0]).unwrap();
    for (w, h) in [
        (640u32, 480u32),
        (7, 1000),
        (1000, 7),
        (2, 1),
        (1, 1),
        (0, 0),
    ] {
        let (fw, fh) = ((w.max(1) - 1) as f64, (h.max(1) - 1) as f64);
        assert_eq!(double.corner_error(&id, w, h), fw.hypot(fh), "{w} × {h}");
        assert_eq!(id.corner_error(&double, w, h), fw.hypot(fh), "{w} × {h}");
    }
    // Stretching only x by 3: the corners on the right move by 2 (w − 1).
    let stretch =
        Homography::from_row_major(&[3.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]).unwrap();
    assert_eq!(stretch.corner_error(&id, 7, 1000), 12.0);
    assert_eq!(stretch.corner_error(&id, 1000, 7), 1998.0);
    // A translation moves every corner by the same distance, whatever the size.
    let shift =
        Homography::from_row_major(&[1.0, 0.0, 3.0, 0.0, 1.0, -4.0, 0.0, 0.0, 1.0]).unwrap();
    for (w, h) in [(640u32, 480u32), (1, 1), (0, 0)] {
        assert_eq!(shift.corner_error(&id, w, h), 5.0);
    }
    // A rotation by 90° about the image centre of a non-square image: the corner (0, 0)
    // goes to ((w−1+h−1)/2, (h−1−(w−1))/2) and moves by √2 times its distance to the centre.
    let (w, h) = (9u32, 5u32);
    let (cx, cy) = (4.0, 2.0);
    let rot = Homography::from_row_major(&[0.0, -1.0, cx + cy, 1.0, 0.0, cy - cx, 0.0, 0.0, 1.0])
        .unwrap();
    let want = 2f64.sqrt() * (cx * cx + cy * cy).sqrt();
    assert!((rot.corner_error(&id, w, h) - want).abs() < 1e-12);
}

/// The frame ellipse mapped by `x ↦ A x + t`: centre `A c + t`, shape `A⁻ᵀ M A⁻¹`.
fn mapped_frame(
    e: &visguide::scoring::overlap::Ellipse,
    a: &nalgebra::Matrix2<f64>,
    t: (f64, f64),
) -> visguide::scoring::overlap::Ellipse {
    let ai = a.try_inverse().unwrap();
    let m = ai.transpose() * nalgebra::Matrix2::new(e.a, e.b, e.b, e.c) * ai;
    visguide::scoring::overlap::Ellipse {
        u: a[(0, 0)] * e.u + a[(0, 1)] * e.v + t.0,
        v: a[(1, 0)] * e.u + a[(1, 1)] * e.v + t.1,
        a: m[(0, 0)],
        b: 0.5 * (m[(0, 1)] + m[(1, 0)]),
        c: m[(1, 1)],
    }
}

/// The local affine map is exactly a true affine map `A = R(φ) S` (positive determinant) from
/// the two frames and φ, also at the ends of the rotation range (φ = π, φ just above −π, φ = 0),
/// for elongated frames and shears, and for a circle as frame 1.
#[test]
fn local_affine_recovers_true_maps_at_the_ends_of_the_rotation_range() {
    use nalgebra::Matrix2;
    use visguide::geometry::local_affine;
    use visguide::scoring::overlap::Ellipse;
    let frames = [
        Ellipse {
            u: 10.0,
            v: 20.0,
            a: 0.01,
            b: 0.0,
            c: 0.01,
        },
        Ellipse {
            u: -5.0,
            v: 3.0,
            a: 0.25,
            b: 0.0,
            c: 0.0025,
        },
        Ellipse {
            u: 100.0,
            v: 50.0,
            a: 0.04,
            b: 0.03,
            c: 0.04,
        },
    ];
    let pi = std::f64::consts::PI;
    for phi in [pi, -pi + 1e-9, 0.0, 0.5 * pi, -0.5 * pi, 3.0] {
        for (s, shear, aniso) in [(1.0, 0.0, 1.0), (0.2, 0.9, 4.0), (5.0, -1.5, 0.25)] {
            // S = L Lᵀ symmetric positive definite: R(φ) S has polar rotation exactly φ.
            let l = Matrix2::new(s * aniso, 0.0, shear * s, s / aniso);
            let sym = l * l.transpose();
            assert!(sym.determinant() > 0.0 && sym[(0, 0)] > 0.0);
            let r = Matrix2::new(phi.cos(), -phi.sin(), phi.sin(), phi.cos());
            let a = r * sym;
            for e1 in &frames {
                let e2 = mapped_frame(e1, &a, (7.0, -2.0));
                let got = local_affine(e1, &e2, phi).expect("a map");
                let tol = 1e-7 * a.abs().max().max(1.0);
                assert!(
                    (got.a - a).abs().max() < tol,
                    "φ {phi}, {e1:?}: {} vs {}",
                    got.a,
                    a
                );
                let (x, y) = got.map(e1.u + 3.0, e1.v - 4.0);
                let want = (
                    e2.u + a[(0, 0)] * 3.0 - a[(0, 1)] * 4.0,
                    e2.v + a[(1, 0)] * 3.0 - a[(1, 1)] * 4.0,
                );
                assert!((x - want.0).abs() < 10.0 * tol && (y - want.1).abs() < 10.0 * tol);
                assert!((got.scale() - a.determinant().sqrt()).abs() < 1e-7 * got.scale());
            }
        }
    }
}
