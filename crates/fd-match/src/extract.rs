//! Descriptor extraction: validation, resampling, FFT (eq. 2), normalisation, AFDs.

use std::sync::Arc;

use rayon::prelude::*;
use rustfft::num_complex::Complex64;
use rustfft::{Fft, FftPlanner};

use crate::afd::affine_invariants;
use crate::contour::{load, scale_pow2};
use crate::descriptor::{Descriptor, DescriptorConfig, DescriptorSet};
use crate::error::FdError;
use crate::point::ContourPoint;
use crate::sampling::{Sampler, Sampling};

/// Turns contours into descriptors. Holds the FFT plans (made once) and every work buffer, so
/// describing a contour allocates nothing once the buffers have grown to the largest contour
/// seen. Cheap to clone (plans are shared); use one per thread.
#[derive(Clone)]
pub struct Extractor {
    config: DescriptorConfig,
    sampler: Sampler,
    poly: Vec<Complex64>,
    samples: Vec<Complex64>,
    spectrum: Vec<Complex64>,
    fft: Arc<dyn Fft<f64>>,
    scratch: Vec<Complex64>,
}

impl Extractor {
    /// An extractor for `config` (validated).
    pub fn new(config: DescriptorConfig) -> Result<Self, FdError> {
        config.validate()?;
        let mut planner = FftPlanner::new();
        let fft = planner.plan_fft_forward(config.samples);
        let z = Complex64::new(0.0, 0.0);
        Ok(Extractor {
            sampler: Sampler::new(&mut planner, config.dense_samples, config.smoothing),
            poly: Vec::new(),
            samples: vec![z; config.samples],
            spectrum: vec![z; config.samples],
            scratch: vec![z; fft.get_inplace_scratch_len()],
            fft,
            config,
        })
    }

    /// The configuration.
    pub fn config(&self) -> &DescriptorConfig {
        &self.config
    }

    /// Validates `contour` and resamples it to `L` points with the configured sampling; returns
    /// the samples `c(l)`, `l = 0..L` (eq. 1), in the input's coordinates (the canonical frame's
    /// for [`Sampling::Canonical`]). Useful for plotting the canonical frame.
    pub fn resample<P: ContourPoint>(&mut self, contour: &[P]) -> Result<&[Complex64], FdError> {
        let exponent = self.resample_scaled(contour)?;
        if self.config.sampling == Sampling::AffineArcLength {
            // The affine sampler works relative to the area centroid (the descriptors drop
            // `C(0)`); put its samples back in the input's coordinates.
            let c = self.sampler.affine_centroid();
            for s in self.samples.iter_mut() {
                *s += c;
            }
        }
        if exponent != 0 && self.config.sampling != Sampling::Canonical {
            for c in self.samples.iter_mut() {
                *c = Complex64::new(scale_pow2(c.re, -exponent), scale_pow2(c.im, -exponent));
            }
        }
        Ok(&self.samples)
    }

    /// Resamples into `self.samples`, scaled by `2^e` for the returned `e` (module `contour`,
    /// "Range"); the descriptors are scale invariant, so they use the scaled samples.
    fn resample_scaled<P: ContourPoint>(&mut self, contour: &[P]) -> Result<i32, FdError> {
        let exponent = load(contour, &mut self.poly)?;
        self.sampler.sample(
            &self.poly,
            exponent,
            self.config.sampling,
            &mut self.samples,
        );
        Ok(exponent)
    }

    /// Describes one contour (allocates the returned vectors; see [`Self::describe_into`]).
    ///
    /// ```
    /// use fd_match::{DescriptorConfig, Extractor, Sampling};
    /// let mut ex = Extractor::new(DescriptorConfig::with_sampling(Sampling::Canonical)).unwrap();
    /// let d = ex.describe(&[(0, 0), (8, 0), (8, 3), (0, 3)]).unwrap();
    /// assert_eq!(d.fd.len(), 50);
    /// let energy: f64 = d.fd.iter().map(|c| c.norm_sqr()).sum();
    /// assert!((energy - 1.0).abs() < 1e-12);
    /// ```
    pub fn describe<P: ContourPoint>(&mut self, contour: &[P]) -> Result<Descriptor, FdError> {
        let mut set = DescriptorSet::new(self.config)?;
        self.describe_into(contour, &mut set, 0)?;
        Ok(set.get(0).expect("one descriptor was added"))
    }

