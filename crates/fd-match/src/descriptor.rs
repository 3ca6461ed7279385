//! Descriptor configuration and contiguous storage of many descriptors.

use rustfft::num_complex::Complex64;
use serde::{Deserialize, Serialize};

use crate::error::FdError;
use crate::sampling::Sampling;

/// Largest accepted [`DescriptorConfig::samples`] (`L`): 2²⁰. A larger value is an
/// [`FdError::InvalidParameter`] before anything is allocated (every extractor holds a few
/// buffers of `L` complex numbers).
pub const MAX_SAMPLES: usize = 1 << 20;

/// Largest accepted [`DescriptorConfig::dense_samples`] (`L₀`): 2²². Larger values are rejected
/// before anything is allocated (the affine sampler holds five buffers of `L₀` values).
pub const MAX_DENSE_SAMPLES: usize = 1 << 22;

/// How contours are turned into descriptors. Deserialising validates (the same checks as
/// [`DescriptorConfig::validate`]), so a configuration read from a file is never invalid.
///
/// ```
/// use fd_match::DescriptorConfig;
/// let ok = serde_json::to_string(&DescriptorConfig::default()).unwrap();
/// assert!(serde_json::from_str::<DescriptorConfig>(&ok).is_ok());
/// let huge = ok.replace("\"samples\":256", "\"samples\":1000000000000");
/// assert!(serde_json::from_str::<DescriptorConfig>(&huge).is_err());
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "RawConfig")]
pub struct DescriptorConfig {
    /// Resampling method (section 3 of Paper A).
    pub sampling: Sampling,
    /// `L`, the number of contour samples fed to the FFT (≥ `coefficients`).
    pub samples: usize,
    /// `N`, the number of lowest-frequency coefficients kept *including* the dropped DC term:
    /// odd, `n = −K..=K` with `K = (N − 1)/2`; `N − 1` coefficients are stored. Paper A: 51.
    pub coefficients: usize,
    /// σ of the Gaussian regularising the derivatives of the affine arc length, in the input's
    /// arc-length units (pixels); at least one dense sample spacing is used.
    pub smoothing: f64,
    /// `L₀`, the dense uniform resampling used to compute regularised derivatives for
    /// [`Sampling::AffineArcLength`] (≥ `samples`).
    pub dense_samples: usize,
}

/// The serialised form of [`DescriptorConfig`], validated on the way in.
#[derive(Deserialize)]
struct RawConfig {
    sampling: Sampling,
    samples: usize,
    coefficients: usize,
    smoothing: f64,
    dense_samples: usize,
}

impl TryFrom<RawConfig> for DescriptorConfig {
    type Error = FdError;

    fn try_from(r: RawConfig) -> Result<Self, FdError> {
        let c = DescriptorConfig {
            sampling: r.sampling,
            samples: r.samples,
            coefficients: r.coefficients,
            smoothing: r.smoothing,
            dense_samples: r.dense_samples,
        };
        c.validate()?;
        Ok(c)
    }
}

impl Default for DescriptorConfig {
    /// Paper A's setting with affine-arc-length sampling: `L = 256`, `N = 51`, `σ = 1`,
    /// `L₀ = 2048`.
    fn default() -> Self {
        DescriptorConfig {
            sampling: Sampling::AffineArcLength,
            samples: 256,
            coefficients: 51,
            smoothing: 1.0,
            dense_samples: 2048,
        }
    }
}

impl DescriptorConfig {
    /// The default configuration with the given sampling.
    pub fn with_sampling(sampling: Sampling) -> Self {
        DescriptorConfig {
            sampling,
            ..Self::default()
        }
    }

    /// `K`, the highest frequency kept (0 for an invalid `coefficients` of 0).
    pub fn max_frequency(&self) -> usize {
        self.coefficients.saturating_sub(1) / 2
    }

    /// Checks the configuration: `coefficients` odd and ≥ 5, `coefficients ≤ samples ≤`
    /// [`MAX_SAMPLES`], `samples ≤ dense_samples ≤` [`MAX_DENSE_SAMPLES`], `smoothing` finite
    /// and non-negative.
    pub fn validate(&self) -> Result<(), FdError> {
        let bad = |name, value: usize, reason| {
            Err(FdError::InvalidParameter {
                name,
                value: value as f64,
                reason,
            })
        };
        if self.coefficients < 5 || self.coefficients.is_multiple_of(2) {
            return bad(
                "coefficients",
                self.coefficients,
                "must be odd and at least 5 (n = −K..=K with K ≥ 2)",
            );
        }
        if self.samples < self.coefficients {
            return bad("samples", self.samples, "must be at least `coefficients`");
        }
        if self.samples > MAX_SAMPLES {
            return bad(
                "samples",
                self.samples,
                "must be at most MAX_SAMPLES = 2^20",
            );
        }
        if self.dense_samples > MAX_DENSE_SAMPLES {
            return bad(
                "dense_samples",
                self.dense_samples,
                "must be at most MAX_DENSE_SAMPLES = 2^22",
            );
        }
        if self.dense_samples < self.samples {
            return bad(
                "dense_samples",
                self.dense_samples,
                "must be at least `samples`",
            );
        }
        if !(self.smoothing.is_finite() && self.smoothing >= 0.0) {
            return Err(FdError::InvalidParameter {
                name: "smoothing",
                value: self.smoothing,
                reason: "must be finite and non-negative",
            });
        }
        Ok(())
    }
}

