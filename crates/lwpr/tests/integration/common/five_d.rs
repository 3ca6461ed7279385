//! The 5-D full-metric model that the save/load tests write and read: a module of the integration
//! tests (`common::five_d`, used by `xml.rs`) and included with `#[path]` by the unit tests of
//! `src/io.rs`. Both crate roots name `Lwpr` and `LwprBuilder` (the library defines them, the
//! tests' `main.rs` imports them).

use crate::{Lwpr, LwprBuilder};

/// `LwprBuilder::new(5, 1)` with a full distance metric, `init_D = 4·I`.
pub fn builder() -> LwprBuilder {
    LwprBuilder::new(5, 1)
        .init_d_spherical(4.0)
        .diag_only(false)
}

/// Sample `k` of a smooth 5-D curve (`t = 0.37 k`: `sin t, cos t, sin 2t, 0.1 t mod 1,
/// cos 0.7 t`) and its target `x₀ x₁ + x₂`.
pub fn sample(k: usize) -> ([f64; 5], f64) {
    let t = k as f64 * 0.37;
    let x = [
        t.sin(),
        t.cos(),
        (2.0 * t).sin(),
        0.1 * t % 1.0,
        (0.7 * t).cos(),
    ];
    (x, x[0] * x[1] + x[2])
}

/// A model of `builder` trained on the first `n` samples of the curve ([`sample`]).
pub fn trained(builder: LwprBuilder, n: usize) -> Lwpr {
    let mut m = builder.build().unwrap();
    for k in 0..n {
        let (x, y) = sample(k);
        m.update(&x, &[y]).unwrap();
    }
    m
}
