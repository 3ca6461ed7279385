//! `visguide.tracking`: channel-based tracking (Paper B) and its Kalman and particle-filter
//! baselines, frame by frame (`step`) or over a whole sequence (`run`, without the GIL).

use cbt_tracker::{
    CbtConfig, CbtModel, CbtTracker, Detection, KalmanParams, KalmanTracker, ParticleFilter,
    PfModel, Space, Tracker, TrainingFrame,
};
use numpy::ndarray::Array2;
use numpy::{AllowTypeChange, IntoPyArray, PyArray2, PyArrayLike2};
use pyo3::exceptions::PyOSError;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyTuple, PyType};

use crate::cbt_config::{config_dict, config_from};
use crate::errors::{from_track, value_error};

/// Points from an `(n, 2)` array, or detections from `(n, 2)` / `(n, 3)` (third column: weight).
/// An empty sequence is no points.
fn rows(name: &str, a: &Bound<'_, PyAny>, max_cols: usize) -> PyResult<Vec<Detection>> {
    if a.len().is_ok_and(|n| n == 0) {
        return Ok(Vec::new());
    }
    let arr: PyArrayLike2<'_, f64, AllowTypeChange> = a.extract()?;
    let v = arr.as_array();
    if !(2..=max_cols).contains(&v.ncols()) {
        return Err(value_error(format!(
            "{name} must be an (n, 2){} array, got {} columns",
            if max_cols == 3 { " or (n, 3)" } else { "" },
            v.ncols()
        )));
    }
    Ok(v.rows()
        .into_iter()
        .map(|r| Detection {
            pos: [r[0], r[1]],
            weight: if r.len() == 3 { r[2] } else { 1.0 },
        })
        .collect())
}

fn point(name: &str, p: (f64, f64)) -> PyResult<[f64; 2]> {
    if !(p.0.is_finite() && p.1.is_finite()) {
        return Err(value_error(format!(
            "{name} ({}, {}) is not finite",
            p.0, p.1
        )));
    }
    Ok([p.0, p.1])
}

type Est = (f64, f64, Option<f64>);

fn est(e: &cbt_tracker::Estimate) -> Est {
    (e.position[0], e.position[1], e.certainty)
}

/// Runs `t` from `start` over `frames`, returning `(T, 3)`: x, y, certainty (NaN if none).
fn run_all<T: Tracker + Send>(
    py: Python<'_>,
    t: &mut T,
    start: [f64; 2],
    frames: &[Vec<Detection>],
) -> PyResult<Vec<f64>> {
    py.detach(|| -> Result<Vec<f64>, cbt_tracker::TrackError> {
        t.reset(start)?;
        let mut out = Vec::with_capacity(frames.len() * 3);
        for f in frames {
            let e = t.step(f)?;
            out.extend([
                e.position[0],
                e.position[1],
                e.certainty.unwrap_or(f64::NAN),
            ]);
        }
        Ok(out)
    })
    .map_err(from_track)
}

fn frames_of(frames: &Bound<'_, PyAny>) -> PyResult<Vec<Vec<Detection>>> {
    frames
        .try_iter()?
        .map(|f| rows("detections", &f?, 3))
        .collect()
}

/// Writes `text` to `path` atomically (`visguide::output::atomic`: a temporary file beside it,
/// flushed and renamed), so a failed write leaves no partial file.
fn write_atomic(path: &std::path::Path, text: &str) -> PyResult<()> {
    visguide::output::atomic::write_bytes(path, text.as_bytes())
        .map_err(|e| PyOSError::new_err(e.to_string()))
}

fn read(path: &std::path::Path) -> PyResult<String> {
    std::fs::read_to_string(path)
        .map_err(|e| PyOSError::new_err(format!("{}: {e}", path.display())))
}

