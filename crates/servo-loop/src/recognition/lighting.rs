//! The lighting model of recognition: a frame is its static scene `B` under a global gain and
//! brightness gradients, `I(u, v) ≈ B(u, v) · (a + b u' + c v')` with `u', v'` in `[-1, 1]` across
//! the image (`arm-sim`'s lighting change has exactly this form; a real camera's is close to it).
//! The coefficients come from a robust least-squares fit on an 8-pixel grid (three rounds,
//! dropping residuals beyond `3·1.4826·MAD`).

use nalgebra::{Matrix3, Vector3};

/// Lighting coefficients `[a, b, c]` of `I ≈ B (a + b u' + c v')`.
pub(crate) fn fit_lighting(img: &[f32], bg: &[f32], w: usize, h: usize) -> [f64; 3] {
    let (hw, hh) = (0.5 * w as f64, 0.5 * h as f64);
    let mut coef = [1.0, 0.0, 0.0];
    let mut limit = f64::INFINITY;
    let mut res = Vec::new();
    for _ in 0..3 {
        let mut ata = Matrix3::<f64>::zeros();
        let mut atb = Vector3::<f64>::zeros();
        res.clear();
        for y in (4..h).step_by(8) {
            let vy = (y as f64 + 0.5 - hh) / hh;
            for x in (4..w).step_by(8) {
                let i = y * w + x;
                let b = f64::from(bg[i]);
                let ux = (x as f64 + 0.5 - hw) / hw;
                let pred = b * (coef[0] + coef[1] * ux + coef[2] * vy);
                let r = f64::from(img[i]) - pred;
                res.push(r.abs());
                if r.abs() > limit || b < 1.0 {
                    continue;
                }
                let a = Vector3::new(b, b * ux, b * vy);
                ata += a * a.transpose();
                atb += a * f64::from(img[i]);
            }
        }
        if let Some(s) = ata.cholesky() {
            let c = s.solve(&atb);
            coef = [c[0], c[1], c[2]];
        }
        // Robust scale of this round's residuals for the next round's cut.
        let mid = res.len() / 2;
        if res.is_empty() {
            break;
        }
        let mad = *res.select_nth_unstable_by(mid, f64::total_cmp).1;
        limit = (3.0 * 1.4826 * mad).max(3.0);
    }
    coef
}

/// Per-pixel gain `a + b u' + c v'`.
pub(crate) fn lighting_field(w: usize, h: usize, coef: [f64; 3]) -> Vec<f32> {
    let (hw, hh) = (0.5 * w as f64, 0.5 * h as f64);
    let mut out = Vec::with_capacity(w * h);
    for y in 0..h {
        let vy = (y as f64 + 0.5 - hh) / hh;
        for x in 0..w {
            let ux = (x as f64 + 0.5 - hw) / hw;
            out.push((coef[0] + coef[1] * ux + coef[2] * vy) as f32);
        }
    }
    out
}

/// Lit scene `(a + b u' + c v') B` subtracted from `img`.
pub(crate) fn residual(img: &[f32], bg: &[f32], w: usize, h: usize, coef: [f64; 3]) -> Vec<f32> {
    let (hw, hh) = (0.5 * w as f32, 0.5 * h as f32);
    let [a, b, c] = coef.map(|v| v as f32);
    let mut out = vec![0.0f32; w * h];
    for y in 0..h {
        let row = a + c * (y as f32 + 0.5 - hh) / hh;
        for x in 0..w {
            let g = row + b * (x as f32 + 0.5 - hw) / hw;
            let i = y * w + x;
            out[i] = img[i] - g * bg[i];
        }
    }
    out
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// A deterministic texture in [85, 115] (a table's grain: ±15 %), shared by the
    /// recognition tests.
    pub(crate) fn texture(w: usize, h: usize) -> Vec<f32> {
        (0..w * h)
            .map(|i| {
                let (x, y) = ((i % w) as f32, (i / w) as f32);
                100.0 + 10.0 * (x / 3.1).sin() * (y / 4.7).cos() + 5.0 * ((x + 2.0 * y) / 9.0).sin()
            })
            .collect()
    }

    #[test]
    fn lighting_fit_recovers_gain_and_gradients_despite_an_object() {
        let (w, h) = (160, 120);
        let bg = texture(w, h);
        let truth = [1.07, 0.03, -0.02];
        let field = lighting_field(w, h, truth);
        let mut img: Vec<f32> = bg.iter().zip(&field).map(|(b, g)| b * g).collect();
        // An object covering ≈ 6 % of the image.
        for y in 40..60 {
            for x in 60..90 {
                img[y * w + x] = 250.0;
            }
        }
        let c = fit_lighting(&img, &bg, w, h);
        for k in 0..3 {
            assert!((c[k] - truth[k]).abs() < 1e-4, "{c:?} vs {truth:?}");
        }
    }

    #[test]
    fn residual_of_a_lit_scene_is_zero() {
        let (w, h) = (40, 30);
        let bg = texture(w, h);
        let coef = [0.9, -0.05, 0.04];
        let field = lighting_field(w, h, coef);
        let img: Vec<f32> = bg.iter().zip(&field).map(|(b, g)| b * g).collect();
        let r = residual(&img, &bg, w, h, coef);
        assert!(r.iter().all(|v| v.abs() < 1e-3), "{:?}", &r[..4]);
    }
}
