//! 2-D `uint8` NumPy arrays as [`mser::GrayView`]s: without a copy when rows are contiguous
//! (unit column stride, non-negative row stride), else through a packed copy.

use numpy::ndarray::ArrayView2;

use crate::errors::value_error;

/// Pixels of an image as the detector reads them: borrowed from the array or a packed copy.
pub enum Pixels<'a> {
    /// The array's own memory: `height` rows `stride` bytes apart.
    Borrowed {
        /// From the first pixel to the last one of the last row.
        data: &'a [u8],
        /// Row stride in bytes.
        stride: usize,
    },
    /// A packed copy (`stride == width`).
    Copied(Vec<u8>),
}

/// The pixels of `view` (any strides), `(width, height)`; errors for an empty image.
pub fn image_pixels<'a>(view: &ArrayView2<'a, u8>) -> pyo3::PyResult<(Pixels<'a>, usize, usize)> {
    let (h, w) = view.dim();
    if w == 0 || h == 0 {
        return Err(value_error(format!("empty image: {w}x{h}")));
    }
    let s = view.strides();
    if s[1] == 1 && s[0] >= w as isize {
        let stride = s[0] as usize;
        let len = stride * (h - 1) + w;
        // SAFETY: the array holds rows 0..h, each of w bytes, starting `stride` bytes apart
        // from its first element; the last byte read is element (h-1, w-1), at offset `len - 1`.
        // So the whole range lies inside the array's buffer, which lives as long as the view.
        let data = unsafe { std::slice::from_raw_parts(view.as_ptr(), len) };
        return Ok((Pixels::Borrowed { data, stride }, w, h));
    }
    let mut out = Vec::with_capacity(w * h);
    for row in view.rows() {
        out.extend(row.iter().copied());
    }
    Ok((Pixels::Copied(out), w, h))
}

impl Pixels<'_> {
    /// The detector's view of these pixels.
    pub fn view(&self, w: usize, h: usize) -> Result<mser::GrayView<'_>, mser::MserError> {
        match self {
            Pixels::Borrowed { data, stride } => mser::GrayView::new(data, w, h, *stride),
            Pixels::Copied(v) => mser::GrayView::packed(v, w, h),
        }
    }
}
