//! `visguide.lwpr.LWPR`: the `lwpr` crate's model with the reference Python module's vocabulary.

use lwpr::{Arithmetic, Kernel, Lwpr, LwprBuilder, Params, PruneRule};
use numpy::ndarray::Array2;
use numpy::{AllowTypeChange, IntoPyArray, PyArray1, PyArray2, PyArrayLike1, PyArrayLike2};
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyTuple, PyType};

use crate::errors::{from_lwpr, from_lwpr_file, value_error};

/// Locally Weighted Projection Regression (Vijayakumar et al. 2005), trained online.
///
/// ``LWPR(n_in, n_out)`` starts a model with the reference library's defaults;
/// ``LWPR(filename)`` loads one written by :meth:`save` or an XML model file (:meth:`write_XML`,
/// or the reference library's), like the reference module's constructor. The meta-parameters are attributes with
/// the reference module's names (``init_D``, ``init_alpha``, ``w_gen``, ``diag_only``,
/// ``update_D``, ``meta``, ``kernel``, ...); setting one is validated (``ValueError``, model
/// unchanged) and applies to the rest of training. ``update`` with a NaN or infinite value, or a
/// wrong length, raises ``ValueError`` and leaves the model unchanged. Models pickle, compare
/// with ``==`` (every learned number bit for bit) and train exactly as the Rust crate does.
#[pyclass(module = "visguide.lwpr", name = "LWPR")]
pub struct PyLwpr {
    model: Lwpr,
}

type Vec1<'py> = PyArrayLike1<'py, f64, AllowTypeChange>;
type Mat2<'py> = PyArrayLike2<'py, f64, AllowTypeChange>;
type Arr1<'py> = Bound<'py, PyArray1<f64>>;
type Arr2<'py> = Bound<'py, PyArray2<f64>>;

/// A vector argument's values (any layout; non-float dtypes are converted).
fn vec_of(a: &Vec1<'_>) -> Vec<f64> {
    a.as_array().iter().copied().collect()
}

/// An `n × n` column-major matrix as a NumPy array.
fn square<'py>(py: Python<'py>, n: usize, v: &[f64]) -> Bound<'py, PyArray2<f64>> {
    Array2::from_shape_fn((n, n), |(i, j)| v[i + j * n]).into_pyarray(py)
}

/// An `n × n` NumPy array as a column-major matrix.
fn square_of(name: &str, n: usize, a: &Mat2<'_>) -> PyResult<Vec<f64>> {
    let a = a.as_array();
    if a.dim() != (n, n) {
        return Err(value_error(format!(
            "{name} must be {n}x{n}, got {}x{}",
            a.dim().0,
            a.dim().1
        )));
    }
    let mut v = vec![0.0; n * n];
    for ((i, j), x) in a.indexed_iter() {
        v[i + j * n] = *x;
    }
    Ok(v)
}

/// Rows of a `(k, d)` array, row after row, checking `d`.
fn rows_of(name: &str, d: usize, a: &Mat2<'_>) -> PyResult<(usize, Vec<f64>)> {
    let a = a.as_array();
    if a.ncols() != d {
        return Err(value_error(format!(
            "{name} must have {d} columns, got {}",
            a.ncols()
        )));
    }
    Ok((a.nrows(), a.iter().copied().collect()))
}

impl PyLwpr {
    /// Replaces the parameters, keeping everything learned. Validates first: on error nothing
    /// changes.
    fn set_params(&mut self, change: impl FnOnce(&mut Params)) -> PyResult<()> {
        let mut p = self.model.params().clone();
        change(&mut p);
        p.validate().map_err(from_lwpr)?;
        let model = if self.model.n_data() == 0 {
            LwprBuilder::from_params(p).build()
        } else {
            // The learned state goes through the crate's own validated format.
            let mut v: serde_json::Value = serde_json::from_str(&self.model.to_json())
                .map_err(|e| value_error(e.to_string()))?;
            v["model"]["params"] =
                serde_json::to_value(&p).map_err(|e| value_error(e.to_string()))?;
            Lwpr::from_json(&v.to_string())
        }
        .map_err(from_lwpr)?;
        self.model = model;
        Ok(())
    }

