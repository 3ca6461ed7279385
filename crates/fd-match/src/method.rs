//! The matching methods of Paper A and their pair errors.

use rustfft::num_complex::Complex64;
use serde::{Deserialize, Serialize};

use crate::correlation::{Alignment, Correlator};
use crate::descriptor::DescriptorSet;
use crate::error::FdError;
use crate::sampling::Sampling;

/// A descriptor and the error used to compare two of them. All errors are in `[0, 4]` for
/// unit-norm descriptors, 0 for a perfect match.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum Method {
    /// "FD Corr": FDs with phase, matched by correlation over rotation and start-point shift,
    /// `e = 2 − 2 max_l |r₁₂(l)|` (eq. 10). The paper's method; reports an [`Alignment`].
    FdCorr,
    /// "abs(FD) SSD": SSD of the magnitudes, `Σ (|C₁(n)| − |C₂(n)|)²` (phase neglected).
    AbsFdSsd,
    /// "AFD0 SSD": SSD of the order-0 affine-invariant descriptors.
    Afd0Ssd,
    /// "AFD1 SSD": SSD of the order-1 affine-invariant descriptors.
    Afd1Ssd,
    /// Plain SSD of the complex FDs, `Σ |C₁(n) − C₂(n)|²` (no rotation or shift compensation;
    /// a reference, meaningful only with a consistent start point and orientation).
    FdSsd,
}

impl Method {
    /// The four methods compared in Paper A (Fig. 4–6).
    pub const PAPER: [Method; 4] = [
        Method::FdCorr,
        Method::AbsFdSsd,
        Method::Afd0Ssd,
        Method::Afd1Ssd,
    ];

    /// Name as in the paper's legends, e.g. `FD Corr`.
    pub fn name(self) -> &'static str {
        match self {
            Method::FdCorr => "FD Corr",
            Method::AbsFdSsd => "abs(FD) SSD",
            Method::Afd0Ssd => "AFD0 SSD",
            Method::Afd1Ssd => "AFD1 SSD",
            Method::FdSsd => "FD SSD",
        }
    }

    /// Legend label with the sampling, e.g. `FD Corr/Canonical`.
    pub fn label(self, sampling: Sampling) -> String {
        format!("{}/{}", self.name(), sampling.name())
    }

    /// Whether pair errors come with a rotation and shift ([`Method::FdCorr`] only).
    pub fn aligns(self) -> bool {
        self == Method::FdCorr
    }

    /// The preselection threshold `T_err` (eq. 18) Paper A reports for this combination
    /// (section 5.2), if any: AFD0 SSD/Affine 1e-4, AFD1 SSD/Affine 5e-4, FD Corr 1e-3 (both
    /// samplings).
    pub fn paper_preselection_threshold(self, sampling: Sampling) -> Option<f64> {
        match (self, sampling) {
            (Method::Afd0Ssd, Sampling::AffineArcLength) => Some(1e-4),
            (Method::Afd1Ssd, Sampling::AffineArcLength) => Some(5e-4),
            (Method::FdCorr, Sampling::AffineArcLength | Sampling::Canonical) => Some(1e-3),
            _ => None,
        }
    }
}

/// Sum of squared differences of complex vectors; [`FdError::LengthMismatch`] when the lengths
/// differ.
pub fn ssd_complex(a: &[Complex64], b: &[Complex64]) -> Result<f64, FdError> {
    same_len(a.len(), b.len())?;
    Ok(ssd_complex_unchecked(a, b))
}

/// Sum of squared differences of real vectors; [`FdError::LengthMismatch`] when the lengths
/// differ.
///
/// ```
/// assert_eq!(fd_match::ssd_real(&[1.0, 2.0], &[1.0, 4.0]), Ok(4.0));
/// assert!(fd_match::ssd_real(&[1.0, 2.0, 3.0], &[1.0]).is_err());
/// ```
pub fn ssd_real(a: &[f64], b: &[f64]) -> Result<f64, FdError> {
    same_len(a.len(), b.len())?;
    Ok(ssd_real_unchecked(a, b))
}

fn same_len(left: usize, right: usize) -> Result<(), FdError> {
    if left != right {
        return Err(FdError::LengthMismatch {
            left,
            right,
            expected: left,
        });
    }
    Ok(())
}

/// [`ssd_complex`] for rows of one set (equal lengths by construction).
#[inline]
fn ssd_complex_unchecked(a: &[Complex64], b: &[Complex64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| (x - y).norm_sqr()).sum()
}

/// [`ssd_real`] for rows of one set (equal lengths by construction).
#[inline]
fn ssd_real_unchecked(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum()
}

/// Evaluates the error of one pair for a method; owns a [`Correlator`] for [`Method::FdCorr`].
#[derive(Clone)]
pub(crate) struct PairError {
    method: Method,
    corr: Correlator,
}

impl PairError {
    pub(crate) fn new(method: Method, set: &DescriptorSet) -> Self {
        let c = set.config();
        PairError {
            method,
            corr: Correlator::new(c.max_frequency(), c.samples)
                .expect("a validated configuration has 2 <= K < L <= MAX_SAMPLES"),
        }
    }

    /// Error between descriptor `i` of `a` and `j` of `b` (same configuration), or `None` if
    /// it provably exceeds `max_error` (FD Corr only; the SSDs are always returned).
    #[inline]
    pub(crate) fn eval_below(
        &mut self,
        a: &DescriptorSet,
        i: usize,
        b: &DescriptorSet,
        j: usize,
        max_error: f64,
    ) -> Option<(f64, Option<Alignment>)> {
        Some(match self.method {
            Method::FdCorr => {
                let c = self.corr.correlate_known(
                    a.fd(i),
                    b.fd(j),
                    a.magnitudes(i),
                    b.magnitudes(j),
                    max_error,
                )?;
                (c.error, Some(c.alignment))
            }
            Method::AbsFdSsd => (ssd_real_unchecked(a.magnitudes(i), b.magnitudes(j)), None),
            Method::Afd0Ssd => (ssd_real_unchecked(a.afd0(i), b.afd0(j)), None),
            Method::Afd1Ssd => (ssd_complex_unchecked(a.afd1(i), b.afd1(j)), None),
            Method::FdSsd => (ssd_complex_unchecked(a.fd(i), b.fd(j)), None),
        })
    }

    /// Error between descriptor `i` of `a` and `j` of `b` (same configuration).
    #[inline]
    pub(crate) fn eval(
        &mut self,
        a: &DescriptorSet,
        i: usize,
        b: &DescriptorSet,
        j: usize,
    ) -> (f64, Option<Alignment>) {
        self.eval_below(a, i, b, j, f64::INFINITY)
            .expect("every error is below infinity")
    }
}