/// Position of frequency `n` (`n ≠ 0`, `|n| ≤ K`) in a stored FD: ascending `n`, DC omitted.
#[inline]
pub(crate) fn fd_index(n: isize, k: usize) -> usize {
    if n < 0 {
        (n + k as isize) as usize
    } else {
        (n + k as isize - 1) as usize
    }
}

/// Frequency `n` of the `i`-th stored FD coefficient (`i < 2K`): `−K, …, −1, 1, …, K`.
///
/// Errors: [`FdError::IndexOutOfRange`] for a position `i ≥ 2K`, where no coefficient is
/// stored (`len` is `2K`); [`FdError::InvalidParameter`] `k` for a `K` of
/// [`MAX_SAMPLES`] or more, which no descriptor has (`K < L ≤ MAX_SAMPLES`). Both used to
/// give a number: a frequency no descriptor stores, or, near `isize::MAX`, an overflow.
///
/// ```
/// use fd_match::{fd_frequency, FdError};
/// assert_eq!(fd_frequency(0, 25), Ok(-25));
/// assert_eq!(fd_frequency(25, 25), Ok(1));
/// assert_eq!(fd_frequency(50, 25), Err(FdError::IndexOutOfRange { index: 50, len: 50 }));
/// ```
pub fn fd_frequency(i: usize, k: usize) -> Result<isize, FdError> {
    check_layout(i, k, 2 * k.min(MAX_SAMPLES))?;
    Ok(fd_frequency_unchecked(i, k))
}

/// Frequency `k` of the `i`-th AFD entry (`i < 2K − 1`): `−K, …, −1, 2, …, K`. Errors as
/// [`fd_frequency`], for `i ≥ 2K − 1` (`len` is `2K − 1`, 0 for `K = 0`).
pub fn afd_frequency(i: usize, k: usize) -> Result<isize, FdError> {
    check_layout(i, k, (2 * k.min(MAX_SAMPLES)).saturating_sub(1))?;
    Ok(if i < k {
        i as isize - k as isize
    } else {
        i as isize - k as isize + 2
    })
}

/// The checks of [`fd_frequency`] and [`afd_frequency`]: `k` below [`MAX_SAMPLES`] and `i`
/// below `len` (the layout's length for that `k`).
fn check_layout(i: usize, k: usize, len: usize) -> Result<(), FdError> {
    if k >= MAX_SAMPLES {
        return Err(FdError::InvalidParameter {
            name: "k",
            value: k as f64,
            reason: "no descriptor has K >= MAX_SAMPLES frequencies",
        });
    }
    if i >= len {
        return Err(FdError::IndexOutOfRange { index: i, len });
    }
    Ok(())
}

/// [`fd_frequency`] for `i < 2K` and `K < MAX_SAMPLES`, known by the caller (the extractor's
/// and correlator's loops over `0..2K` of a validated configuration).
#[inline]
pub(crate) fn fd_frequency_unchecked(i: usize, k: usize) -> isize {
    if i < k {
        i as isize - k as isize
    } else {
        i as isize - k as isize + 1
    }
}

/// The descriptors of one contour (owned; see [`DescriptorSet`] for bulk storage).
#[derive(Debug, Clone, PartialEq)]
pub struct Descriptor {
    /// Normalised FD `C(n)`, `n = −K..=K` without 0, ‖C‖₂ = 1 (layout of [`fd_frequency`]).
    pub fd: Vec<Complex64>,
    /// AFD0 (unit norm, layout of [`afd_frequency`]).
    pub afd0: Vec<f64>,
    /// AFD1 (unit norm, layout of [`afd_frequency`]).
    pub afd1: Vec<Complex64>,
}

impl Descriptor {
    /// `|C(n)|`, the phase-free descriptor.
    pub fn magnitudes(&self) -> Vec<f64> {
        self.fd.iter().map(|c| c.norm()).collect()
    }
}

