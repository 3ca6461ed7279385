//! The learned tip ([`TipRule::Learned`](crate::TipRule::Learned)): the far end, corrected by
//! an offset learned from the end-face rule over random poses.
//!
//! The two measured tips fail in opposite ways. The far end (`FarEnd`) changes smoothly with
//! the pose but lies off the end face's centre by an offset that depends on the pose (ahead by
//! up to the face's projected depth, sideways where the cap is oblique). The end-face tip
//! (`EndFace`) finds that centre, but jumps by 1–2.5 px between nearby poses where single
//! outline pixels of the cap come and go. The learned rule takes the smooth one and learns its
//! offset from the accurate one:
//! 1. **Samples** (action precedes perception): at random poses, every camera's far end `f_c`
//!    and end-face tip `e_c`. The descriptor `z = (f_0, f_1, …)` (all cameras' far ends, which
//!    together fix the arm's pose), the target the offsets `o_c = e_c − f_c`. A sample is kept
//!    when every camera's offset lies within its end window (`0.6 L_c`, where the end-face rule
//!    looks for the face).
//! 2. **Regression**: `ô(z)` is the Nadaraya–Watson estimate with a Gaussian kernel of bandwidth
//!    `h`, `ô(z) = Σ wᵢ oᵢ / Σ wᵢ`, `wᵢ = exp(−|z − zᵢ|² / 2h²)`: a weighted mean of the offsets at
//!    nearby poses, smooth in `z`, in which the end-face jumps average out. `h` is the value of a
//!    fixed grid with the smallest leave-one-out mean squared error on the samples themselves.
//! 3. **Tip**: `p_c = f_c + ô_c(z)`, then moved towards the end-face tip by at most `r` = 0.5 px:
//!    `t_c = p_c + min(1, r / |e_c − p_c|) (e_c − p_c)` (`t_c = p_c` where the outline shows no
//!    end face). Where the two agree to half a pixel the end face's detail passes through; a jump
//!    of the end face moves the tip by at most `r`.
//!
//! `r` was chosen on one development seed of `arm-sim` (0.5 px against 1 px, Huber-type clipping
//! against a Gaussian taper; `docs/performance.md` at f7d00c4, sixth round), never on the
//! evaluation's.

use serde::{Deserialize, Serialize};

use crate::error::{Result, ServoError, check_finite};

/// Bandwidths (pixels of the descriptor) the leave-one-out choice considers.
const BANDWIDTHS: [f64; 8] = [4.0, 6.0, 8.0, 12.0, 16.0, 24.0, 32.0, 48.0];
/// Largest move from the corrected far end towards the end-face tip (pixels).
const CLIP_PX: f64 = 0.5;
/// Fewest kept samples a correction is learned from.
const MIN_SAMPLES: usize = 20;

/// One training pose: every camera's far end and end-face tip (`None` where the outline showed
/// no end face).
#[derive(Debug, Clone, PartialEq)]
pub struct CorrectionSample {
    /// Per camera, the far-end tip (pixels).
    pub far_ends: Vec<[f64; 2]>,
    /// Per camera, the end-face tip (pixels).
    pub end_faces: Vec<Option<[f64; 2]>>,
}

/// What learning the correction found.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct CorrectionReport {
    /// Poses offered.
    pub poses: usize,
    /// Poses kept (an end face in every camera, within the end windows).
    pub samples: usize,
    /// The chosen kernel bandwidth (pixels).
    pub bandwidth: f64,
    /// Its leave-one-out root-mean-square error of the offsets (pixels, over cameras).
    pub loo_rms_px: f64,
}

/// The learned far-end correction (module docs).
///
/// ```
/// use servo_loop::{CorrectionSample, TipCorrection};
///
/// // One camera whose end face lies 2 px to the left of the far end, at 100 poses.
/// let samples: Vec<CorrectionSample> = (0..100)
///     .map(|k| {
///         let f = [100.0 + 3.0 * (k % 10) as f64, 80.0 + 3.0 * (k / 10) as f64];
///         CorrectionSample {
///             far_ends: vec![f],
///             end_faces: vec![Some([f[0] - 2.0, f[1]])],
///         }
///     })
///     .collect();
/// let (correction, report) = TipCorrection::learn(&samples, &[10.0]).unwrap();
/// assert_eq!(report.samples, 100);
/// // In a new image without a usable end face, the far end moves by the learned offset.
/// let tip = correction.tips(&[[112.5, 91.0]], &[None]).unwrap();
/// assert!((tip[0][0] - 110.5).abs() < 1e-6 && (tip[0][1] - 91.0).abs() < 1e-6);
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TipCorrection {
    cameras: usize,
    /// Per sample, the `2 · cameras` descriptor values (row-major).
    descriptors: Vec<f64>,
    /// Per sample, the `2 · cameras` offsets (row-major).
    offsets: Vec<f64>,
    bandwidth: f64,
}

