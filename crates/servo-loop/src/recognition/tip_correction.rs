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
//!
//! **The correction's own certainty** ([`TipCorrection::tips_gated`]). The offsets are not a
//! smooth function everywhere: where the far end changes feature between nearby poses, the
//! neighbouring samples' offsets disagree by pixels and their weighted mean is off. The same
//! kernel weights give the local **spread** `σ_c(z)`, the weighted RMS distance of the
//! neighbours' offsets of camera `c` from their mean: on `arm-sim`'s development seeds
//! 1001–1005 (three arms, 600 test captures), of the learned tips whose spread exceeded 2 px
//! (with an end face) 73 of 172 were more than 2 px off, against 10 of 633 below it. The gated
//! rule lets the tip move towards the end-face tip by `r_c = max(r, k σ_c)` instead of `r`:
//! where the correction is sure it stays the smooth learned tip, where it is not the
//! end face (accurate, but jumping by 1–2.5 px) takes over, continuously in `σ_c`, which is
//! smooth in the pose (no switch between candidates; `k` =
//! [`SilhouetteConfig::face_gate`](crate::SilhouetteConfig::face_gate)). Where a camera shows no
//! end face, the spread caps that camera's certainty
//! ([`SilhouetteConfig::spread_scale`](crate::SilhouetteConfig::spread_scale)), for the percepts
//! the servo acts on and, unless [`SilhouetteConfig::cap_training`](crate::SilhouetteConfig::cap_training)
//! is off, training moves too. An opt-in in the library (both 0 by default); `eval servo` uses
//! it with the cap on servo percepts only: measured in docs/methods.md, *Gated learned tip*.

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

/// A learned tip and the correction's local spread there ([`TipCorrection::tips_gated`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CorrectedTip {
    /// The tip (pixels).
    pub position: [f64; 2],
    /// The kernel-weighted RMS distance of the neighbouring samples' offsets of this camera
    /// from their weighted mean (pixels): how much the correction can be trusted here.
    pub spread: f64,
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
///
/// Deserialising applies the same consistency check as every use ([`TipCorrection::tips`]'s
/// "inconsistent model" error): a file that fails it is an error when it is read.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "TipCorrectionFile")]
pub struct TipCorrection {
    cameras: usize,
    /// Per sample, the `2 · cameras` descriptor values (row-major).
    descriptors: Vec<f64>,
    /// Per sample, the `2 · cameras` offsets (row-major).
    offsets: Vec<f64>,
    bandwidth: f64,
}

/// The serialised form of a [`TipCorrection`], checked on deserialisation.
#[derive(Deserialize)]
struct TipCorrectionFile {
    cameras: usize,
    descriptors: Vec<f64>,
    offsets: Vec<f64>,
    bandwidth: f64,
}

impl TryFrom<TipCorrectionFile> for TipCorrection {
    type Error = ServoError;

    fn try_from(f: TipCorrectionFile) -> Result<Self> {
        let c = TipCorrection {
            cameras: f.cameras,
            descriptors: f.descriptors,
            offsets: f.offsets,
            bandwidth: f.bandwidth,
        };
        c.check()?;
        Ok(c)
    }
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
    /// one, non-finite far ends, an inconsistent model (deserialising refuses one already).
    pub fn tips(
        &self,
        far_ends: &[[f64; 2]],
        end_faces: &[Option<[f64; 2]>],
    ) -> Result<Vec<[f64; 2]>> {
        Ok(self
            .tips_gated(far_ends, end_faces, 0.0)?
            .into_iter()
            .map(|t| t.position)
            .collect())
    }

    /// As [`TipCorrection::tips`], but each camera's tip moves towards its end-face tip by at
    /// most `max(0.5 px, gate · σ_c)` for the correction's local spread `σ_c` (module docs,
    /// *the correction's own certainty*), and every tip carries that spread. `gate = 0` is
    /// [`TipCorrection::tips`]. Errors: as [`TipCorrection::tips`]; a `gate` that is not finite
    /// and non-negative.
    pub fn tips_gated(
        &self,
        far_ends: &[[f64; 2]],
        end_faces: &[Option<[f64; 2]>],
        gate: f64,
    ) -> Result<Vec<CorrectedTip>> {
        if !(gate.is_finite() && gate >= 0.0) {
            return Err(ServoError::invalid(
                "face_gate",
                "must be finite and non-negative",
            ));
        }
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
        let (o, spread) = self.offsets_and_spread(&z);
        Ok(far_ends
            .iter()
            .zip(end_faces)
            .enumerate()
            .map(|(c, (f, e))| {
                let p = [f[0] + o[2 * c], f[1] + o[2 * c + 1]];
                let spread = spread[c];
                let Some(e) = e.filter(|e| e[0].is_finite() && e[1].is_finite()) else {
                    return CorrectedTip {
                        position: p,
                        spread,
                    };
                };
                let clip = CLIP_PX.max(gate * spread);
                let (rx, ry) = (e[0] - p[0], e[1] - p[1]);
                let r = rx.hypot(ry);
                let g = if r > clip { clip / r } else { 1.0 };
                CorrectedTip {
                    position: [p[0] + g * rx, p[1] + g * ry],
                    spread,
                }
            })
            .collect())
    }

