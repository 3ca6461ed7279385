//! `visguide.tracking`: channel-based tracking (Paper B) and its Kalman and particle-filter
//! baselines, frame by frame (`step`) or over a whole sequence (`run`, without the GIL).

use cbt_tracker::{
    CbtConfig, CbtModel, CbtTracker, Clutter, Detection, KalmanParams, KalmanTracker, Layout,
    ObservationFallback, Order, ParticleFilter, PfModel, Space, SystemFallback, Tracker,
    TrainingFrame,
};
use numpy::ndarray::Array2;
use numpy::{AllowTypeChange, IntoPyArray, PyArray2, PyArrayLike2};
use pyo3::exceptions::PyOSError;
use pyo3::prelude::*;
use pyo3::types::{PyTuple, PyType};

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

/// Writes `text` to `path` through a temporary file, so a failed write leaves no partial file.
fn write_atomic(path: &std::path::Path, text: &str) -> PyResult<()> {
    let mut tmp = path.as_os_str().to_owned();
    tmp.push(".tmp");
    let tmp = std::path::PathBuf::from(tmp);
    let r = std::fs::write(&tmp, text).and_then(|_| std::fs::rename(&tmp, path));
    if let Err(e) = r {
        let _ = std::fs::remove_file(&tmp);
        return Err(PyOSError::new_err(format!("{}: {e}", path.display())));
    }
    Ok(())
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
            /// weights.
            fn step(&mut self, detections: &Bound<'_, PyAny>) -> PyResult<Est> {
                let d = rows("detections", detections, 3)?;
                self.t.step(&d).map(|e| est(&e)).map_err(from_track)
            }

            /// Resets to ``start`` and steps through ``frames`` (one detection array per frame)
            /// without the GIL. Returns ``(T, 3)``: x, y, certainty (NaN if none).
            fn run<'py>(
                &mut self,
                py: Python<'py>,
                start: (f64, f64),
                frames: &Bound<'py, PyAny>,
            ) -> PyResult<Bound<'py, PyArray2<f64>>> {
                let start = point("start", start)?;
                let frames = frames_of(frames)?;
                let out = run_all(py, &mut self.t, start, &frames)?;
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
                let text = slf.borrow().to_json()?;
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

/// `name` as a count (`ValueError`, not `OverflowError`, for a negative value).
fn count(name: &str, v: i64) -> PyResult<usize> {
    usize::try_from(v).map_err(|_| value_error(format!("{name} = {v} must be ≥ 0")))
}

/// One of the names in `options` (`ValueError` naming them otherwise).
fn choice<T: Copy>(name: &str, v: &str, options: &[(&str, T)]) -> PyResult<T> {
    options
        .iter()
        .find(|(k, _)| *k == v)
        .map(|(_, t)| *t)
        .ok_or_else(|| {
            let known: Vec<String> = options.iter().map(|(k, _)| format!("'{k}'")).collect();
            value_error(format!(
                "{name} must be one of {}, not '{v}'",
                known.join(", ")
            ))
        })
}

const ORDERS: &[(&str, Order)] = &[("first", Order::First), ("second", Order::Second)];
const LAYOUTS: &[(&str, Layout)] = &[
    ("separable", Layout::Separable),
    ("sparse_joint", Layout::SparseJoint),
    ("stationary", Layout::Stationary),
];
const CLUTTERS: &[(&str, Clutter)] = &[
    ("model", Clutter::Model),
    ("subtract", Clutter::Subtract),
    ("uniform", Clutter::Uniform),
];
const OBSERVATION_FALLBACKS: &[(&str, ObservationFallback)] = &[
    ("identity", ObservationFallback::Identity),
    ("uniform", ObservationFallback::Uniform),
];
const SYSTEM_FALLBACKS: &[(&str, SystemFallback)] = &[
    ("constant_velocity", SystemFallback::ConstantVelocity),
    ("first_order", SystemFallback::FirstOrder),
];