impl TipCorrection {
    /// Learns the correction from `samples`, keeping those whose every offset is within
    /// `windows[c]` pixels (and whose tips are finite). Errors: a window that is not finite and
    /// positive, camera counts that differ from `windows`, fewer than 20 kept samples.
    pub fn learn(
        samples: &[CorrectionSample],
        windows: &[f64],
    ) -> Result<(TipCorrection, CorrectionReport)> {
        if windows.iter().any(|w| !(w.is_finite() && *w > 0.0)) {
            return Err(ServoError::invalid(
                "windows",
                "every end window must be finite and positive",
            ));
        }
        let cameras = windows.len();
        let dim = 2 * cameras;
        let mut descriptors = Vec::new();
        let mut offsets = Vec::new();
        for s in samples {
            if s.far_ends.len() != cameras || s.end_faces.len() != cameras {
                return Err(ServoError::DimensionMismatch {
                    what: "correction sample cameras",
                    expected: cameras,
                    got: s.far_ends.len().min(s.end_faces.len()),
                });
            }
            let mut o = Vec::with_capacity(dim);
            for ((f, e), &win) in s.far_ends.iter().zip(&s.end_faces).zip(windows) {
                let Some(e) = e else { break };
                let (dx, dy) = (e[0] - f[0], e[1] - f[1]);
                let r = dx.hypot(dy);
                if r.is_nan() || r > win {
                    break;
                }
                o.extend([dx, dy]);
            }
            let finite = s.far_ends.iter().flatten().all(|v| v.is_finite());
            if o.len() == dim && finite {
                descriptors.extend(s.far_ends.iter().flatten());
                offsets.extend(o);
            }
        }
        let kept = offsets.len().checked_div(dim).unwrap_or(0);
        if kept < MIN_SAMPLES {
            return Err(ServoError::NotEnoughData(format!(
                "{kept} of {} poses showed an end face in every camera; the tip correction \
                 needs {MIN_SAMPLES}",
                samples.len()
            )));
        }
        let mut model = TipCorrection {
            cameras,
            descriptors,
            offsets,
            bandwidth: BANDWIDTHS[0],
        };
        let mut best = (f64::INFINITY, BANDWIDTHS[0]);
        for h in BANDWIDTHS {
            model.bandwidth = h;
            let mse = model.leave_one_out_mse();
            if mse < best.0 {
                best = (mse, h);
            }
        }
        model.bandwidth = best.1;
        let report = CorrectionReport {
            poses: samples.len(),
            samples: kept,
            bandwidth: best.1,
            // Mean squared error per offset component, two components per camera.
            loo_rms_px: (2.0 * best.0).sqrt(),
        };
        Ok((model, report))
    }

    /// Number of cameras.
    pub fn num_cameras(&self) -> usize {
        self.cameras
    }

    /// The kernel bandwidth (pixels).
    pub fn bandwidth(&self) -> f64 {
        self.bandwidth
    }

    /// The learned tips from every camera's far end and end-face tip (module docs, step 3; a
    /// non-finite end-face tip counts as none). Errors: camera counts other than the learned
    /// one, non-finite far ends, an inconsistent model (e.g. one read from an edited file).
    pub fn tips(
        &self,
        far_ends: &[[f64; 2]],
        end_faces: &[Option<[f64; 2]>],
    ) -> Result<Vec<[f64; 2]>> {
        self.check()?;
        let flat: Vec<f64> = far_ends.iter().flatten().copied().collect();
        check_finite("far ends", &flat)?;
        if far_ends.len() != self.cameras || end_faces.len() != self.cameras {
            return Err(ServoError::DimensionMismatch {
                what: "camera tips",
                expected: self.cameras,
                got: far_ends.len().min(end_faces.len()),
            });
        }
        let z: Vec<f64> = far_ends.iter().flatten().copied().collect();
        let o = self.offsets_at(&z, None);
        Ok(far_ends
            .iter()
            .zip(end_faces)
            .enumerate()
            .map(|(c, (f, e))| {
                let p = [f[0] + o[2 * c], f[1] + o[2 * c + 1]];
                let Some(e) = e.filter(|e| e[0].is_finite() && e[1].is_finite()) else {
                    return p;
                };
                let (rx, ry) = (e[0] - p[0], e[1] - p[1]);
                let r = rx.hypot(ry);
                let g = if r > CLIP_PX { CLIP_PX / r } else { 1.0 };
                [p[0] + g * rx, p[1] + g * ry]
            })
            .collect())
    }