/// Many descriptors built with one [`DescriptorConfig`], stored contiguously (row `i` of each
/// table belongs to descriptor `i`), with the index of the contour each came from.
#[derive(Debug, Clone, PartialEq)]
pub struct DescriptorSet {
    config: DescriptorConfig,
    fd: Vec<Complex64>,
    mag: Vec<f64>,
    afd0: Vec<f64>,
    afd1: Vec<Complex64>,
    source: Vec<usize>,
}

impl DescriptorSet {
    /// An empty set for descriptors made with `config`.
    pub fn new(config: DescriptorConfig) -> Result<Self, FdError> {
        config.validate()?;
        Ok(DescriptorSet {
            config,
            fd: Vec::new(),
            mag: Vec::new(),
            afd0: Vec::new(),
            afd1: Vec::new(),
            source: Vec::new(),
        })
    }

    /// The configuration all descriptors were made with.
    pub fn config(&self) -> &DescriptorConfig {
        &self.config
    }

    /// Number of descriptors.
    pub fn len(&self) -> usize {
        self.source.len()
    }

    /// True if the set holds no descriptor.
    pub fn is_empty(&self) -> bool {
        self.source.is_empty()
    }

    /// Length of an FD (and magnitude) row: `N − 1`.
    pub fn fd_len(&self) -> usize {
        self.config.coefficients - 1
    }

    /// Length of an AFD row: `N − 2`.
    pub fn afd_len(&self) -> usize {
        self.config.coefficients - 2
    }

    /// The row of descriptor `i` in a table of rows of `width` values. Panics if
    /// `i >= len()`, with the index and the length, like slice indexing; never a wrapped
    /// product that would hand back another descriptor's row.
    fn row(&self, i: usize, width: usize) -> std::ops::Range<usize> {
        assert!(
            i < self.len(),
            "descriptor index {i} out of range for a set of {}",
            self.len()
        );
        i * width..(i + 1) * width
    }

    /// FD of descriptor `i`. Panics if `i >= len()`, like slice indexing ([`get`](Self::get)
    /// returns `None` instead).
    pub fn fd(&self, i: usize) -> &[Complex64] {
        &self.fd[self.row(i, self.fd_len())]
    }

    /// `|C(n)|` of descriptor `i`. Panics if `i >= len()`.
    pub fn magnitudes(&self, i: usize) -> &[f64] {
        &self.mag[self.row(i, self.fd_len())]
    }

    /// AFD0 of descriptor `i`. Panics if `i >= len()`.
    pub fn afd0(&self, i: usize) -> &[f64] {
        &self.afd0[self.row(i, self.afd_len())]
    }

    /// AFD1 of descriptor `i`. Panics if `i >= len()`.
    pub fn afd1(&self, i: usize) -> &[Complex64] {
        &self.afd1[self.row(i, self.afd_len())]
    }

    /// Caller-given index of the contour descriptor `i` was made from (its position in the
    /// input of [`crate::describe_all`]). Panics if `i >= len()`.
    pub fn source(&self, i: usize) -> usize {
        self.source[i]
    }

    /// All source indices, in descriptor order.
    pub fn sources(&self) -> &[usize] {
        &self.source
    }

    /// Descriptor `i` as an owned value.
    pub fn get(&self, i: usize) -> Option<Descriptor> {
        (i < self.len()).then(|| Descriptor {
            fd: self.fd(i).to_vec(),
            afd0: self.afd0(i).to_vec(),
            afd1: self.afd1(i).to_vec(),
        })
    }

    /// Appends a descriptor (e.g. one made by [`crate::Extractor::describe`]). The descriptor
    /// must be what the extractor makes: rows of the set's lengths, every value finite, and
    /// each of `fd`, `afd0`, `afd1` of unit norm (within [`UNIT_NORM_TOLERANCE`]); otherwise a
    /// typed error and the set is unchanged.
    pub fn push(&mut self, d: &Descriptor, source: usize) -> Result<(), FdError> {
        if d.fd.len() != self.fd_len()
            || d.afd0.len() != self.afd_len()
            || d.afd1.len() != self.afd_len()
        {
            return Err(FdError::IncompatibleSets {
                reason: "descriptor length differs from the set's configuration",
            });
        }
        check_unit(d.fd.iter().map(|c| [c.re, c.im]), "fd")?;
        check_unit(d.afd0.iter().map(|&v| [v, 0.0]), "afd0")?;
        check_unit(d.afd1.iter().map(|c| [c.re, c.im]), "afd1")?;
        self.fd.extend_from_slice(&d.fd);
        // As the extractor computes them (and `Correlator::correlate_below`).
        self.mag.extend(d.fd.iter().map(|c| c.norm_sqr().sqrt()));
        self.afd0.extend_from_slice(&d.afd0);
        self.afd1.extend_from_slice(&d.afd1);
        self.source.push(source);
        Ok(())
    }

