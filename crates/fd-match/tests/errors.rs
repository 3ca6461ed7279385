//! Bad input gives typed errors, never a panic.

use fd_match::*;

fn ex() -> Extractor {
    Extractor::new(DescriptorConfig::default()).unwrap()
}

#[test]
fn too_few_points() {
    assert_eq!(
        ex().describe::<(f64, f64)>(&[]).unwrap_err(),
        FdError::TooFewPoints { got: 0 }
    );
    assert_eq!(
        ex().describe(&[(1, 1), (2, 2)]).unwrap_err(),
        FdError::TooFewPoints { got: 2 }
    );
    // A single MSER pixel, closed explicitly.
    assert_eq!(
        ex().describe(&[(5u32, 5u32), (5, 5)]).unwrap_err(),
        FdError::TooFewPoints { got: 1 }
    );
}

#[test]
fn zero_area() {
    for c in [
        vec![(0.0, 0.0), (1.0, 1.0), (2.0, 2.0)],
        // A one-pixel-wide line traced out and back.
        vec![(0.0, 0.0), (1.0, 0.0), (2.0, 0.0), (1.0, 0.0)],
    ] {
        assert!(
            matches!(ex().describe(&c), Err(FdError::ZeroArea { .. })),
            "{c:?}"
        );
    }
}

#[test]
fn repeated_points() {
    assert_eq!(
        ex().describe(&[[0.0, 0.0], [3.0, 0.0], [3.0, 0.0], [0.0, 2.0]])
            .unwrap_err(),
        FdError::RepeatedPoint {
            index: 2,
            x: 3.0,
            y: 0.0
        }
    );
}

#[test]
fn non_finite_coordinates() {
    for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
        assert!(matches!(
            ex().describe(&[(0.0, 0.0), (3.0, bad), (0.0, 2.0)]),
            Err(FdError::NonFinite { index: 1, .. })
        ));
    }
}

#[test]
fn invalid_configuration() {
    let cfg = DescriptorConfig {
        coefficients: 52,
        ..DescriptorConfig::default()
    };
    assert!(matches!(
        Extractor::new(cfg),
        Err(FdError::InvalidParameter {
            name: "coefficients",
            ..
        })
    ));
    assert!(describe_all(cfg, &[vec![(0, 0), (1, 0), (0, 1)]]).is_err());
}

#[test]
fn describe_all_collects_rejections_in_input_order() {
    let contours: Vec<Vec<(i32, i32)>> = vec![
        vec![(0, 0), (1, 1)],
        vec![(0, 0), (10, 0), (10, 7), (0, 7)],
        vec![(0, 0), (1, 0), (2, 0)],
        vec![(0, 0), (6, 1), (2, 5)],
    ];
    let d = describe_all(DescriptorConfig::default(), &contours).unwrap();
    assert_eq!(d.set.sources(), &[1, 3]);
    let idx: Vec<usize> = d.rejected.iter().map(|r| r.0).collect();
    assert_eq!(idx, vec![0, 2]);
    assert!(matches!(d.rejected[1].1, FdError::ZeroArea { .. }));
}

#[test]
fn accepted_descriptors_have_finite_afds() {
    // (The `DegenerateFirstHarmonic` error itself is unit-tested on an exact FD in `afd.rs`:
    // resampled polygons practically never hit it exactly.)
    let d = ex().describe(&[(0, 0), (9, 0), (9, 1), (0, 1)]).unwrap();
    assert!(d.afd0.iter().all(|v| v.is_finite()));
    assert!(d.afd1.iter().all(|v| v.re.is_finite() && v.im.is_finite()));
}

#[test]
fn pixel_contours_of_all_integer_types_are_accepted() {
    let sq32: Vec<(u32, u32)> = vec![
        (2, 2),
        (3, 2),
        (4, 2),
        (4, 3),
        (4, 4),
        (3, 4),
        (2, 4),
        (2, 3),
    ];
    let sqf: Vec<[f64; 2]> = sq32.iter().map(|&(x, y)| [x as f64, y as f64]).collect();
    let a = ex().describe(&sq32).unwrap();
    let b = ex().describe(&sqf).unwrap();
    assert_eq!(a, b);
    // Clockwise input is reoriented: same descriptor.
    let rev: Vec<(u32, u32)> = sq32.iter().rev().copied().collect();
    let c = ex().describe(&rev).unwrap();
    let e = Correlator::new(25, 256).correlate(&a.fd, &c.fd).error;
    assert!(e < 1e-9, "{e}");
}
