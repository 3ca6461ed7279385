//! `visguide.mser`: region detection on 2-D `uint8` arrays.

use numpy::{PyArray2, PyArrayMethods, PyReadonlyArray2};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::errors::{from_mser, value_error};
use crate::image::image_pixels;

/// One maximally stable extremal region.
///
/// Coordinates are pixel centres, 0-based, x to the right and y down. ``ellipse`` is the
/// Oxford ``(u, v, a, b, c)`` with ``a(x-u)^2 + 2b(x-u)(y-v) + c(y-v)^2 = 1`` and about the
/// region's area; ``pixels`` and ``contour`` are ``(N, 2)`` ``int32`` arrays of ``(x, y)``
/// when requested from :func:`visguide.mser.detect`, else ``None``.
#[pyclass(frozen, module = "visguide.mser", name = "Region")]
pub struct PyRegion {
    r: mser::Region,
    /// Region pixels `(x, y)` in raster order, when requested.
    #[pyo3(get)]
    pixels: Option<Py<PyArray2<i32>>>,
    /// Outer contour `(x, y)` (closed, counter-clockwise on screen, from the seed), when
    /// requested.
    #[pyo3(get)]
    contour: Option<Py<PyArray2<i32>>>,
}

#[pymethods]
impl PyRegion {
    /// ``"dark"`` (darker than its surround) or ``"bright"``.
    #[getter]
    fn polarity(&self) -> &'static str {
        polarity_name(self.r.polarity)
    }

    /// Grey level at which the region exists (its darkest pixel for bright regions, its
    /// brightest for dark ones).
    #[getter]
    fn level(&self) -> u8 {
        self.r.level
    }

    /// First pixel in raster order, ``(x, y)``.
    #[getter]
    fn seed(&self) -> (u32, u32) {
        self.r.seed
    }

    /// Number of pixels.
    #[getter]
    fn area(&self) -> u32 {
        self.r.area
    }

    /// Area variation ``v`` of the stability test.
    #[getter]
    fn variation(&self) -> f64 {
        self.r.variation
    }

    /// Inclusive bounding box ``(x_min, y_min, x_max, y_max)``.
    #[getter]
    fn bbox(&self) -> (u32, u32, u32, u32) {
        let b = self.r.bbox;
        (b.x_min, b.y_min, b.x_max, b.y_max)
    }

    /// Centroid ``(x, y)``.
    #[getter]
    fn centroid(&self) -> (f64, f64) {
        self.r.centroid()
    }

    /// Raw integer moments ``(n, Σx, Σy, Σx², Σxy, Σy²)`` over pixel centres.
    #[getter]
    fn moments(&self) -> (u64, u64, u64, u64, u64, u64) {
        let m = self.r.moments;
        (m.n, m.sx, m.sy, m.sxx, m.sxy, m.syy)
    }

    /// Oxford ellipse ``(u, v, a, b, c)`` with about the region's area.
    #[getter]
    fn ellipse(&self) -> PyResult<(f64, f64, f64, f64, f64)> {
        let e = self.r.ellipse().map_err(|e| value_error(e.to_string()))?;
        Ok((e.u, e.v, e.a, e.b, e.c))
    }

    /// The ellipse with semi-axes ``k`` standard deviations (``k = 1``: VLFeat's frames; the
    /// ``ellipse`` attribute is ``k = 2``).
    fn ellipse_scaled(&self, k: f64) -> PyResult<(f64, f64, f64, f64, f64)> {
        let e = self
            .r
            .ellipse_scaled(k)
            .map_err(|e| value_error(e.to_string()))?;
        Ok((e.u, e.v, e.a, e.b, e.c))
    }

    fn __repr__(&self) -> String {
        let (x, y) = self.r.seed;
        format!(
            "Region(polarity='{}', level={}, seed=({x}, {y}), area={})",
            polarity_name(self.r.polarity),
            self.r.level,
            self.r.area
        )
    }
}

fn polarity_name(p: mser::Polarity) -> &'static str {
    match p {
        mser::Polarity::Dark => "dark",
        mser::Polarity::Bright => "bright",
    }
}