    /// Appends room for one more descriptor and returns its rows for filling in place.
    pub(crate) fn push_slot(
        &mut self,
        source: usize,
    ) -> (&mut [Complex64], &mut [f64], &mut [f64], &mut [Complex64]) {
        let (d, a) = (self.fd_len(), self.afd_len());
        let z = Complex64::new(0.0, 0.0);
        let i = self.source.len();
        self.fd.resize((i + 1) * d, z);
        self.mag.resize((i + 1) * d, 0.0);
        self.afd0.resize((i + 1) * a, 0.0);
        self.afd1.resize((i + 1) * a, z);
        self.source.push(source);
        (
            &mut self.fd[i * d..],
            &mut self.mag[i * d..],
            &mut self.afd0[i * a..],
            &mut self.afd1[i * a..],
        )
    }

    /// Removes the last descriptor (used to roll back a failed in-place fill).
    pub(crate) fn pop(&mut self) {
        if self.source.pop().is_some() {
            let (d, a) = (self.fd_len(), self.afd_len());
            let i = self.source.len();
            self.fd.truncate(i * d);
            self.mag.truncate(i * d);
            self.afd0.truncate(i * a);
            self.afd1.truncate(i * a);
        }
    }

    /// Appends all descriptors of `other` (same configuration required).
    pub fn append(&mut self, other: &DescriptorSet) -> Result<(), FdError> {
        if other.config != self.config {
            return Err(FdError::IncompatibleSets {
                reason: "different descriptor configurations",
            });
        }
        self.fd.extend_from_slice(&other.fd);
        self.mag.extend_from_slice(&other.mag);
        self.afd0.extend_from_slice(&other.afd0);
        self.afd1.extend_from_slice(&other.afd1);
        self.source.extend_from_slice(&other.source);
        Ok(())
    }

    /// The subset of descriptors at `indices` (in that order), keeping their source indices;
    /// e.g. the survivors of [`crate::preselect`].
    pub fn select(&self, indices: &[usize]) -> Result<DescriptorSet, FdError> {
        let mut out = DescriptorSet::new(self.config)?;
        for &i in indices {
            if i >= self.len() {
                return Err(FdError::IndexOutOfRange {
                    index: i,
                    len: self.len(),
                });
            }
            out.fd.extend_from_slice(self.fd(i));
            out.mag.extend_from_slice(self.magnitudes(i));
            out.afd0.extend_from_slice(self.afd0(i));
            out.afd1.extend_from_slice(self.afd1(i));
            out.source.push(self.source[i]);
        }
        Ok(out)
    }
}

/// Largest accepted deviation of a pushed descriptor's norm from 1 (the extractor's are within
/// ~1e-15).
pub const UNIT_NORM_TOLERANCE: f64 = 1e-6;

/// Checks that the values are finite and of unit norm.
pub(crate) fn check_unit(
    values: impl Iterator<Item = [f64; 2]>,
    part: &'static str,
) -> Result<(), FdError> {
    let mut sq = 0.0;
    for (index, [re, im]) in values.enumerate() {
        if !(re.is_finite() && im.is_finite()) {
            return Err(FdError::NonFiniteDescriptor { part, index });
        }
        sq += re * re + im * im;
    }
    let norm = sq.sqrt();
    if (norm - 1.0).abs() > UNIT_NORM_TOLERANCE {
        return Err(FdError::NotUnitNorm { part, norm });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn index_and_frequency_layouts_are_inverse() {
        let k = 25;
        for i in 0..2 * k {
            assert_eq!(fd_index(fd_frequency(i, k).unwrap(), k), i);
        }
        assert_eq!(fd_frequency(0, k), Ok(-25));
        assert_eq!(fd_frequency(25, k), Ok(1));
        assert_eq!(afd_frequency(25, k), Ok(2));
        assert_eq!(afd_frequency(2 * k - 2, k), Ok(25));
    }

    #[test]
    fn config_validation() {
        assert!(DescriptorConfig::default().validate().is_ok());
        for bad in [
            DescriptorConfig {
                coefficients: 50,
                ..Default::default()
            },
            DescriptorConfig {
                coefficients: 3,
                ..Default::default()
            },
            DescriptorConfig {
                samples: 40,
                ..Default::default()
            },
            DescriptorConfig {
                dense_samples: 100,
                ..Default::default()
            },
            DescriptorConfig {
                smoothing: f64::NAN,
                ..Default::default()
            },
        ] {
            assert!(matches!(
                bad.validate(),
                Err(FdError::InvalidParameter { .. })
            ));
        }
    }
}