/// The methods every tracker class shares: `reset`, `step`, `run`, `estimate`, JSON
/// save/load and pickling.
macro_rules! tracker_methods {
    ($T:ty, { $($extra:tt)* }) => {
        #[pymethods]
        impl $T {
            $($extra)*

            /// Starts tracking at ``start = (x, y)``.
            fn reset(&mut self, start: (f64, f64)) -> PyResult<()> {
                self.t.reset(point("start", start)?).map_err(from_track)
            }

            /// One frame: predicts, then updates with ``detections`` (``(n, 2)``, or ``(n, 3)``
            /// with weights; empty for none). Returns ``(x, y, certainty)`` (certainty ``None``
            /// for trackers without one). ``ValueError`` (state unchanged) for NaN or negative
            /// weights, or a detection off CBT's grid (:meth:`step_on_grid` leaves those out).
            fn step(&mut self, detections: &Bound<'_, PyAny>) -> PyResult<Est> {
                let d = rows("detections", detections, 3)?;
                self.t.step(&d).map(|e| est(&e)).map_err(from_track)
            }

            /// As :meth:`step`, but a detection off the tracker's grid (outside the extent
            /// its model covers; only CBT has one) is left out instead of refusing the frame,
            /// and the frame's other detections are used. Returns ``(x, y, certainty,
            /// left_out)``, ``left_out`` the number of detections left out. ``ValueError``
            /// (state unchanged) for NaN or negative weights, as :meth:`step`.
            fn step_on_grid(
                &mut self,
                detections: &Bound<'_, PyAny>,
            ) -> PyResult<(f64, f64, Option<f64>, usize)> {
                let d = rows("detections", detections, 3)?;
                let (e, left_out) =
                    cbt_tracker::step_on_grid(&mut self.t, &d).map_err(from_track)?;
                Ok((e.position[0], e.position[1], e.certainty, left_out))
            }

            /// Resets to ``start`` and steps through ``frames`` (one detection array per frame)
            /// without the GIL. Returns ``(T, 3)``: x, y, certainty (NaN if none).
            /// ``ValueError`` (state unchanged: neither reset nor part-run) for a frame that
            /// :meth:`step` refuses.
            fn run<'py>(
                &mut self,
                py: Python<'py>,
                start: (f64, f64),
                frames: &Bound<'py, PyAny>,
            ) -> PyResult<Bound<'py, PyArray2<f64>>> {
                let start = point("start", start)?;
                let frames = frames_of(frames)?;
                // On a copy, kept only when every frame was accepted: a refused frame used to
                // leave the tracker reset and stepped up to it.
                let mut t = self.t.clone();
                let out = run_all(py, &mut t, start, &frames)?;
                self.t = t;
                Ok(Array2::from_shape_vec((frames.len(), 3), out)
                    .expect("3 values per frame")
                    .into_pyarray(py))
            }

            /// The current estimate ``(x, y, certainty)``.
            fn estimate(&self) -> Est {
                est(&self.t.estimate())
            }

            /// The tracker (model and state) as JSON.
            fn to_json(&self) -> PyResult<String> {
                serde_json::to_string(&self.t).map_err(|e| value_error(e.to_string()))
            }

            /// A tracker from :meth:`to_json` (validated: ``ValueError`` if corrupt).
            #[classmethod]
            fn from_json(_cls: &Bound<'_, PyType>, text: &str) -> PyResult<Self> {
                Ok(Self {
                    t: serde_json::from_str(text).map_err(|e| value_error(e.to_string()))?,
                })
            }

            /// Writes :meth:`to_json` to ``path`` (``OSError`` on failure, no partial file).
            fn save(&self, path: std::path::PathBuf) -> PyResult<()> {
                write_atomic(&path, &self.to_json()?)
            }

            /// Reads a tracker written by :meth:`save`.
            #[classmethod]
            fn load(cls: &Bound<'_, PyType>, path: std::path::PathBuf) -> PyResult<Self> {
                Self::from_json(cls, &read(&path)?)
            }

            fn __reduce__<'py>(
                slf: &Bound<'py, Self>,
            ) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyTuple>)> {
                let from_json = slf.get_type().getattr("from_json")?;
                // `try_borrow`: while `run` steps without the GIL it holds the tracker, and a
                // pickle from another thread then is a `RuntimeError`, as any other call
                // (`borrow` panicked: `PanicException`).
                let text = slf.try_borrow()?.to_json()?;
                Ok((from_json, PyTuple::new(slf.py(), [text])?))
            }

            fn __eq__(&self, other: &Self) -> bool {
                self.t == other.t
            }
        }
    };
}

/// Channel-based tracker (Paper B) with models learned from unordered truths and detections.
/// Create one with :meth:`learn`.
#[pyclass(module = "visguide.tracking", name = "CBT")]
pub struct PyCbt {
    t: CbtTracker,
}