fn parse_polarities(s: &str) -> PyResult<mser::Polarities> {
    match s {
        "both" => Ok(mser::Polarities::Both),
        "dark" => Ok(mser::Polarities::Dark),
        "bright" => Ok(mser::Polarities::Bright),
        _ => Err(value_error(format!(
            "polarities must be 'both', 'dark' or 'bright', not '{s}'"
        ))),
    }
}

fn parse_variation(s: &str) -> PyResult<mser::Variation> {
    match s {
        "symmetric" => Ok(mser::Variation::Symmetric),
        "upward" => Ok(mser::Variation::Upward),
        _ => Err(value_error(format!(
            "variation must be 'symmetric' or 'upward', not '{s}'"
        ))),
    }
}

fn preset(name: &str) -> PyResult<mser::MserParams> {
    match name {
        "opencv" => Ok(mser::MserParams::opencv()),
        "larsson2009" => Ok(mser::MserParams::larsson2009()),
        _ => Err(value_error(format!(
            "unknown preset '{name}' (known: 'opencv', 'larsson2009')"
        ))),
    }
}

/// A non-negative integer parameter.
fn count(name: &str, v: i64) -> PyResult<usize> {
    usize::try_from(v).map_err(|_| value_error(format!("{name} = {v} must be ≥ 0")))
}

/// The parameters of a preset as a dict (``max_area`` is ``None`` when unlimited).
#[pyfunction]
#[pyo3(name = "preset")]
pub fn preset_dict<'py>(py: Python<'py>, name: &str) -> PyResult<Bound<'py, PyDict>> {
    let p = preset(name)?;
    let d = PyDict::new(py);
    d.set_item("delta", p.delta)?;
    d.set_item("min_area", p.min_area)?;
    d.set_item("max_area", (p.max_area != usize::MAX).then_some(p.max_area))?;
    d.set_item("max_variation", p.max_variation)?;
    d.set_item("min_diversity", p.min_diversity)?;
    d.set_item(
        "polarities",
        match p.polarities {
            mser::Polarities::Both => "both",
            mser::Polarities::Dark => "dark",
            mser::Polarities::Bright => "bright",
        },
    )?;
    d.set_item(
        "variation",
        match p.variation {
            mser::Variation::Symmetric => "symmetric",
            mser::Variation::Upward => "upward",
        },
    )?;
    Ok(d)
}

/// `(x, y)` points as an `(N, 2)` `int32` array, shifted by `off` in both coordinates.
fn points<'py>(py: Python<'py>, pts: &[(u32, u32)], off: u32) -> PyResult<Py<PyArray2<i32>>> {
    let mut flat = Vec::with_capacity(pts.len() * 2);
    // Within `i32`: a point lies in the image, and `mser::GrayView` refuses images of more
    // than 2^28 (padded) pixels, so `x, y + off < 2^28 + 1`.
    for &(x, y) in pts {
        flat.push((x + off) as i32);
        flat.push((y + off) as i32);
    }
    let arr = numpy::PyArray1::from_vec(py, flat).reshape([pts.len(), 2])?;
    Ok(arr.unbind())
}

/// The parameters: `preset`, then the keyword arguments that name a parameter (`caller` names
/// the function in the `TypeError` for any other keyword).
pub(crate) fn params_from(
    caller: &str,
    preset: &str,
    kw: Option<&Bound<'_, PyDict>>,
) -> PyResult<mser::MserParams> {
    let mut p = self::preset(preset)?;
    let Some(kw) = kw else {
        return Ok(p);
    };
    for (k, v) in kw.iter() {
        let key: String = k.extract()?;
        match key.as_str() {
            "delta" => {
                let d: i64 = v.extract()?;
                p.delta = u8::try_from(d)
                    .map_err(|_| value_error(format!("delta = {d} must be in 1..=255")))?;
            }
            "min_area" => p.min_area = count("min_area", v.extract()?)?,
            "max_area" => {
                p.max_area = match v.extract::<Option<i64>>()? {
                    None => usize::MAX,
                    Some(a) => count("max_area", a)?,
                }
            }
            "max_variation" => p.max_variation = v.extract()?,
            "min_diversity" => p.min_diversity = v.extract()?,
            "polarities" => p.polarities = parse_polarities(&v.extract::<String>()?)?,
            "variation" => p.variation = parse_variation(&v.extract::<String>()?)?,
            _ => {
                return Err(pyo3::exceptions::PyTypeError::new_err(format!(
                    "{caller}() got an unexpected keyword argument '{key}'"
                )));
            }
        }
    }
    p.validate().map_err(from_mser)?;
    Ok(p)
}