    /// Describes one contour and appends it to `set` (same configuration required) with the
    /// given source index. On error `set` is unchanged.
    pub fn describe_into<P: ContourPoint>(
        &mut self,
        contour: &[P],
        set: &mut DescriptorSet,
        source: usize,
    ) -> Result<(), FdError> {
        if set.config() != &self.config {
            return Err(FdError::IncompatibleSets {
                reason: "the set was made with another configuration",
            });
        }
        self.resample_scaled(contour)?;
        self.spectrum.copy_from_slice(&self.samples);
        self.fft
            .process_with_scratch(&mut self.spectrum, &mut self.scratch);
        let k = self.config.max_frequency();
        let l = self.config.samples;
        let (fd, mag, afd0, afd1) = set.push_slot(source);
        // C(n) = S[n mod L] / L (eq. 2); the 1/L cancels in the normalisation.
        for (i, c) in fd.iter_mut().take(2 * k).enumerate() {
            let n = crate::descriptor::fd_frequency_unchecked(i, k);
            *c = self.spectrum[n.rem_euclid(l as isize) as usize];
        }
        let fd = &mut fd[..2 * k];
        let energy = fd.iter().map(|c| c.norm_sqr()).sum::<f64>().sqrt();
        // energy > 0: a polygon with positive area has a non-constant resampling.
        for (c, m) in fd.iter_mut().zip(mag.iter_mut()) {
            *c /= energy;
            *m = c.norm_sqr().sqrt();
        }
        let fd: &[Complex64] = fd;
        if let Err(e) = affine_invariants(fd, k, &mut afd0[..2 * k - 1], &mut afd1[..2 * k - 1]) {
            set.pop();
            return Err(e);
        }
        Ok(())
    }
}

/// The descriptors of many contours, and the contours that could not be described.
#[derive(Debug, Clone)]
pub struct Described {
    /// Descriptors of the accepted contours, in input order; `set.source(i)` is the input index.
    pub set: DescriptorSet,
    /// Input index and reason of every rejected contour (degenerate or invalid), in input order.
    pub rejected: Vec<(usize, FdError)>,
}

/// Describes many contours in parallel (rayon). Output order and values do not depend on the
/// number of threads. Fails only on an invalid configuration; bad contours are listed in
/// [`Described::rejected`].
///
/// ```
/// use fd_match::{describe_all, DescriptorConfig};
/// let contours = vec![
///     vec![(0, 0), (6, 0), (6, 4), (0, 4)],
///     vec![(0, 0), (1, 1), (2, 2)], // collinear: rejected
/// ];
/// let out = describe_all(DescriptorConfig::default(), &contours).unwrap();
/// assert_eq!(out.set.len(), 1);
/// assert_eq!(out.rejected[0].0, 1);
/// ```
pub fn describe_all<P, C>(config: DescriptorConfig, contours: &[C]) -> Result<Described, FdError>
where
    P: ContourPoint + Sync,
    C: AsRef<[P]> + Sync,
{
    const CHUNK: usize = 32;
    let proto = Extractor::new(config)?;
    let parts: Vec<(DescriptorSet, Vec<(usize, FdError)>)> = contours
        .par_chunks(CHUNK)
        .enumerate()
        .map(|(ci, chunk)| {
            let mut ex = proto.clone();
            let mut set = DescriptorSet::new(config).expect("validated above");
            let mut rejected = Vec::new();
            for (j, c) in chunk.iter().enumerate() {
                let src = ci * CHUNK + j;
                if let Err(e) = ex.describe_into(c.as_ref(), &mut set, src) {
                    rejected.push((src, e));
                }
            }
            (set, rejected)
        })
        .collect();
    let mut set = DescriptorSet::new(config)?;
    let mut rejected = Vec::new();
    for (s, r) in parts {
        set.append(&s)?;
        rejected.extend(r);
    }
    Ok(Described { set, rejected })
}