/// The name of `v` in `options`.
fn name_of<T: PartialEq>(v: T, options: &[(&'static str, T)]) -> &'static str {
    options
        .iter()
        .find(|(_, t)| *t == v)
        .map(|(k, _)| *k)
        .expect("every variant is listed")
}

/// A configuration from keyword arguments (`None`: the crate's default), validated.
#[allow(clippy::too_many_arguments)]
fn config_of(
    order: &str,
    layout: &str,
    clutter: &str,
    observation_fallback: &str,
    system_fallback: &str,
    prior_weight: f64,
    fallback_sigma: f64,
    observation_floor: f64,
    mixing: f64,
    prune: f64,
    online_weight: f64,
    runner_ups: i64,
    obs_radius: i64,
    support: f64,
    decode_radius: i64,
) -> PyResult<CbtConfig> {
    let c = CbtConfig {
        order: choice("order", order, ORDERS)?,
        layout: choice("layout", layout, LAYOUTS)?,
        clutter: choice("clutter", clutter, CLUTTERS)?,
        observation_fallback: choice(
            "observation_fallback",
            observation_fallback,
            OBSERVATION_FALLBACKS,
        )?,
        system_fallback: choice("system_fallback", system_fallback, SYSTEM_FALLBACKS)?,
        prior_weight,
        fallback_sigma,
        observation_floor,
        mixing,
        prune,
        online_weight,
        runner_ups: count("runner_ups", runner_ups)?,
        obs_radius: count("obs_radius", obs_radius)?,
        support,
        decode_radius: count("decode_radius", decode_radius)?,
        input: None,
    };
    c.validate().map_err(from_track)?;
    Ok(c)
}

tracker_methods!(PyCbt, {
    /// Learns the system and observation models from ``sequences``: each a list of frames
    /// ``(truths, detections)`` with ``truths`` an ``(k, 2)`` array (usually one row; empty when
    /// the frame is not annotated) and ``detections`` ``(n, 2)`` or ``(n, 3)`` with weights,
    /// clutter included, no association needed. The grid covers ``[0, width] × [0, height]``
    /// with channels ``spacing`` apart. Releases the GIL while learning.
    ///
    /// The keywords are the crate's ``CbtConfig`` (defaults: the second-order separable
    /// tracker of Paper B): ``order`` (``"first"``, ``"second"``), ``layout``
    /// (``"separable"``, ``"sparse_joint"``, ``"stationary"``), ``clutter`` (``"model"``,
    /// ``"subtract"``, ``"uniform"``), ``observation_fallback`` (``"identity"``,
    /// ``"uniform"``), ``system_fallback`` (``"first_order"``, ``"constant_velocity"``),
    /// ``prior_weight`` (> 0), ``fallback_sigma`` (> 0, channels), ``observation_floor``,
    /// ``mixing``, ``prune`` and ``support`` (in [0, 1]), ``online_weight`` (> 0),
    /// ``runner_ups``, ``obs_radius`` (1–64 channels) and ``decode_radius`` (channels).
    /// ``self_learning=True`` makes every :meth:`step` also learn from the tracker's own
    /// estimate (:meth:`learn_online`). ``ValueError`` for any invalid value.
    #[staticmethod]
    #[pyo3(signature = (
        sequences, width, height, spacing = 10.0, *, order = "second", layout = "separable",
        clutter = "model", observation_fallback = "identity", system_fallback = "first_order",
        prior_weight = 1.0, fallback_sigma = 1.0, observation_floor = 1e-3, mixing = 1e-3,
        prune = 0.01, online_weight = 1.0, runner_ups = 3, obs_radius = 10, support = 1e-2,
        decode_radius = 4, self_learning = false
    ))]
    #[allow(clippy::too_many_arguments)]
    fn learn(
        py: Python<'_>,
        sequences: &Bound<'_, PyAny>,
        width: f64,
        height: f64,
        spacing: f64,
        order: &str,
        layout: &str,
        clutter: &str,
        observation_fallback: &str,
        system_fallback: &str,
        prior_weight: f64,
        fallback_sigma: f64,
        observation_floor: f64,
        mixing: f64,
        prune: f64,
        online_weight: f64,
        runner_ups: i64,
        obs_radius: i64,
        support: f64,
        decode_radius: i64,
        self_learning: bool,
    ) -> PyResult<Self> {
        let config = config_of(
            order,
            layout,
            clutter,
            observation_fallback,
            system_fallback,
            prior_weight,
            fallback_sigma,
            observation_floor,
            mixing,
            prune,
            online_weight,
            runner_ups,
            obs_radius,
            support,
            decode_radius,
        )?;
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
    fn config<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, pyo3::types::PyDict>> {
        let c = self.t.model().config();
        let d = pyo3::types::PyDict::new(py);
        d.set_item("order", name_of(c.order, ORDERS))?;
        d.set_item("layout", name_of(c.layout, LAYOUTS))?;
        d.set_item("clutter", name_of(c.clutter, CLUTTERS))?;
        d.set_item(
            "observation_fallback",
            name_of(c.observation_fallback, OBSERVATION_FALLBACKS),
        )?;
        d.set_item(
            "system_fallback",
            name_of(c.system_fallback, SYSTEM_FALLBACKS),
        )?;
        d.set_item("prior_weight", c.prior_weight)?;
        d.set_item("fallback_sigma", c.fallback_sigma)?;
        d.set_item("observation_floor", c.observation_floor)?;
        d.set_item("mixing", c.mixing)?;
        d.set_item("prune", c.prune)?;
        d.set_item("online_weight", c.online_weight)?;
        d.set_item("runner_ups", c.runner_ups)?;
        d.set_item("obs_radius", c.obs_radius)?;
        d.set_item("support", c.support)?;
        d.set_item("decode_radius", c.decode_radius)?;
        Ok(d)
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