    /// A model fit to use: cameras, matching finite sample arrays, a positive bandwidth (a
    /// learned one always is; a deserialised one may not be).
    fn check(&self) -> Result<()> {
        let consistent = self.cameras.checked_mul(2).is_some_and(|dim| {
            dim > 0
                && !self.offsets.is_empty()
                && self.descriptors.len() == self.offsets.len()
                && self.offsets.len().is_multiple_of(dim)
        }) && self.bandwidth.is_finite()
            && self.bandwidth > 0.0
            && self
                .descriptors
                .iter()
                .chain(&self.offsets)
                .all(|v| v.is_finite());
        if consistent {
            Ok(())
        } else {
            Err(ServoError::invalid(
                "correction",
                "inconsistent sample arrays or bandwidth",
            ))
        }
    }

    /// The Nadaraya–Watson offsets at descriptor `z`, leaving out sample `skip`. The weights
    /// are taken relative to the nearest sample's, which cancels in the ratio and keeps them
    /// from underflowing far from every sample.
    fn offsets_at(&self, z: &[f64], skip: Option<usize>) -> Vec<f64> {
        let dim = 2 * self.cameras;
        let d2: Vec<f64> = self
            .descriptors
            .chunks_exact(dim)
            .map(|zi| zi.iter().zip(z).map(|(a, b)| (a - b) * (a - b)).sum())
            .collect();
        let nearest = d2
            .iter()
            .enumerate()
            .filter(|&(i, _)| Some(i) != skip)
            .map(|(_, &d)| d)
            .fold(f64::INFINITY, f64::min);
        let inv = 0.5 / (self.bandwidth * self.bandwidth);
        let mut sum = vec![0.0; dim];
        let mut total = 0.0;
        for (i, (&d, o)) in d2.iter().zip(self.offsets.chunks_exact(dim)).enumerate() {
            if Some(i) == skip {
                continue;
            }
            let w = (-(d - nearest) * inv).exp();
            total += w;
            for (s, v) in sum.iter_mut().zip(o) {
                *s += w * v;
            }
        }
        if total > 0.0 {
            sum.iter_mut().for_each(|s| *s /= total);
        }
        sum
    }