/// Detects maximally stable extremal regions in a 2-D ``uint8`` image (any strides; rows with
/// unit column stride are read in place, other layouts through a packed copy).
///
/// Parameters start from ``preset`` (``"opencv"``: OpenCV's ``MSER_create()`` defaults;
/// ``"larsson2009"``: the thesis setting, Δ = 15 and ``min_area`` = 50) and keywords override
/// them: ``delta``, ``min_area``, ``max_area`` (``None``: unlimited), ``max_variation``,
/// ``min_diversity``, ``polarities`` (``"both"``, ``"dark"``, ``"bright"``) and ``variation``
/// (``"symmetric"``, ``"upward"``); :func:`preset` lists a preset's values. ``pixels`` /
/// ``contours`` fill the regions' ``pixels`` / ``contour`` arrays.
///
/// ``opencv_compatible=True`` does what OpenCV 4.x's ``MSER.detectRegions`` does on grey images:
/// the outermost pixel ring is never part of a region and ``min_diversity`` is ignored (0), so
/// the regions' pixel sets equal OpenCV's with the same parameters. Dark regions alone do not
/// exist in OpenCV; ``polarities="dark"`` is refused in that mode.
///
/// The GIL is released during detection: do not write to the array from another thread
/// meanwhile.
///
/// Raises ``TypeError`` for anything but a 2-D ``uint8`` array or an unknown keyword, and
/// ``ValueError`` for an empty image or invalid parameters.
#[pyfunction]
#[pyo3(signature = (image, *, preset = "opencv", pixels = false, contours = false, opencv_compatible = false, **params))]
pub fn detect(
    py: Python<'_>,
    image: PyReadonlyArray2<'_, u8>,
    preset: &str,
    pixels: bool,
    contours: bool,
    opencv_compatible: bool,
    params: Option<&Bound<'_, PyDict>>,
) -> PyResult<Vec<PyRegion>> {
    let mut p = params_from("detect", preset, params)?;
    if opencv_compatible {
        if p.polarities == mser::Polarities::Dark {
            return Err(value_error(
                "opencv_compatible: OpenCV cannot detect dark regions alone",
            ));
        }
        p.min_diversity = 0.0;
    }
    let view = image.as_array();
    let (px, w, h) = image_pixels(&view)?;
    let full = px.view(w, h).map_err(from_mser)?;
    // OpenCV 4.x floods only the inner (w-2)x(h-2) pixels.
    let (img, off) = if opencv_compatible {
        if w < 3 || h < 3 {
            return Ok(Vec::new());
        }
        (full.window(1, 1, w - 2, h - 2).map_err(from_mser)?, 1)
    } else {
        (full, 0)
    };
    type Found = (
        mser::Region,
        Option<Vec<(u32, u32)>>,
        Option<Vec<(u32, u32)>>,
    );
    let found: Vec<Found> = py
        .detach(|| -> mser::Result<Vec<Found>> {
            let regions = mser::detect(&img, &p)?;
            regions
                .into_iter()
                .map(|r| {
                    let pix = pixels.then(|| r.pixels(&img)).transpose()?;
                    let con = contours.then(|| r.contour(&img)).transpose()?;
                    Ok((r, pix, con))
                })
                .collect()
        })
        .map_err(from_mser)?;
    found
        .into_iter()
        .map(|(r, pix, con)| {
            Ok(PyRegion {
                // Detected on the image without its outer pixel ring: in full-image
                // coordinates.
                r: if off == 0 {
                    r
                } else {
                    r.translated(off, off).map_err(from_mser)?
                },
                pixels: pix.map(|v| points(py, &v, off)).transpose()?,
                contour: con.map(|v| points(py, &v, off)).transpose()?,
            })
        })
        .collect()
}
