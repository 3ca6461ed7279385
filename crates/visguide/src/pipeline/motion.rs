//! The commanded move as a known input of the tracker: a forward model, learned by action, of
//! where each camera sees the tip for a command, `x̂ = g(y)`, so that a move from `y` to `y'`
//! is predicted to shift the tip by `g(y') − g(y)` in each image.
//!
//! `g` is one LWPR model (crate `lwpr`, the thesis's incremental regression of Paper C) from the
//! controlled servos' set-points to the tip's image positions of every camera, learned from
//! random moves seen through the heuristic percept (the same teacher as the shape model; no
//! ground truth). Where no trustworthy receptive field covers a command the prediction is
//! `None`: that move shifts no track, and one larger than the notifier's `reset_us` restarts
//! the tracks, as without a forward model.
//!
//! How the tracker uses it ([`super::track`]): each track keeps the sum `c` of the predicted
//! shifts since it started and tracks in *compensated* coordinates `z − c`, where the tip moves
//! only by what the prediction got wrong. The stationary layout's models depend on
//! displacements only, so this change of coordinates is exactly a shift of the posterior by the
//! predicted move before the learned prediction; and the training walks are compensated the
//! same way, so the learned system model is the distribution of the prediction's residuals.

use lwpr::{Lwpr, LwprBuilder};
use servo_loop::ServoError;

use super::error::{PipelineError, Result, check_unit_interval};

/// Settings of the forward model.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MotionConfig {
    /// Random moves through the heuristic percept to learn it from (0: no forward model; the
    /// tracker then uses its learned motion alone).
    pub moves: usize,
    /// Input normalisation (µs for RC servos).
    pub command_scale: f64,
    /// Output normalisation (pixels).
    pub pixel_scale: f64,
    /// Initial spherical distance metric (normalised units).
    pub init_d: f64,
    /// Learning rate of the distance metric.
    pub init_alpha: f64,
    /// Activation below which a new receptive field is created.
    pub w_gen: f64,
    /// Activation below which a prediction is refused.
    pub cutoff: f64,
    /// Learn only from teacher percepts whose every camera is at least this certain (the
    /// teacher caps its certainty by the cameras' epipolar consistency; 0, the default, learns
    /// from every percept). Its error scale for the prior is measured on such percepts too.
    /// An option: with 0.05 (the servo loop's refusal threshold) the prior became sharp enough
    /// to apply on the simulated hard scene and its servo improved, but the default scene's got
    /// worse (docs/methods.md, *The forward model learned from accepted teacher percepts only*).
    pub min_teacher_certainty: f64,
}

impl Default for MotionConfig {
    /// The inverse model's LWPR settings (`servo_loop::InverseModelConfig`), inputs and
    /// outputs swapped; 300 moves.
    fn default() -> Self {
        MotionConfig {
            moves: 300,
            command_scale: 500.0,
            pixel_scale: 320.0,
            init_d: 25.0,
            init_alpha: 250.0,
            w_gen: 0.2,
            cutoff: 0.001,
            min_teacher_certainty: 0.0,
        }
    }
}

impl MotionConfig {
    /// Checks the settings: scales, `init_d` and `init_alpha` finite and positive, `w_gen` and
    /// `cutoff` in `(0, 1)` (the inverse model's checks, `servo_loop::InverseModelConfig`, whose
    /// LWPR settings these are with inputs and outputs swapped; its `percept_scale` is this
    /// `pixel_scale`), and `min_teacher_certainty` in `[0, 1]`. An error names the setting.
    pub fn validate(&self) -> Result<()> {
        servo_loop::InverseModelConfig {
            percept_scale: self.pixel_scale,
            command_scale: self.command_scale,
            init_d: self.init_d,
            init_alpha: self.init_alpha,
            w_gen: self.w_gen,
            update_d: true,
            cutoff: self.cutoff,
        }
        .validate()
        .map_err(|e| match e {
            ServoError::InvalidParameter { name, reason } => PipelineError::InvalidParameter {
                name: if name == "percept_scale" {
                    "pixel_scale"
                } else {
                    name
                },
                reason,
            },
            other => PipelineError::Servo(other),
        })?;
        check_unit_interval("min_teacher_certainty", self.min_teacher_certainty)
    }
}

