//! `visguide.fd`: Fourier descriptors of `(N, 2)` contour arrays and their symmetric matching.

use fd_match::{DescriptorConfig, DescriptorSet, Method, Sampling, describe_all};
use numpy::ndarray::Array2;
use numpy::{AllowTypeChange, IntoPyArray, PyArray1, PyArray2, PyArrayLike2};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::errors::{from_fd, value_error};

pub(crate) fn parse_sampling(s: &str) -> PyResult<Sampling> {
    match s {
        "arc_length" => Ok(Sampling::ArcLength),
        "affine" => Ok(Sampling::AffineArcLength),
        "canonical" => Ok(Sampling::Canonical),
        _ => Err(value_error(format!(
            "sampling must be 'arc_length', 'affine' or 'canonical', not '{s}'"
        ))),
    }
}

fn sampling_name(s: Sampling) -> &'static str {
    match s {
        Sampling::ArcLength => "arc_length",
        Sampling::AffineArcLength => "affine",
        Sampling::Canonical => "canonical",
    }
}

pub(crate) fn parse_method(s: &str) -> PyResult<Method> {
    match s {
        "fd_corr" => Ok(Method::FdCorr),
        "abs_fd_ssd" => Ok(Method::AbsFdSsd),
        "afd0_ssd" => Ok(Method::Afd0Ssd),
        "afd1_ssd" => Ok(Method::Afd1Ssd),
        "fd_ssd" => Ok(Method::FdSsd),
        _ => Err(value_error(format!(
            "method must be one of 'fd_corr', 'abs_fd_ssd', 'afd0_ssd', 'afd1_ssd', 'fd_ssd', not '{s}'"
        ))),
    }
}

/// Descriptors of a list of contours (see :func:`visguide.fd.describe`).
///
/// ``sources[i]`` is the index of the contour that descriptor ``i`` describes; contours that
/// could not be described (fewer than 3 points, repeated points, zero area, ...) are listed in
/// ``rejected`` as ``(index, reason)``. ``fd`` is the ``(k, N-1)`` complex array of
/// coefficients ``n = -K..-1, 1..K`` (unit norm), ``magnitudes`` their absolute values,
/// ``afd0`` / ``afd1`` the affine-invariant descriptors.
#[pyclass(frozen, module = "visguide.fd", name = "Descriptors")]
pub struct PyDescriptors {
    pub(crate) set: DescriptorSet,
    #[pyo3(get)]
    rejected: Vec<(usize, String)>,
}

#[pymethods]
impl PyDescriptors {
    fn __len__(&self) -> usize {
        self.set.len()
    }

    /// Contour index of each descriptor.
    #[getter]
    fn sources<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<usize>> {
        PyArray1::from_slice(py, self.set.sources())
    }

    /// The sampling they were made with.
    #[getter]
    fn sampling(&self) -> &'static str {
        sampling_name(self.set.config().sampling)
    }

    /// Complex Fourier descriptors, ``(k, N-1)``.
    #[getter]
    fn fd<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<numpy::Complex64>> {
        let w = self.set.fd_len();
        Array2::from_shape_fn((self.set.len(), w), |(i, j)| self.set.fd(i)[j]).into_pyarray(py)
    }

    /// ``|fd|``, ``(k, N-1)``.
    #[getter]
    fn magnitudes<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        let w = self.set.fd_len();
        Array2::from_shape_fn((self.set.len(), w), |(i, j)| self.set.magnitudes(i)[j])
            .into_pyarray(py)
    }

    /// Order-0 affine-invariant descriptors (real).
    #[getter]
    fn afd0<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        let w = self.set.afd_len();
        Array2::from_shape_fn((self.set.len(), w), |(i, j)| self.set.afd0(i)[j]).into_pyarray(py)
    }

    /// Order-1 affine-invariant descriptors (complex).
    #[getter]
    fn afd1<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<numpy::Complex64>> {
        let w = self.set.afd_len();
        Array2::from_shape_fn((self.set.len(), w), |(i, j)| self.set.afd1(i)[j]).into_pyarray(py)
    }

    /// The descriptors at ``indices`` (``ValueError`` for an index out of range).
    fn select(&self, indices: Vec<usize>) -> PyResult<Self> {
        Ok(PyDescriptors {
            set: self.set.select(&indices).map_err(from_fd)?,
            rejected: self.rejected.clone(),
        })
    }

    /// Each descriptor's smallest error against the others of this set (eq. 18's preselection
    /// statistic).
    #[pyo3(signature = (method = "fd_corr"))]
    fn min_errors<'py>(
        &self,
        py: Python<'py>,
        method: &str,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let method = parse_method(method)?;
        let set = &self.set;
        let e = py
            .detach(|| fd_match::min_errors_within(set, method))
            .map_err(from_fd)?;
        Ok(PyArray1::from_vec(py, e))
    }

    fn __repr__(&self) -> String {
        format!(
            "Descriptors(len={}, sampling='{}', rejected={})",
            self.set.len(),
            sampling_name(self.set.config().sampling),
            self.rejected.len()
        )
    }
}

