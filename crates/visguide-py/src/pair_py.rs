//! `visguide.fd.match_images`: the `visguide` crate's image-pair pipeline (regions → contour
//! descriptors → symmetric matches with the ratio test → rotations, local affine maps and a
//! RANSAC homography) on two images given as arrays or files.

use numpy::ndarray::{Array2, Array3};
use numpy::{IntoPyArray, PyArray1, PyReadonlyArray2};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use visguide::{Combination, MatchSettings, RansacConfig, RegionMatch};

use crate::errors::{from_visguide, value_error};
use crate::fd_py::{parse_method, parse_sampling};
use crate::image::image_pixels;
use crate::mser_py::params_from;

/// An image argument: a 2-D `uint8` array (any strides, copied once) or a file path.
fn gray_of(arg: &Bound<'_, PyAny>) -> PyResult<image::GrayImage> {
    if let Ok(arr) = arg.extract::<PyReadonlyArray2<'_, u8>>() {
        let view = arr.as_array();
        let (px, w, h) = image_pixels(&view)?;
        let mut out = Vec::with_capacity(w * h);
        match px {
            crate::image::Pixels::Borrowed { data, stride } => {
                for y in 0..h {
                    out.extend_from_slice(&data[y * stride..y * stride + w]);
                }
            }
            crate::image::Pixels::Copied(v) => out = v,
        }
        let (w, h) = (
            u32::try_from(w).map_err(|_| value_error("image too wide"))?,
            u32::try_from(h).map_err(|_| value_error("image too high"))?,
        );
        return image::GrayImage::from_raw(w, h, out).ok_or_else(|| value_error("image size"));
    }
    if let Ok(path) = arg.extract::<std::path::PathBuf>() {
        return visguide::load_gray(path).map_err(from_visguide);
    }
    Err(pyo3::exceptions::PyTypeError::new_err(
        "an image must be a 2-D uint8 array or a file path",
    ))
}

/// `[i, j, error, ratio]` columns of matches as a dict of arrays.
fn matches_dict<'py>(py: Python<'py>, ms: &[RegionMatch]) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item(
        "i",
        PyArray1::from_vec(py, ms.iter().map(|m| m.i).collect()),
    )?;
    d.set_item(
        "j",
        PyArray1::from_vec(py, ms.iter().map(|m| m.j).collect()),
    )?;
    d.set_item(
        "error",
        PyArray1::from_vec(py, ms.iter().map(|m| m.error).collect()),
    )?;
    d.set_item(
        "ratio",
        PyArray1::from_vec(py, ms.iter().map(|m| m.ratio).collect()),
    )?;
    Ok(d)
}

/// The frames `(u, v, a, b, c)` of one image's regions as an `(N, 5)` array.
fn frames_array<'py>(py: Python<'py>, f: &visguide::Features) -> Bound<'py, numpy::PyArray2<f64>> {
    Array2::from_shape_fn((f.frames.len(), 5), |(k, c)| {
        let e = &f.frames[k];
        [e.u, e.v, e.a, e.b, e.c][c]
    })
    .into_pyarray(py)
}