    /// A model fit to use: cameras, matching finite sample arrays, a positive bandwidth (a
    /// learned one always is; a deserialised one is checked as it is read).
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

    /// The Nadaraya–Watson offsets at descriptor `z` and, per camera, the weighted RMS
    /// distance of the samples' offsets from them (the same weights).
    fn offsets_and_spread(&self, z: &[f64]) -> (Vec<f64>, Vec<f64>) {
        let dim = 2 * self.cameras;
        let mean = self.offsets_at(z, None);
        let weights = self.weights(z, None);
        let total: f64 = weights.iter().sum();
        let mut spread = vec![0.0; self.cameras];
        if total > 0.0 {
            for (&w, o) in weights.iter().zip(self.offsets.chunks_exact(dim)) {
                for (c, s) in spread.iter_mut().enumerate() {
                    let (dx, dy) = (o[2 * c] - mean[2 * c], o[2 * c + 1] - mean[2 * c + 1]);
                    *s += w * (dx * dx + dy * dy);
                }
            }
            spread.iter_mut().for_each(|s| *s = (*s / total).sqrt());
        }
        (mean, spread)
    }

    /// The kernel weights of every sample at descriptor `z` (0 for sample `skip`), relative
    /// to the nearest sample's, which cancels in the ratio and keeps them from underflowing
    /// far from every sample.
    fn weights(&self, z: &[f64], skip: Option<usize>) -> Vec<f64> {
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
        d2.iter()
            .enumerate()
            .map(|(i, &d)| {
                if Some(i) == skip {
                    0.0
                } else {
                    (-(d - nearest) * inv).exp()
                }
            })
            .collect()
    }

    /// The Nadaraya–Watson offsets at descriptor `z`, leaving out sample `skip`.
    fn offsets_at(&self, z: &[f64], skip: Option<usize>) -> Vec<f64> {
        let dim = 2 * self.cameras;
        let weights = self.weights(z, skip);
        let mut sum = vec![0.0; dim];
        let mut total = 0.0;
        for (&w, o) in weights.iter().zip(self.offsets.chunks_exact(dim)) {
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

    /// Samples of one camera on a 20 × 20 grid whose offset is a smooth function, except in the
    /// block `u ≥ 250` where it alternates between two values 8 px apart from pose to pose (the
    /// far end changing feature): the correction's spread is small far from the block and large
    /// in it.
    fn split_samples() -> Vec<CorrectionSample> {
        let mut out = Vec::new();
        for i in 0..20 {
            for j in 0..20 {
                let f = [100.0 + 10.0 * i as f64, 80.0 + 8.0 * j as f64];
                let o = if f[0] >= 200.0 {
                    if (i + j) % 2 == 0 {
                        [4.0, 0.0]
                    } else {
                        [-4.0, 0.0]
                    }
                } else {
                    [1.0 + 0.01 * f[0], -0.5]
                };
                out.push(CorrectionSample {
                    far_ends: vec![f],
                    end_faces: vec![Some([f[0] + o[0], f[1] + o[1]])],
                });
            }
        }
        out
    }

    /// The gated tips: gate 0 is the plain rule, the spread tells the smooth part from the
    /// disagreeing one, and the end-face tip takes over (moves the tip by up to `k σ`) only
    /// where the correction is unsure.
    #[test]
    fn the_spread_gates_how_far_the_end_face_moves_the_tip() {
        let (model, _) = TipCorrection::learn(&split_samples(), &[10.0]).expect("learned");
        let smooth = [[105.0, 120.0]];
        let split = [[275.0, 120.0]];
        let s = model.tips_gated(&smooth, &[None], 1.0).unwrap()[0];
        let d = model.tips_gated(&split, &[None], 1.0).unwrap()[0];
        assert!(s.spread < 0.5, "smooth part: spread {}", s.spread);
        assert!(d.spread > 3.0, "disagreeing part: spread {}", d.spread);
        for f in [smooth, split] {
            // A face 3 px from the plain tip.
            let plain = model.tips(&f, &[None]).unwrap()[0];
            let face = [Some([plain[0], plain[1] + 3.0])];
            let zero = model.tips_gated(&f, &face, 0.0).unwrap()[0];
            assert_eq!(zero.position, model.tips(&f, &face).unwrap()[0]);
            let gated = model.tips_gated(&f, &face, 1.0).unwrap()[0];
            let moved = gated.position[1] - plain[1];
            let expected = (CLIP_PX.max(gated.spread)).min(3.0);
            assert!(
                (moved - expected).abs() < 1e-9,
                "moved {moved}, expected {expected}"
            );
            assert_eq!(gated.position[0], plain[0]);
            // Deterministic.
            assert_eq!(model.tips_gated(&f, &face, 1.0).unwrap()[0], gated);
        }
        // In the disagreeing part a gate of 1 lets the face take over entirely (3 px < σ).
        let plain = model.tips(&split, &[None]).unwrap()[0];
        let face = [plain[0] + 2.0, plain[1] - 2.0];
        let t = model.tips_gated(&split, &[Some(face)], 1.0).unwrap()[0];
        assert_eq!(t.position, face);
        for bad in [-1.0, f64::NAN, f64::INFINITY] {
            assert!(matches!(
                model.tips_gated(&split, &[None], bad),
                Err(ServoError::InvalidParameter {
                    name: "face_gate",
                    ..
                })
            ));
        }
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