/// Describes each contour (an ``(N, 2)`` array of ``(x, y)``, closed, not repeating its first
/// point; any numeric dtype) by its Fourier descriptor. ``sampling``: ``"arc_length"``,
/// ``"affine"`` (Paper A's default) or ``"canonical"``; ``samples`` (L), ``coefficients`` (N,
/// odd), ``smoothing`` (σ of the affine arc length's derivatives) and ``dense_samples`` (L₀) as
/// in the ``fd-match`` crate. A contour that cannot be described is listed in ``rejected``, not
/// raised; an array of the wrong shape is a ``ValueError``.
#[pyfunction]
#[pyo3(signature = (contours, *, sampling = "affine", samples = 256, coefficients = 51, smoothing = 1.0, dense_samples = 2048))]
pub fn describe(
    py: Python<'_>,
    contours: Vec<PyArrayLike2<'_, f64, AllowTypeChange>>,
    sampling: &str,
    samples: usize,
    coefficients: usize,
    smoothing: f64,
    dense_samples: usize,
) -> PyResult<PyDescriptors> {
    let config = DescriptorConfig {
        sampling: parse_sampling(sampling)?,
        samples,
        coefficients,
        smoothing,
        dense_samples,
    };
    let mut pts: Vec<Vec<(f64, f64)>> = Vec::with_capacity(contours.len());
    for (i, c) in contours.iter().enumerate() {
        let a = c.as_array();
        if a.ncols() != 2 {
            return Err(value_error(format!(
                "contour {i} must be an (N, 2) array, got {} columns",
                a.ncols()
            )));
        }
        pts.push(a.rows().into_iter().map(|r| (r[0], r[1])).collect());
    }
    let d = py.detach(|| describe_all(config, &pts)).map_err(from_fd)?;
    Ok(PyDescriptors {
        set: d.set,
        rejected: d
            .rejected
            .into_iter()
            .map(|(i, e)| (i, e.to_string()))
            .collect(),
    })
}

/// Symmetric matching of two descriptor sets (eq. 19): pairs ``(i, j)`` where ``j`` is the best
/// target of ``i`` and ``i`` the best of ``j``, kept when the larger of the two error ratios
/// ``e_min / e_sec`` is below ``ratio`` (a positive number; ``None``: keep all); ``a`` and ``b``
/// must be made with the same settings. Returns a dict of equal-length arrays in ascending
/// ``query``: ``query`` / ``target`` (descriptor indices), ``query_contour`` /
/// ``target_contour`` (contour indices), ``error``, ``ratio``, and for ``"fd_corr"``
/// ``rotation`` (radians, A to B) and ``shift`` (start-point shift in samples); NaN for the
/// other methods.
#[pyfunction]
#[pyo3(name = "match", signature = (a, b, *, method = "fd_corr", ratio = Some(fd_match::DEFAULT_RATIO_THRESHOLD)))]
pub fn match_sets<'py>(
    py: Python<'py>,
    a: &PyDescriptors,
    b: &PyDescriptors,
    method: &str,
    ratio: Option<f64>,
) -> PyResult<Bound<'py, PyDict>> {
    let method = parse_method(method)?;
    // As `match_images` (and the crate's `MatchSettings`): a threshold of 0 or below would
    // silently keep no match.
    if let Some(r) = ratio
        && (r.is_nan() || r <= 0.0)
    {
        return Err(value_error(format!(
            "ratio {r} is not a positive number (None keeps every match)"
        )));
    }
    let (sa, sb) = (&a.set, &b.set);
    let all = py
        .detach(|| fd_match::match_sets(sa, sb, method))
        .map_err(from_fd)?;
    let kept: Vec<_> = all
        .into_iter()
        .filter(|m| ratio.is_none_or(|r| m.accepted(r)))
        .collect();
    let d = PyDict::new(py);
    let col = |f: &dyn Fn(&fd_match::Match) -> f64| -> Vec<f64> { kept.iter().map(f).collect() };
    let idx =
        |f: &dyn Fn(&fd_match::Match) -> usize| -> Vec<usize> { kept.iter().map(f).collect() };
    d.set_item("query", PyArray1::from_vec(py, idx(&|m| m.query)))?;
    d.set_item("target", PyArray1::from_vec(py, idx(&|m| m.target)))?;
    d.set_item(
        "query_contour",
        PyArray1::from_vec(py, idx(&|m| sa.source(m.query))),
    )?;
    d.set_item(
        "target_contour",
        PyArray1::from_vec(py, idx(&|m| sb.source(m.target))),
    )?;
    d.set_item("error", PyArray1::from_vec(py, col(&|m| m.error)))?;
    d.set_item("ratio", PyArray1::from_vec(py, col(&|m| m.ratio)))?;
    d.set_item(
        "rotation",
        PyArray1::from_vec(py, col(&|m| m.alignment.map_or(f64::NAN, |a| a.rotation))),
    )?;
    d.set_item(
        "shift",
        PyArray1::from_vec(py, col(&|m| m.alignment.map_or(f64::NAN, |a| a.shift))),
    )?;
    Ok(d)
}