/// Matches the regions of two images and fits a homography, as the ``visguide`` crate's
/// ``match_images`` (and the ``visguide match`` command) does; the results are identical to it.
///
/// ``image1`` / ``image2``: 2-D ``uint8`` arrays (any strides) or image files (PNG, PGM, PPM;
/// colour is converted to grey with BT.601 weights). Regions: MSER with ``preset``
/// (``"larsson2009"``, Paper A's setting, or ``"opencv"``) and keyword overrides as in
/// :func:`visguide.mser.detect` (``delta``, ``min_area``, ...), the same for both images.
/// Descriptors and matching: ``sampling`` and ``method`` as in :func:`describe` /
/// :func:`match`; ``preselection`` the threshold of eq. 18 (``None``: none); a match is
/// accepted when its ratio is below ``ratio``. With ``homography=True`` a homography is fitted
/// to the accepted matches' centres by seeded RANSAC (``ransac_threshold`` px,
/// ``ransac_iterations``, ``ransac_confidence``, ``ransac_seed``) when there are at least 4.
///
/// Returns a dict: ``frames1`` / ``frames2`` (``(N, 5)`` region ellipses ``(u, v, a, b, c)``,
/// indexed by region), ``described`` (descriptors per image), ``all`` (every symmetric match
/// before the ratio test: arrays ``i``, ``j``, ``error``, ``ratio``), ``accepted`` (the same
/// arrays for the accepted matches plus ``rotation``, radians, and ``affine``, ``(K, 2, 2)``
/// local affine maps of the frames; NaN where not measurable), and ``homography`` (``None``,
/// or a dict with ``H`` (3×3, image 1 → image 2), ``inliers`` (bool per accepted match),
/// ``inlier_count``, ``rms`` (px) and ``iterations``).
///
/// The GIL is released while the two images are processed. ``OSError`` for image files that
/// cannot be read, ``TypeError`` for other image arguments or unknown keywords, ``ValueError``
/// for invalid settings.
#[pyfunction]
#[pyo3(signature = (
    image1, image2, *, preset = "larsson2009", sampling = "affine", method = "fd_corr",
    ratio = 0.5, preselection = None, homography = true, ransac_threshold = 3.0,
    ransac_iterations = 5000, ransac_confidence = 0.999, ransac_seed = 0, **params
))]
#[allow(clippy::too_many_arguments)]
pub fn match_images<'py>(
    py: Python<'py>,
    image1: &Bound<'py, PyAny>,
    image2: &Bound<'py, PyAny>,
    preset: &str,
    sampling: &str,
    method: &str,
    ratio: f64,
    preselection: Option<f64>,
    homography: bool,
    ransac_threshold: f64,
    ransac_iterations: usize,
    ransac_confidence: f64,
    ransac_seed: u64,
    params: Option<&Bound<'py, PyDict>>,
) -> PyResult<Bound<'py, PyDict>> {
    let p = params_from("match_images", preset, params)?;
    let settings = MatchSettings {
        mser: (p.clone(), p),
        combination: Combination::new(parse_method(method)?, parse_sampling(sampling)?),
        ratio_threshold: ratio,
        preselection,
        ransac: homography.then_some(RansacConfig {
            threshold: ransac_threshold,
            max_iterations: ransac_iterations,
            confidence: ransac_confidence,
            seed: ransac_seed,
        }),
    };
    // The crate's one check of `ratio`, `preselection` and the RANSAC keywords, before any
    // work (a ValueError naming the setting).
    settings.validate().map_err(from_visguide)?;
    let (img1, img2) = (gray_of(image1)?, gray_of(image2)?);
    let pair = py
        .detach(|| visguide::match_images(&img1, &img2, &settings))
        .map_err(from_visguide)?;
    let d = PyDict::new(py);
    d.set_item("frames1", frames_array(py, &pair.features1))?;
    d.set_item("frames2", frames_array(py, &pair.features2))?;
    d.set_item("described", pair.described)?;
    d.set_item("all", matches_dict(py, &pair.all)?)?;
    let acc: Vec<RegionMatch> = pair.accepted.iter().map(|g| g.m).collect();
    let a = matches_dict(py, &acc)?;
    a.set_item(
        "rotation",
        PyArray1::from_vec(
            py,
            pair.accepted
                .iter()
                .map(|g| g.rotation.unwrap_or(f64::NAN))
                .collect(),
        ),
    )?;
    let affine = Array3::from_shape_fn((pair.accepted.len(), 2, 2), |(k, r, c)| {
        pair.accepted[k].local.map_or(f64::NAN, |l| l.a[(r, c)])
    });
    a.set_item("affine", affine.into_pyarray(py))?;
    d.set_item("accepted", a)?;
    match &pair.homography {
        None => d.set_item("homography", py.None())?,
        Some(fit) => {
            let h = PyDict::new(py);
            let m = fit.homography.to_row_major();
            h.set_item(
                "H",
                Array2::from_shape_fn((3, 3), |(r, c)| m[3 * r + c]).into_pyarray(py),
            )?;
            h.set_item("inliers", PyArray1::from_vec(py, fit.inliers.clone()))?;
            h.set_item("inlier_count", fit.inlier_count)?;
            h.set_item("rms", fit.rms)?;
            h.set_item("iterations", fit.iterations)?;
            d.set_item("homography", h)?;
        }
    }
    Ok(d)
}