tracker_methods!(PyCbt, {
    /// Learns the system and observation models from ``sequences``: each a list of frames
    /// ``(truths, detections)`` with ``truths`` an ``(k, 2)`` array (usually one row; empty when
    /// the frame is not annotated) and ``detections`` ``(n, 2)`` or ``(n, 3)`` with weights,
    /// clutter included, no association needed. The grid covers ``[0, width] × [0, height]``
    /// with channels ``spacing`` apart. Releases the GIL while learning.
    ///
    /// The keywords ``**config`` are the fields of the crate's ``CbtConfig``, by name
    /// (:meth:`default_config` lists them with their defaults: the second-order separable
    /// tracker of Paper B): ``order`` (``"first"``, ``"second"``), ``layout``
    /// (``"separable"``, ``"sparse_joint"``, ``"stationary"``), ``clutter`` (``"model"``,
    /// ``"subtract"``, ``"uniform"``), ``observation_fallback`` (``"identity"``,
    /// ``"uniform"``), ``system_fallback`` (``"first_order"``, ``"constant_velocity"``),
    /// ``prior_weight`` (> 0), ``fallback_sigma`` (> 0, channels), ``observation_floor``,
    /// ``mixing``, ``prune`` and ``support`` (in [0, 1]), ``online_weight`` (> 0),
    /// ``runner_ups`` (0–1024), ``obs_radius`` (1–64 channels) and ``decode_radius``
    /// (0–2^24 channels); and for the stationary layout ``smoothing`` (``"fixed"``,
    /// ``"held_out"``), ``start`` (``"marginal"``, ``"learned"``, ``"pooled"``),
    /// ``displacements`` (``"channels"``, ``"interpolated"``, ``"aligned"``, ``"selected"``,
    /// ``"fitted"``), ``observation_smoothing`` (``"counted"``, ``"held_out"``) and ``velocity``
    /// (``"factored"``, ``"per_position"``).
    /// For image tracking and real motion use :meth:`stationary_config`'s settings
    /// (``CBT.learn(seqs, w, h, spacing, **CBT.stationary_config())``, with ``spacing`` about
    /// 0.75 of the detection noise).
    /// ``self_learning=True`` makes every :meth:`step` also learn from the tracker's own
    /// estimate (:meth:`learn_online`). ``TypeError`` for an unknown keyword, ``ValueError``
    /// for any invalid value.
    #[staticmethod]
    #[pyo3(signature = (sequences, width, height, spacing = 10.0, *, self_learning = false, **config))]
    fn learn(
        py: Python<'_>,
        sequences: &Bound<'_, PyAny>,
        width: f64,
        height: f64,
        spacing: f64,
        self_learning: bool,
        config: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Self> {
        let config = config_from("learn", config)?;
        let mut seqs = Vec::new();
        for s in sequences.try_iter()? {
            let mut frames = Vec::new();
            for f in s?.try_iter()? {
                let f = f?;
                let (truths, dets): (Bound<'_, PyAny>, Bound<'_, PyAny>) = f.extract()?;
                frames.push(TrainingFrame {
                    states: rows("truths", &truths, 2)?.iter().map(|d| d.pos).collect(),
                    detections: rows("detections", &dets, 3)?,
                });
            }
            seqs.push(frames);
        }
        let model = py
            .detach(|| -> Result<CbtModel, cbt_tracker::TrackError> {
                let space = Space::image(width, height, spacing)?;
                CbtModel::learn(space, config, &seqs)
            })
            .map_err(from_track)?;
        let t = CbtTracker::new(model);
        Ok(PyCbt {
            t: if self_learning {
                t.with_self_learning()
            } else {
                t
            },
        })
    }

    /// The model's configuration as a dict (the keywords of :meth:`learn`).
    #[getter]
    fn config<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        config_dict(py, self.t.model().config())
    }

    /// The keywords of :meth:`learn` with their defaults, as a dict.
    #[staticmethod]
    fn default_config(py: Python<'_>) -> PyResult<Bound<'_, PyDict>> {
        config_dict(py, &CbtConfig::default())
    }

    /// The keywords of :meth:`learn` for image tracking (the crate's
    /// ``CbtConfig::stationary()``: the stationary layout, second order, the settings chosen
    /// on real walkers), as a dict.
    #[staticmethod]
    fn stationary_config(py: Python<'_>) -> PyResult<Bound<'_, PyDict>> {
        config_dict(py, &CbtConfig::stationary())
    }

    /// Adds one frame (``truths`` ``(k, 2)``, ``detections`` ``(n, 2)`` or ``(n, 3)``) to both
    /// models with weight ``online_weight`` (incremental learning; consecutive calls chain
    /// into transitions). ``ValueError`` for points off the grid or NaN.
    fn learn_online(
        &mut self,
        truths: &Bound<'_, PyAny>,
        detections: &Bound<'_, PyAny>,
    ) -> PyResult<()> {
        let states: Vec<[f64; 2]> = rows("truths", truths, 2)?.iter().map(|d| d.pos).collect();
        let dets = rows("detections", detections, 3)?;
        self.t.learn_online(&states, &dets).map_err(from_track)
    }

    /// The posterior over the channel grid (channel coefficients, summing to 1).
    #[getter]
    fn posterior<'py>(&self, py: Python<'py>) -> Bound<'py, numpy::PyArray1<f64>> {
        numpy::PyArray1::from_slice(py, self.t.posterior())
    }

    fn __repr__(&self) -> String {
        format!("CBT(cells={})", self.t.model().space().cells())
    }
});

