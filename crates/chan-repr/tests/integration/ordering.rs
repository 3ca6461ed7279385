//! The decoders' documented order: modes by decreasing certainty, equal certainties by
//! increasing value (1-D, periodic and n-D), whatever order the values were added in.

use chan_repr::{ChannelBasis, ChannelGrid, Kernel, PeriodicBasis, SoftHistogram};

#[test]
fn equal_certainties_come_out_in_value_order() {
    // B-spline channels sum to exactly 1 around each of these values: equal certainties.
    let b = ChannelBasis::integer(20, Kernel::BSpline2).unwrap();
    let mut c = b.encode(15.0).unwrap();
    b.accumulate(9.0, 1.0, &mut c).unwrap();
    b.accumulate(4.0, 1.0, &mut c).unwrap();
    let values: Vec<f64> = b.decode(&c).unwrap().iter().map(|m| m.value).collect();
    assert_eq!(values, [4.0, 9.0, 15.0]);

    let p = PeriodicBasis::new(360.0, 36, Kernel::BSpline2).unwrap();
    let mut c = p.encode(300.0).unwrap();
    p.accumulate(20.0, 1.0, &mut c).unwrap();
    p.accumulate(150.0, 1.0, &mut c).unwrap();
    let values: Vec<f64> = p.decode(&c).unwrap().iter().map(|m| m.value).collect();
    assert_eq!(values.len(), 3);
    for (got, want) in values.iter().zip([20.0, 150.0, 300.0]) {
        assert!((got - want).abs() < 1e-9, "{values:?}");
    }

    let g = ChannelGrid::new(vec![b.clone(), b]).unwrap();
    let mut h = SoftHistogram::new(g).unwrap();
    for x in [[15.0, 3.0], [4.0, 12.0], [4.0, 5.0]] {
        h.add(&x, 1.0).unwrap();
    }
    let values: Vec<Vec<f64>> = h.decode().unwrap().into_iter().map(|m| m.value).collect();
    assert_eq!(values, [[4.0, 5.0], [4.0, 12.0], [15.0, 3.0]]);
}

#[test]
fn a_more_certain_mode_comes_first_whatever_its_value() {
    let b = ChannelBasis::integer(20, Kernel::BSpline2).unwrap();
    let mut c = b.encode_weighted(4.0, 1.0).unwrap();
    b.accumulate(15.0, 3.0, &mut c).unwrap();
    b.accumulate(9.0, 2.0, &mut c).unwrap();
    let modes = b.decode(&c).unwrap();
    let values: Vec<f64> = modes.iter().map(|m| m.value).collect();
    assert_eq!(values, [15.0, 9.0, 4.0]);
    assert!(modes.windows(2).all(|w| w[0].certainty > w[1].certainty));
}