/// The learned forward model `x̂ = g(y)`: controlled servos' set-points → the tip in every camera.
#[derive(Debug, Clone)]
pub struct MotionModel {
    lwpr: Lwpr,
    controlled: Vec<usize>,
    cameras: usize,
    cutoff: f64,
}

impl MotionModel {
    /// An empty model reading the servos `controlled` of a full command, for `cameras`
    /// cameras. Errors: an invalid configuration, no servo or camera, or more than LWPR takes
    /// (two outputs per camera).
    pub fn new(controlled: &[usize], cameras: usize, config: &MotionConfig) -> Result<Self> {
        config.validate()?;
        if controlled.is_empty() || cameras == 0 {
            return Err(PipelineError::InvalidParameter {
                name: "motion model",
                reason: "needs at least one controlled servo and one camera".into(),
            });
        }
        // Two outputs per camera: a camera count whose double overflows is refused here (it
        // used to panic in the multiplication).
        let n_out = cameras
            .checked_mul(2)
            .ok_or_else(|| PipelineError::InvalidParameter {
                name: "cameras",
                reason: format!("{cameras} cameras: too many outputs"),
            })?;
        let n_in = controlled.len();
        lwpr::check_sizes(n_in, n_out)?;
        let lwpr = LwprBuilder::new(n_in, n_out)
            .norm_in(&vec![config.command_scale; n_in])
            .norm_out(&vec![config.pixel_scale; n_out])
            .init_d_spherical(config.init_d)
            .init_alpha(config.init_alpha)
            .w_gen(config.w_gen)
            .update_d(true)
            .build()?;
        Ok(MotionModel {
            lwpr,
            controlled: controlled.to_vec(),
            cameras,
            cutoff: config.cutoff,
        })
    }

    /// Cameras predicted.
    pub fn num_cameras(&self) -> usize {
        self.cameras
    }

    /// Training pairs seen.
    pub fn n_data(&self) -> u64 {
        self.lwpr.n_data()
    }

    fn input(&self, command: &[f64]) -> Result<Vec<f64>> {
        let x: Option<Vec<f64>> = self
            .controlled
            .iter()
            .map(|&i| command.get(i).copied().filter(|v| v.is_finite()))
            .collect();
        x.ok_or_else(|| PipelineError::InvalidParameter {
            name: "command",
            reason: format!(
                "{} set-points, finite at servos {:?} expected",
                command.len(),
                self.controlled
            ),
        })
    }

    /// One training pair: the full `command` and the tip seen in every camera. Invalid input
    /// (a short or non-finite command, a wrong camera count, a non-finite position) is refused
    /// and leaves the model unchanged.
    pub fn update(&mut self, command: &[f64], tips: &[[f64; 2]]) -> Result<()> {
        let x = self.input(command)?;
        if tips.len() != self.cameras || tips.iter().flatten().any(|v| !v.is_finite()) {
            return Err(PipelineError::InvalidParameter {
                name: "tips",
                reason: format!("{} finite positions expected", self.cameras),
            });
        }
        let y: Vec<f64> = tips.iter().flatten().copied().collect();
        self.lwpr.update(&x, &y)?;
        Ok(())
    }

    /// The tip in every camera for the full `command`; `None` where no trustworthy receptive
    /// field covers it. Errors: a short or non-finite command.
    pub fn predict(&self, command: &[f64]) -> Result<Option<Vec<[f64; 2]>>> {
        let x = self.input(command)?;
        let (y, w) = self.lwpr.predict_with_max_activation(&x, self.cutoff)?;
        if w.iter().any(|&w| w <= self.cutoff) {
            return Ok(None);
        }
        Ok(Some(y.chunks_exact(2).map(|p| [p[0], p[1]]).collect()))
    }

    /// The predicted shift of the tip in every camera for a move from `from` to `to` (full
    /// commands): `g(to) − g(from)`, `None` where either lies outside the model.
    pub fn shift(&self, from: &[f64], to: &[f64]) -> Result<Option<Vec<[f64; 2]>>> {
        let (Some(a), Some(b)) = (self.predict(from)?, self.predict(to)?) else {
            return Ok(None);
        };
        Ok(Some(Self::difference(&a, &b)?))
    }