    fn n(&self) -> usize {
        self.model.n_in()
    }
}

#[pymethods]
impl PyLwpr {
    #[new]
    #[pyo3(signature = (n_in, n_out = None))]
    fn new(n_in: &Bound<'_, PyAny>, n_out: Option<usize>) -> PyResult<Self> {
        if let Ok(path) = n_in.extract::<std::path::PathBuf>()
            && !n_in.is_instance_of::<pyo3::types::PyInt>()
        {
            if n_out.is_some() {
                return Err(value_error("LWPR(filename) takes no n_out"));
            }
            return Ok(PyLwpr {
                model: Lwpr::load(&path).map_err(|e| from_lwpr_file(&path, e))?,
            });
        }
        let n_in: usize = n_in.extract()?;
        let n_out = n_out.ok_or_else(|| value_error("LWPR(n_in, n_out) needs n_out"))?;
        Ok(PyLwpr {
            model: LwprBuilder::new(n_in, n_out).build().map_err(from_lwpr)?,
        })
    }

    /// Trains on one sample ``(x, y)`` and returns the prediction made while learning.
    fn update<'py>(
        &mut self,
        py: Python<'py>,
        x: Vec1<'py>,
        y: Vec1<'py>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let yp = self
            .model
            .update(&vec_of(&x), &vec_of(&y))
            .map_err(from_lwpr)?;
        Ok(PyArray1::from_vec(py, yp))
    }

    /// Trains on the rows of ``X`` (``(k, n_in)``) and ``Y`` (``(k, n_out)``) in order, exactly
    /// as ``k`` calls of :meth:`update`, without the GIL. Every sample is checked first: on
    /// ``ValueError`` naming the row (wrong shape, NaN, infinity, or a value beyond LWPR's bound
    /// of 1e30, raw or normalised: what :meth:`update` refuses) the model is unchanged. Returns
    /// the ``(k, n_out)`` predictions made while learning.
    fn update_batch<'py>(
        &mut self,
        py: Python<'py>,
        x: Mat2<'py>,
        y: Mat2<'py>,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let (n, m) = (self.model.n_in(), self.model.n_out());
        let (k, xs) = rows_of("X", n, &x)?;
        let (ky, ys) = rows_of("Y", m, &y)?;
        if k != ky {
            return Err(value_error(format!("X has {k} rows, Y has {ky}")));
        }
        // Every row as `update` checks it (finite, within LWPR's bound raw and normalised),
        // before any row is learned: a row it would refuse in the middle of the batch used to
        // be refused after the rows before it were learned.
        for (row, (xr, yr)) in xs.chunks_exact(n).zip(ys.chunks_exact(m)).enumerate() {
            self.model
                .check_sample(xr, yr)
                .map_err(|e| value_error(format!("row {row}: {e}")))?;
        }
        let model = &mut self.model;
        let out = py
            .detach(|| -> lwpr::Result<Vec<f64>> {
                let mut out = vec![0.0; k * m];
                for ((xr, yr), o) in xs
                    .chunks_exact(n)
                    .zip(ys.chunks_exact(m))
                    .zip(out.chunks_exact_mut(m))
                {
                    model.update_into(xr, yr, o)?;
                }
                Ok(out)
            })
            .map_err(from_lwpr)?;
        Ok(Array2::from_shape_vec((k, m), out)
            .expect("k * m values")
            .into_pyarray(py))
    }

    /// Prediction ``y`` at ``x``; receptive fields with activation ≤ ``cutoff`` are ignored.
    #[pyo3(signature = (x, cutoff = 0.0))]
    fn predict<'py>(
        &self,
        py: Python<'py>,
        x: Vec1<'py>,
        cutoff: f64,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let y = self.model.predict(&vec_of(&x), cutoff).map_err(from_lwpr)?;
        Ok(PyArray1::from_vec(py, y))
    }

    /// Predictions for the rows of ``X`` (``(k, n_in)`` → ``(k, n_out)``), in parallel without
    /// the GIL; equal to :meth:`predict` row by row.
    #[pyo3(signature = (x, cutoff = 0.0))]
    fn predict_batch<'py>(
        &self,
        py: Python<'py>,
        x: Mat2<'py>,
        cutoff: f64,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let (k, xs) = rows_of("X", self.n(), &x)?;
        let model = &self.model;
        let y = py
            .detach(|| model.predict_batch(&xs, cutoff))
            .map_err(from_lwpr)?;
        Ok(Array2::from_shape_vec((k, model.n_out()), y)
            .expect("k * n_out values")
            .into_pyarray(py))
    }

    /// ``(y, conf)``: the prediction and the reference's confidence bounds (infinite where no
    /// trustworthy receptive field is active).
    #[pyo3(signature = (x, cutoff = 0.0))]
    fn predict_conf<'py>(
        &self,
        py: Python<'py>,
        x: Vec1<'py>,
        cutoff: f64,
    ) -> PyResult<(Arr1<'py>, Arr1<'py>)> {
        let p = self
            .model
            .predict_with_confidence(&vec_of(&x), cutoff)
            .map_err(from_lwpr)?;
        Ok((
            PyArray1::from_vec(py, p.y),
            PyArray1::from_vec(py, p.confidence),
        ))
    }

    /// ``(y, J)``: the prediction and its Jacobian ``∂y/∂x`` (``(n_out, n_in)``).
    #[pyo3(signature = (x, cutoff = 0.0))]
    #[pyo3(name = "predict_J")]
    fn predict_j<'py>(
        &self,
        py: Python<'py>,
        x: Vec1<'py>,
        cutoff: f64,
    ) -> PyResult<(Arr1<'py>, Arr2<'py>)> {
        let p = self
            .model
            .predict_with_jacobian(&vec_of(&x), cutoff)
            .map_err(from_lwpr)?;
        let (m, n) = p.jacobian.shape();
        let j = Array2::from_shape_fn((m, n), |(i, k)| p.jacobian[(i, k)]);
        Ok((PyArray1::from_vec(py, p.y), j.into_pyarray(py)))
    }

    /// Centre of receptive field ``n`` of output ``dim`` (input units).
    fn rf_center<'py>(
        &self,
        py: Python<'py>,
        dim: usize,
        n: usize,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let rfs = self.model.receptive_fields(dim);
        let rf = rfs
            .get(n)
            .ok_or_else(|| value_error(format!("no receptive field ({dim}, {n})")))?;
        Ok(PyArray1::from_vec(py, rf.centre()))
    }

    /// Distance metric ``D`` of receptive field ``n`` of output ``dim`` (normalised units).
    #[pyo3(name = "rf_D")]
    fn rf_d<'py>(
        &self,
        py: Python<'py>,
        dim: usize,
        n: usize,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let rfs = self.model.receptive_fields(dim);
        let rf = rfs
            .get(n)
            .ok_or_else(|| value_error(format!("no receptive field ({dim}, {n})")))?;
        Ok(square(py, self.n(), rf.metric()))
    }

    /// Writes the model: the crate's binary form if ``path`` ends in ``.bin``, JSON otherwise.
    /// ``OSError`` if the file cannot be written.
    fn save(&self, path: std::path::PathBuf) -> PyResult<()> {
        // The crate's write errors name the file themselves.
        self.model.save(&path).map_err(from_lwpr)
    }

    /// Reads a model written by :meth:`save` (``OSError`` for a missing file, ``ValueError``
    /// for a corrupt one).
    #[classmethod]
    fn load(_cls: &Bound<'_, PyType>, path: std::path::PathBuf) -> PyResult<Self> {
        Ok(PyLwpr {
            model: Lwpr::load(&path).map_err(|e| from_lwpr_file(&path, e))?,
        })
    }

    /// Writes the model as an XML model file of the reference LWPR library (its Python module's
    /// ``write_XML``): the reference's layout with every number exact, so ``LWPR.read_XML``
    /// gives back the identical model and the reference library reads it (``lwpr_read_xml``,
    /// its ``LWPR(filename)``). ``OSError`` if the file cannot be written (nothing is left
    /// behind).
    #[pyo3(name = "write_XML")]
    fn write_xml(&self, filename: std::path::PathBuf) -> PyResult<()> {
        self.model.save_xml(&filename).map_err(from_lwpr)
    }

    /// Reads an XML model file: one written by :meth:`write_XML` or by the reference library
    /// (its ``write_XML`` / ``lwpr_write_xml``; six decimals, so such a model predicts what the
    /// reference predicts from the same file). ``OSError`` for a missing file, ``ValueError``
    /// for a malformed, truncated or inconsistent one. ``LWPR(filename)`` reads XML files too.
    #[classmethod]
    #[pyo3(name = "read_XML")]
    fn read_xml(_cls: &Bound<'_, PyType>, filename: std::path::PathBuf) -> PyResult<Self> {
        Ok(PyLwpr {
            model: Lwpr::load_xml(&filename).map_err(|e| from_lwpr_file(&filename, e))?,
        })
    }

    /// The model as the text of an XML model file (see :meth:`write_XML`).
    fn to_xml(&self) -> String {
        self.model.to_xml()
    }

    /// A model from the text of an XML model file (``ValueError`` if malformed).
    #[classmethod]
    fn from_xml(_cls: &Bound<'_, PyType>, text: &str) -> PyResult<Self> {
        Ok(PyLwpr {
            model: Lwpr::from_xml(text).map_err(from_lwpr)?,
        })
    }

    /// The model in the crate's binary form (checksummed).
    fn to_bytes<'py>(&self, py: Python<'py>) -> Bound<'py, PyBytes> {
        PyBytes::new(py, &self.model.to_binary())
    }

    /// A model from :meth:`to_bytes` (``ValueError`` if corrupt).
    #[classmethod]
    fn from_bytes(_cls: &Bound<'_, PyType>, data: &[u8]) -> PyResult<Self> {
        Ok(PyLwpr {
            model: Lwpr::from_binary(data).map_err(from_lwpr)?,
        })
    }

    fn __reduce__<'py>(
        slf: &Bound<'py, Self>,
    ) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyTuple>)> {
        let py = slf.py();
        let from_bytes = slf.get_type().getattr("from_bytes")?;
        // `try_borrow`: while `update_batch` trains without the GIL it holds the model, and a
        // pickle from another thread then is a `RuntimeError`, as any other call (`borrow`
        // panicked: `PanicException`).
        let bytes = slf.try_borrow()?.to_bytes(py);
        Ok((from_bytes, PyTuple::new(py, [bytes])?))
    }

    fn __eq__(&self, other: &Self) -> bool {
        self.model == other.model
    }

    fn __repr__(&self) -> String {
        format!(
            "LWPR(n_in={}, n_out={}, n_data={}, num_rfs={:?})",
            self.model.n_in(),
            self.model.n_out(),
            self.model.n_data(),
            self.model.num_rfs()
        )
    }

    /// Input dimension.
    #[getter(nIn)]
    fn n_in_attr(&self) -> usize {
        self.model.n_in()
    }

    /// Output dimension.
    #[getter(nOut)]
    fn n_out_attr(&self) -> usize {
        self.model.n_out()
    }

    /// Number of training samples seen.
    #[getter]
    fn n_data(&self) -> u64 {
        self.model.n_data()
    }

    /// Receptive fields per output.
    #[getter]
    fn num_rfs(&self) -> Vec<usize> {
        self.model.num_rfs()
    }

    /// Receptive fields pruned so far, per output.
    #[getter]
    fn n_pruned(&self) -> Vec<usize> {
        self.model.num_pruned()
    }

    /// Running mean of the training inputs.
    #[getter]
    fn mean_x<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_slice(py, self.model.mean_x())
    }

    /// Running variance of the training inputs.
    #[getter]
    fn var_x<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_slice(py, self.model.var_x())
    }

    /// Initial distance metric of new receptive fields (``n_in × n_in``, symmetric positive
    /// definite; diagonal when ``diag_only``).
    #[getter(init_D)]
    fn get_init_d<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        square(py, self.n(), &self.model.params().init_d)
    }

    #[setter(init_D)]
    fn set_init_d(&mut self, d: Mat2<'_>) -> PyResult<()> {
        let d = square_of("init_D", self.n(), &d)?;
        self.set_params(|p| p.init_d = d)
    }

    /// Upper-triangular Cholesky factor of ``init_D`` (read-only; set ``init_D``).
    #[getter(init_M)]
    fn init_m<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        square(py, self.n(), &self.model.params().init_m)
    }

    /// Initial learning rates of the metric (``n_in × n_in``, positive).
    #[getter]
    fn get_init_alpha<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        square(py, self.n(), &self.model.params().init_alpha)
    }

    #[setter]
    fn set_init_alpha(&mut self, a: Mat2<'_>) -> PyResult<()> {
        let a = square_of("init_alpha", self.n(), &a)?;
        self.set_params(|p| p.init_alpha = a)
    }

    /// Input normalisation (``n_in`` positive values).
    #[getter]
    fn get_norm_in<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_slice(py, &self.model.params().norm_in)
    }

    #[setter]
    fn set_norm_in(&mut self, v: Vec1<'_>) -> PyResult<()> {
        let v = vec_of(&v);
        self.set_params(|p| p.norm_in = v)
    }

    /// Output normalisation (``n_out`` positive values).
    #[getter]
    fn get_norm_out<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_slice(py, &self.model.params().norm_out)
    }

    #[setter]
    fn set_norm_out(&mut self, v: Vec1<'_>) -> PyResult<()> {
        let v = vec_of(&v);
        self.set_params(|p| p.norm_out = v)
    }

    /// ``"Gaussian"`` or ``"BiSquare"``.
    #[getter]
    fn get_kernel(&self) -> &'static str {
        match self.model.params().kernel {
            Kernel::Gaussian => "Gaussian",
            Kernel::BiSquare => "BiSquare",
        }
    }

    #[setter]
    fn set_kernel(&mut self, k: &str) -> PyResult<()> {
        let k = match k {
            "Gaussian" => Kernel::Gaussian,
            "BiSquare" => Kernel::BiSquare,
            _ => {
                return Err(value_error(format!(
                    "kernel must be 'Gaussian' or 'BiSquare', not '{k}'"
                )));
            }
        };
        self.set_params(|p| p.kernel = k)
    }

    /// ``"reference_c"`` (the C library's choice, the default) or ``"published"`` (remove the
    /// narrower field, as published).
    #[getter]
    fn get_prune_rule(&self) -> &'static str {
        match self.model.params().prune_rule {
            PruneRule::Published => "published",
            PruneRule::ReferenceC => "reference_c",
        }
    }

    #[setter]
    fn set_prune_rule(&mut self, r: &str) -> PyResult<()> {
        let r = match r {
            "published" => PruneRule::Published,
            "reference_c" => PruneRule::ReferenceC,
            _ => {
                return Err(value_error(format!(
                    "prune_rule must be 'published' or 'reference_c', not '{r}'"
                )));
            }
        };
        self.set_params(|p| p.prune_rule = r)
    }

    /// ``"fast"`` (default) or ``"reference"`` (bit-identical to the C library for every input
    /// dimension).
    #[getter]
    fn get_arithmetic(&self) -> &'static str {
        match self.model.params().arithmetic {
            Arithmetic::Fast => "fast",
            Arithmetic::Reference => "reference",
        }
    }

    #[setter]
    fn set_arithmetic(&mut self, a: &str) -> PyResult<()> {
        let a = match a {
            "fast" => Arithmetic::Fast,
            "reference" => Arithmetic::Reference,
            _ => {
                return Err(value_error(format!(
                    "arithmetic must be 'fast' or 'reference', not '{a}'"
                )));
            }
        };
        self.model.set_arithmetic(a);
        Ok(())
    }

    /// Create a receptive field when no activation exceeds this (0 < w_gen < 1).
    #[getter(w_gen)]
    fn get_w_gen(&self) -> f64 {
        self.model.params().w_gen
    }

    #[setter(w_gen)]
    fn set_w_gen(&mut self, v: f64) -> PyResult<()> {
        self.set_params(|p| p.w_gen = v)
    }

    /// Prune when the second-largest activation exceeds this.
    #[getter(w_prune)]
    fn get_w_prune(&self) -> f64 {
        self.model.params().w_prune
    }

    #[setter(w_prune)]
    fn set_w_prune(&mut self, v: f64) -> PyResult<()> {
        self.set_params(|p| p.w_prune = v)
    }

    /// Initial forgetting factor.
    #[getter(init_lambda)]
    fn get_init_lambda(&self) -> f64 {
        self.model.params().init_lambda
    }

    #[setter(init_lambda)]
    fn set_init_lambda(&mut self, v: f64) -> PyResult<()> {
        self.set_params(|p| p.init_lambda = v)
    }

    /// Final forgetting factor.
    #[getter(final_lambda)]
    fn get_final_lambda(&self) -> f64 {
        self.model.params().final_lambda
    }

    #[setter(final_lambda)]
    fn set_final_lambda(&mut self, v: f64) -> PyResult<()> {
        self.set_params(|p| p.final_lambda = v)
    }

    /// Annealing constant of the forgetting factor.
    #[getter(tau_lambda)]
    fn get_tau_lambda(&self) -> f64 {
        self.model.params().tau_lambda
    }

    #[setter(tau_lambda)]
    fn set_tau_lambda(&mut self, v: f64) -> PyResult<()> {
        self.set_params(|p| p.tau_lambda = v)
    }

    /// Initial PLS statistics ``SSs2``.
    #[getter(init_S2)]
    fn get_init_s2(&self) -> f64 {
        self.model.params().init_s2
    }

    #[setter(init_S2)]
    fn set_init_s2(&mut self, v: f64) -> PyResult<()> {
        self.set_params(|p| p.init_s2 = v)
    }

    /// Add a PLS direction when the error ratio falls below this.
    #[getter(add_threshold)]
    fn get_add_threshold(&self) -> f64 {
        self.model.params().add_threshold
    }

    #[setter(add_threshold)]
    fn set_add_threshold(&mut self, v: f64) -> PyResult<()> {
        self.set_params(|p| p.add_threshold = v)
    }

    /// Ridge penalty on the distance metric.
    #[getter(penalty)]
    fn get_penalty(&self) -> f64 {
        self.model.params().penalty
    }

    #[setter(penalty)]
    fn set_penalty(&mut self, v: f64) -> PyResult<()> {
        self.set_params(|p| p.penalty = v)
    }

    /// Meta learning rate.
    #[getter(meta_rate)]
    fn get_meta_rate(&self) -> f64 {
        self.model.params().meta_rate
    }

    #[setter(meta_rate)]
    fn set_meta_rate(&mut self, v: f64) -> PyResult<()> {
        self.set_params(|p| p.meta_rate = v)
    }

    /// Learn only the diagonal of ``D``.
    #[getter(diag_only)]
    fn get_diag_only(&self) -> bool {
        self.model.params().diag_only
    }

    #[setter(diag_only)]
    fn set_diag_only(&mut self, v: bool) -> PyResult<()> {
        self.set_params(|p| p.diag_only = v)
    }

    /// Learn the distance metric at all.
    #[getter(update_D)]
    fn get_update_d(&self) -> bool {
        self.model.params().update_d
    }

    #[setter(update_D)]
    fn set_update_d(&mut self, v: bool) -> PyResult<()> {
        self.set_params(|p| p.update_d = v)
    }

    /// Meta-learn the learning rates (IDBD).
    #[getter(meta)]
    fn get_meta(&self) -> bool {
        self.model.params().meta
    }

    #[setter(meta)]
    fn set_meta(&mut self, v: bool) -> PyResult<()> {
        self.set_params(|p| p.meta = v)
    }
}