    /// Mean over samples and offset components of the squared leave-one-out error.
    fn leave_one_out_mse(&self) -> f64 {
        let dim = 2 * self.cameras;
        let n = self.offsets.len() / dim;
        let mut sq = 0.0;
        for i in 0..n {
            let z = &self.descriptors[i * dim..(i + 1) * dim];
            let o = self.offsets_at(z, Some(i));
            sq += o
                .iter()
                .zip(&self.offsets[i * dim..(i + 1) * dim])
                .map(|(a, b)| (a - b) * (a - b))
                .sum::<f64>();
        }
        sq / (n * dim) as f64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A two-camera pose grid whose offsets are a smooth function of the far ends, with the
    /// end-face tips disturbed on every other pose by jumps of alternately +1.5 and −1.5 px.
    fn samples(jumps: bool) -> Vec<CorrectionSample> {
        let mut out = Vec::new();
        for i in 0..20 {
            for j in 0..20 {
                let (u, v) = (100.0 + 10.0 * i as f64, 80.0 + 8.0 * j as f64);
                let f0 = [u, v];
                let f1 = [0.7 * u + 0.2 * v, 0.5 * v - 0.1 * u + 200.0];
                let off = |p: [f64; 2]| [2.0 * (p[0] / 60.0).sin(), 1.5 * (p[1] / 50.0).cos()];
                // Every other pose jumps, alternately by +1.5 and -1.5 px.
                let jump = match (jumps, (i + j) % 4) {
                    (true, 0) => 1.5,
                    (true, 2) => -1.5,
                    _ => 0.0,
                };
                let (o0, o1) = (off(f0), off(f1));
                out.push(CorrectionSample {
                    far_ends: vec![f0, f1],
                    end_faces: vec![
                        Some([f0[0] + o0[0] + jump, f0[1] + o0[1]]),
                        Some([f1[0] + o1[0], f1[1] + o1[1] - jump]),
                    ],
                });
            }
        }
        out
    }

    /// On exact end-face tips the learned tip reproduces them (the correction interpolates a
    /// smooth offset to a small fraction of a pixel, the clip passes the rest).
    #[test]
    fn a_smooth_offset_is_learned_and_reproduced() {
        let train = samples(false);
        let (model, report) = TipCorrection::learn(&train, &[10.0, 10.0]).expect("learned");
        assert_eq!(report.samples, 400);
        assert!(report.loo_rms_px < 0.3, "{report:?}");
        // A pose between the grid points.
        let f0 = [155.0, 124.0];
        let f1 = [0.7 * 155.0 + 0.2 * 124.0, 0.5 * 124.0 - 15.5 + 200.0];
        let truth = |p: [f64; 2]| [2.0 * (p[0] / 60.0).sin(), 1.5 * (p[1] / 50.0).cos()];
        let tips = model.tips(&[f0, f1], &[None, None]).expect("two cameras");
        for (t, f) in tips.iter().zip([f0, f1]) {
            let o = truth(f);
            let err = (t[0] - f[0] - o[0]).hypot(t[1] - f[1] - o[1]);
            assert!(err < 0.3, "correction off by {err} px");
        }
    }

    /// Jumps of the end-face tip average out of the correction, and a jump in a new image moves
    /// the tip by at most the clip radius.
    #[test]
    fn end_face_jumps_are_averaged_out_and_clipped() {
        let (model, _) = TipCorrection::learn(&samples(true), &[10.0, 10.0]).expect("learned");
        let (clean, _) = TipCorrection::learn(&samples(false), &[10.0, 10.0]).expect("learned");
        let f = [[155.0, 124.0], [133.3, 246.5]];
        let a = model.tips(&f, &[None, None]).expect("tips");
        let b = clean.tips(&f, &[None, None]).expect("tips");
        for (p, q) in a.iter().zip(&b) {
            assert!((p[0] - q[0]).hypot(p[1] - q[1]) < 0.25, "{p:?} vs {q:?}");
        }
        let far_face = [
            Some([a[0][0] + 3.0, a[0][1]]),
            Some([a[1][0], a[1][1] + 0.2]),
        ];
        let t = model.tips(&f, &far_face).expect("tips");
        assert!((t[0][0] - a[0][0] - CLIP_PX).abs() < 1e-12 && t[0][1] == a[0][1]);
        assert!(
            (t[1][1] - a[1][1] - 0.2).abs() < 1e-12,
            "within the clip it passes"
        );
    }

    #[test]
    fn too_few_samples_and_wrong_camera_counts_are_typed_errors() {
        let train = samples(false);
        assert!(matches!(
            TipCorrection::learn(&train[..10], &[10.0, 10.0]),
            Err(ServoError::NotEnoughData(_))
        ));
        // Offsets beyond the windows are dropped, so nothing is kept.
        assert!(matches!(
            TipCorrection::learn(&train, &[0.1, 0.1]),
            Err(ServoError::NotEnoughData(_))
        ));
        assert!(matches!(
            TipCorrection::learn(&train, &[10.0]),
            Err(ServoError::DimensionMismatch { .. })
        ));
        let (model, _) = TipCorrection::learn(&train, &[10.0, 10.0]).expect("learned");
        assert!(matches!(
            model.tips(&[[1.0, 2.0]], &[None]),
            Err(ServoError::DimensionMismatch { .. })
        ));
        // Non-finite input: a typed error for windows and far ends; a NaN end face is none.
        assert!(matches!(
            TipCorrection::learn(&train, &[10.0, f64::NAN]),
            Err(ServoError::InvalidParameter {
                name: "windows",
                ..
            })
        ));
        let f = [[155.0, 124.0], [133.3, 246.5]];
        assert!(matches!(
            model.tips(&[[f64::NAN, 1.0], f[1]], &[None, None]),
            Err(ServoError::NonFinite {
                what: "far ends",
                ..
            })
        ));
        assert_eq!(
            model.tips(&f, &[Some([f64::NAN, 0.0]), None]).unwrap(),
            model.tips(&f, &[None, None]).unwrap()
        );
        let broken = TipCorrection {
            offsets: model.offsets[1..].to_vec(),
            ..model.clone()
        };
        assert!(matches!(
            broken.tips(&[[1.0, 2.0], [3.0, 4.0]], &[None, None]),
            Err(ServoError::InvalidParameter {
                name: "correction",
                ..
            })
        ));
    }
}