    /// The shift between two predictions of every camera, `to − from` (what [`Self::shift`]
    /// returns for the commands they were predicted at, for a caller that keeps the last
    /// prediction instead of predicting it again).
    ///
    /// Errors ([`PipelineError::InvalidParameter`], `predictions`): `from` and `to` of
    /// different lengths (predictions of different camera counts; the shift used to be cut to
    /// the shorter one silently).
    pub fn difference(from: &[[f64; 2]], to: &[[f64; 2]]) -> Result<Vec<[f64; 2]>> {
        if from.len() != to.len() {
            return Err(PipelineError::InvalidParameter {
                name: "predictions",
                reason: format!(
                    "from {} cameras to {}: one prediction per camera in both expected",
                    from.len(),
                    to.len()
                ),
            });
        }
        Ok(from
            .iter()
            .zip(to)
            .map(|(a, b)| [b[0] - a[0], b[1] - a[1]])
            .collect())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A linear arm: the tip moves 0.3 px per µs of servo 0 along x in camera 0, and so on.
    fn truth(y: &[f64]) -> Vec<[f64; 2]> {
        vec![
            [
                0.3 * (y[0] - 1500.0) + 320.0,
                -0.2 * (y[2] - 1500.0) + 240.0,
            ],
            [
                0.25 * (y[0] - 1500.0) + 300.0,
                0.2 * (y[2] - 1500.0) + 250.0,
            ],
        ]
    }

    fn learned() -> MotionModel {
        let mut m = MotionModel::new(&[0, 2], 2, &MotionConfig::default()).unwrap();
        let mut s = 1u64;
        for _ in 0..400 {
            let mut y = vec![1500.0; 3];
            for v in [0, 2] {
                s = s
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                y[v] = 1300.0 + 400.0 * ((s >> 11) as f64 / (1u64 << 53) as f64);
            }
            m.update(&y, &truth(&y)).unwrap();
        }
        m
    }

    #[test]
    fn shift_of_a_linear_arm_is_learned() {
        // Within 5 % + 0.5 px: LWPR's local models start with one PLS projection of two inputs.
        let m = learned();
        let (a, b) = (vec![1400.0, 1500.0, 1450.0], vec![1550.0, 1500.0, 1600.0]);
        let d = m.shift(&a, &b).unwrap().expect("inside the model");
        let (ta, tb) = (truth(&a), truth(&b));
        for c in 0..2 {
            for k in 0..2 {
                let want = tb[c][k] - ta[c][k];
                assert!(
                    (d[c][k] - want).abs() < 0.05 * want.abs() + 0.5,
                    "camera {c} axis {k}: {} vs {want}",
                    d[c][k]
                );
            }
        }
        // The servo it does not read does not matter.
        let b2 = vec![1550.0, 1900.0, 1600.0];
        assert_eq!(m.shift(&a, &b2).unwrap(), Some(d));
    }

    #[test]
    fn outside_the_model_is_none_and_bad_input_an_error() {
        let m = learned();
        assert_eq!(m.predict(&[9000.0, 1500.0, 9000.0]).unwrap(), None);
        assert!(m.predict(&[1500.0, 1500.0]).is_err());
        assert!(m.predict(&[f64::NAN, 1500.0, 1500.0]).is_err());
        let empty = MotionModel::new(&[0], 1, &MotionConfig::default()).unwrap();
        assert_eq!(empty.predict(&[1500.0]).unwrap(), None);
    }

    #[test]
    fn refused_updates_change_nothing() {
        let mut m = learned();
        let n = m.n_data();
        let before = m.predict(&[1500.0, 1500.0, 1500.0]).unwrap();
        assert!(m.update(&[1500.0, 1500.0, 1500.0], &[[1.0, 2.0]]).is_err());
        assert!(
            m.update(&[1500.0, 1500.0, 1500.0], &[[1.0, f64::NAN], [0.0, 0.0]])
                .is_err()
        );
        assert!(m.update(&[1500.0], &[[1.0, 2.0], [0.0, 0.0]]).is_err());
        assert_eq!(m.n_data(), n);
        assert_eq!(m.predict(&[1500.0, 1500.0, 1500.0]).unwrap(), before);
    }

    /// Sets one field of the settings.
    type Setter = fn(&mut MotionConfig, f64);

    /// Every setting out of its range is refused by `validate`, naming that setting (the
    /// inverse model's check, with its `percept_scale` named `pixel_scale` here).
    #[test]
    fn every_bad_setting_is_named() {
        let ok = MotionConfig::default();
        assert!(ok.validate().is_ok());
        let cases: [(&str, Setter, &[f64]); 7] = [
            (
                "command_scale",
                |c, v| c.command_scale = v,
                &[0.0, -1.0, f64::NAN, f64::INFINITY],
            ),
            (
                "pixel_scale",
                |c, v| c.pixel_scale = v,
                &[0.0, -1.0, f64::NAN, f64::INFINITY],
            ),
            (
                "init_d",
                |c, v| c.init_d = v,
                &[0.0, -1.0, f64::NAN, f64::INFINITY],
            ),
            (
                "init_alpha",
                |c, v| c.init_alpha = v,
                &[0.0, -1.0, f64::NAN, f64::INFINITY],
            ),
            ("w_gen", |c, v| c.w_gen = v, &[0.0, 1.0, 2.0, f64::NAN]),
            ("cutoff", |c, v| c.cutoff = v, &[0.0, 1.0, -0.5, f64::NAN]),
            (
                "min_teacher_certainty",
                |c, v| c.min_teacher_certainty = v,
                &[-0.1, 1.5, f64::NAN],
            ),
        ];
        for (name, set, bad) in cases {
            for &v in bad {
                let mut c = ok;
                set(&mut c, v);
                match c.validate() {
                    Err(PipelineError::InvalidParameter { name: n, .. }) => {
                        assert_eq!(n, name, "{name} = {v}");
                    }
                    other => panic!("{name} = {v}: {other:?}"),
                }
            }
            // A value inside the range is accepted.
            let mut c = ok;
            set(
                &mut c,
                if name == "min_teacher_certainty" {
                    1.0
                } else {
                    0.5
                },
            );
            assert!(c.validate().is_ok(), "{name}");
        }
    }

    #[test]
    fn settings_are_checked() {
        for bad in [
            MotionConfig {
                command_scale: 0.0,
                ..MotionConfig::default()
            },
            MotionConfig {
                pixel_scale: f64::NAN,
                ..MotionConfig::default()
            },
            MotionConfig {
                w_gen: 1.0,
                ..MotionConfig::default()
            },
            MotionConfig {
                cutoff: 0.0,
                ..MotionConfig::default()
            },
            MotionConfig {
                min_teacher_certainty: f64::NAN,
                ..MotionConfig::default()
            },
            MotionConfig {
                min_teacher_certainty: 1.5,
                ..MotionConfig::default()
            },
        ] {
            assert!(MotionModel::new(&[0], 1, &bad).is_err());
        }
        assert!(MotionModel::new(&[], 1, &MotionConfig::default()).is_err());
        assert!(MotionModel::new(&[0], 0, &MotionConfig::default()).is_err());
    }

    /// The shift between predictions of different camera counts is a typed error (it used to
    /// be cut to the shorter one: a camera left out of the shift, silently).
    #[test]
    fn a_difference_of_predictions_of_different_lengths_is_refused() {
        let (a, b) = ([[1.0, 2.0], [3.0, 4.0]], [[2.0, 4.0], [6.0, 8.0]]);
        assert_eq!(
            MotionModel::difference(&a, &b).unwrap(),
            vec![[1.0, 2.0], [3.0, 4.0]]
        );
        for (from, to) in [(&a[..], &b[..1]), (&a[..1], &b[..]), (&a[..0], &b[..])] {
            assert!(matches!(
                MotionModel::difference(from, to),
                Err(PipelineError::InvalidParameter {
                    name: "predictions",
                    ..
                })
            ));
        }
        assert!(MotionModel::difference(&[], &[]).unwrap().is_empty());
    }

    /// A camera count whose two outputs per camera overflow is a typed error (it used to panic
    /// on the multiplication); one LWPR refuses as too large is its error.
    #[test]
    fn a_huge_camera_count_is_refused_not_a_panic() {
        let d = MotionConfig::default();
        assert!(matches!(
            MotionModel::new(&[0], usize::MAX / 2 + 1, &d),
            Err(PipelineError::InvalidParameter {
                name: "cameras",
                ..
            })
        ));
        assert!(MotionModel::new(&[0], usize::MAX / 2, &d).is_err());
    }
}
