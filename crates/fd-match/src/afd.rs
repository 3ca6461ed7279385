//! Affine-invariant Fourier descriptors of orders 0 and 1 (AFD0, AFD1), after Arbter et al.
//! (PAMI 1990), as reconstructed in docs/methods.md § Fourier descriptors (Arbter's exact formulas
//! were not available; the construction below is invariant by derivation and verified by the
//! property test `afd_is_invariant_to_random_affine_maps`).
//!
//! From the complex FD `C(n)` of `c = x + i·y` (real `x, y`), the coordinate spectra are
//! `X_n = (C(n) + conj C(−n)) / 2` and `Y_n = (C(n) − conj C(−n)) / 2i`. With
//! `U_n = (X_n, Y_n)ᵀ` and `Δ_{k,p} = det[U_k, conj U_p] = X_k conj Y_p − Y_k conj X_p`, an affine
//! map `x ↦ A x + b` together with a start-point shift `φ` (of the affine-arc-length parameter)
//! gives `U_k ↦ e^{ikφ} A U_k` for `k ≠ 0` and hence `Δ_{k,p} ↦ det A · e^{i(k−p)φ} Δ_{k,p}`.
//! With `q_k = Δ_{k,1} / Δ_{1,1}` (free of `det A`):
//!
//! * AFD0: `I⁰_k = |q_k|` (start point and affine map cancel; inter-harmonic phase discarded);
//! * AFD1: `I¹_k = q_k · e^{−i(k−1)θ}` with `θ = arg q₂` (product form: the start-point phase is
//!   cancelled by a power of the reference term `q₂`, so first-order phase is kept).
//!
//! `k` runs over `−K..=K` without 0 and 1 (`q₁ = 1`), i.e. `2K − 1` entries in ascending `k`.
//! Each vector is normalised to unit ℓ2 norm, so its SSD lies in `[0, 4]` like the FD errors and
//! the preselection thresholds of Paper A are on a comparable scale (a choice of ours; Arbter's
//! normalisation is unknown). Reflections (`det A < 0`) are excluded by orienting every contour
//! positively ([`crate::validate_contour`]).

use rustfft::num_complex::Complex64;

use crate::descriptor::fd_index;
use crate::error::FdError;

/// Writes AFD0 and AFD1 of the FD `fd` (layout of [`crate::DescriptorSet::fd`], `K` = `k`).
pub(crate) fn affine_invariants(
    fd: &[Complex64],
    k: usize,
    afd0: &mut [f64],
    afd1: &mut [Complex64],
) -> Result<(), FdError> {
    let ki = k as isize;
    let c = |n: isize| fd[fd_index(n, k)];
    let u = |n: isize| {
        let (a, b) = (c(n), c(-n).conj());
        ((a + b) * 0.5, (a - b) * Complex64::new(0.0, -0.5))
    };
    let (x1, y1) = u(1);
    let delta = |n: isize| {
        let (xn, yn) = u(n);
        xn * y1.conj() - yn * x1.conj()
    };
    let d11 = delta(1);
    let mut total = 0.0;
    for n in -ki..=ki {
        if n != 0 {
            total += delta(n).norm();
        }
    }
    if d11.norm().partial_cmp(&(1e-12 * total)) != Some(std::cmp::Ordering::Greater) {
        return Err(FdError::DegenerateFirstHarmonic);
    }
    let theta = (delta(2) / d11).arg();
    let mut i = 0;
    for n in -ki..=ki {
        if n == 0 || n == 1 {
            continue;
        }
        let q = delta(n) / d11;
        afd0[i] = q.norm();
        afd1[i] = q * Complex64::from_polar(1.0, -((n - 1) as f64) * theta);
        i += 1;
    }
    let n0 = afd0.iter().map(|v| v * v).sum::<f64>().sqrt();
    let n1 = afd1.iter().map(|v| v.norm_sqr()).sum::<f64>().sqrt();
    // An ellipse has no harmonics beyond ±1: all ellipses are affine-equivalent and get the
    // zero vector.
    if n0 > 0.0 {
        afd0.iter_mut().for_each(|v| *v /= n0);
    }
    if n1 > 0.0 {
        afd1.iter_mut().for_each(|v| *v /= n1);
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::descriptor::fd_index;

    fn fd(k: usize, coeffs: &[(isize, Complex64)]) -> Vec<Complex64> {
        let mut v = vec![Complex64::new(0.0, 0.0); 2 * k];
        for &(n, c) in coeffs {
            v[fd_index(n, k)] = c;
        }
        v
    }

    #[test]
    fn degenerate_first_harmonic_is_an_error() {
        // C(1) = C(−1): the first harmonic is the line x = cos t, so Δ₁₁ = 0.
        let k = 3;
        let v = fd(
            k,
            &[
                (1, Complex64::new(0.5, 0.0)),
                (-1, Complex64::new(0.5, 0.0)),
                (2, Complex64::new(0.0, 0.3)),
            ],
        );
        let (mut a0, mut a1) = (
            vec![0.0; 2 * k - 1],
            vec![Complex64::new(0.0, 0.0); 2 * k - 1],
        );
        assert_eq!(
            affine_invariants(&v, k, &mut a0, &mut a1),
            Err(FdError::DegenerateFirstHarmonic)
        );
    }

    #[test]
    fn ellipses_map_to_the_zero_vector() {
        let k = 3;
        let v = fd(
            k,
            &[
                (1, Complex64::new(0.8, 0.1)),
                (-1, Complex64::new(0.2, -0.3)),
            ],
        );
        let (mut a0, mut a1) = (
            vec![1.0; 2 * k - 1],
            vec![Complex64::new(1.0, 0.0); 2 * k - 1],
        );
        affine_invariants(&v, k, &mut a0, &mut a1).unwrap();
        assert!(a0.iter().all(|&x| x == 0.0));
        assert!(a1.iter().all(|x| x.norm_sqr() == 0.0));
    }
}