/// Constant-velocity Kalman filter with nearest-neighbour gating (the baseline of Paper B).
#[pyclass(module = "visguide.tracking", name = "Kalman")]
pub struct PyKalman {
    t: KalmanTracker,
}

tracker_methods!(PyKalman, {
    /// ``accel_sigma`` (px/frame²), ``meas_sigma`` (px), ``init_vel_sigma`` (px/frame) and the
    /// gate on the squared Mahalanobis distance of the innovation (99 %: 9.21).
    #[new]
    #[pyo3(signature = (accel_sigma, meas_sigma, init_vel_sigma, gate = cbt_tracker::GATE_99))]
    fn new(accel_sigma: f64, meas_sigma: f64, init_vel_sigma: f64, gate: f64) -> PyResult<Self> {
        let params = KalmanParams {
            accel_sigma,
            meas_sigma,
            init_vel_sigma,
            gate,
        };
        Ok(PyKalman {
            t: KalmanTracker::new(params).map_err(from_track)?,
        })
    }

    /// State ``[x, y, vx, vy]``.
    #[getter]
    fn x(&self) -> [f64; 4] {
        let s = self.t.state();
        [s[0], s[1], s[2], s[3]]
    }

    /// State covariance ``P`` (4 × 4).
    #[getter]
    #[allow(non_snake_case)]
    fn P<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        let p = self.t.covariance();
        Array2::from_shape_fn((4, 4), |(i, j)| p[(i, j)]).into_pyarray(py)
    }
});

/// SIR particle filter with a constant-velocity model and a clutter-aware likelihood; every
/// random draw comes from ``seed``.
#[pyclass(module = "visguide.tracking", name = "ParticleFilter")]
pub struct PyParticleFilter {
    t: ParticleFilter,
}

tracker_methods!(PyParticleFilter, {
    /// ``accel_sigma``, ``meas_sigma``, ``p_detect`` (in (0, 1]), ``clutter_density``
    /// (detections per px² per frame), ``init_vel_sigma``; ``n`` particles; ``seed``.
    #[new]
    #[pyo3(signature = (accel_sigma, meas_sigma, p_detect, clutter_density, init_vel_sigma, n = 1000, seed = 0))]
    fn new(
        accel_sigma: f64,
        meas_sigma: f64,
        p_detect: f64,
        clutter_density: f64,
        init_vel_sigma: f64,
        n: usize,
        seed: u64,
    ) -> PyResult<Self> {
        let model = PfModel::ConstantVelocity {
            accel_sigma,
            meas_sigma,
            p_detect,
            clutter_density,
            init_vel_sigma,
        };
        Ok(PyParticleFilter {
            t: ParticleFilter::new(model, n, seed).map_err(from_track)?,
        })
    }

    /// Number of particles.
    fn __len__(&self) -> usize {
        self.t.len()
    }
});
