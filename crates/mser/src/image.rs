//! Borrowed 8-bit grey images and the conversions into them.

use crate::error::{MserError, Result};

/// A borrowed 8-bit grey image: `height` rows of `width` pixels, rows `stride` bytes apart.
///
/// Pixel `(x, y)` (x to the right, y down, 0-based) is `data[y * stride + x]`.
#[derive(Debug, Clone, Copy)]
pub struct GrayView<'a> {
    data: &'a [u8],
    width: usize,
    height: usize,
    stride: usize,
}

impl<'a> GrayView<'a> {
    /// Wraps a buffer, checking that it is non-empty and holds every row.
    ///
    /// ```
    /// let pixels = [0u8, 1, 2, 99, 3, 4, 5, 99];
    /// let img = mser::GrayView::new(&pixels, 3, 2, 4).unwrap();
    /// assert_eq!(img.get(2, 1), 5);
    /// assert!(mser::GrayView::new(&pixels, 3, 2, 2).is_err()); // stride < width
    /// ```
    pub fn new(data: &'a [u8], width: usize, height: usize, stride: usize) -> Result<Self> {
        if width == 0 || height == 0 {
            return Err(MserError::EmptyImage { width, height });
        }
        if stride < width {
            return Err(MserError::StrideTooSmall { stride, width });
        }
        let needed = stride
            .checked_mul(height - 1)
            .and_then(|n| n.checked_add(width))
            .ok_or(MserError::ImageTooLarge { width, height })?;
        if data.len() < needed {
            return Err(MserError::BufferTooSmall {
                got: data.len(),
                needed,
            });
        }
        // Padded size used by the detector (module `layout`): (height + 2) padded rows.
        let padded_w = crate::layout::padded_stride(width);
        let fits = padded_w
            .checked_mul(height + 2)
            .is_some_and(|n| n <= 1 << 28);
        if !fits {
            return Err(MserError::ImageTooLarge { width, height });
        }
        Ok(GrayView {
            data,
            width,
            height,
            stride,
        })
    }

    /// A tightly packed buffer (`stride == width`).
    pub fn packed(data: &'a [u8], width: usize, height: usize) -> Result<Self> {
        Self::new(data, width, height, width)
    }

    /// Views an [`image::GrayImage`].
    pub fn from_image(img: &'a image::GrayImage) -> Result<Self> {
        Self::packed(img.as_raw(), img.width() as usize, img.height() as usize)
    }

    /// The window of `width × height` pixels whose top-left pixel is `(x0, y0)` here, as a view
    /// of the same buffer (no copy): its pixel `(x, y)` is this view's `(x0 + x, y0 + y)`. A
    /// region detected on it is moved back with [`Region::translated`](crate::Region::translated).
    ///
    /// ```
    /// let pixels = [0u8, 1, 2, 3, 4, 5, 6, 7, 8];
    /// let img = mser::GrayView::packed(&pixels, 3, 3).unwrap();
    /// let w = img.window(1, 1, 2, 2).unwrap();
    /// assert_eq!((w.get(0, 0), w.get(1, 1)), (4, 8));
    /// assert!(img.window(2, 0, 2, 1).is_err()); // reaches past the right edge
    /// ```
    ///
    /// Errors: an empty window ([`MserError::EmptyImage`]) or one that does not lie inside this
    /// view ([`MserError::InvalidParameter`] `window`).
    pub fn window(&self, x0: usize, y0: usize, width: usize, height: usize) -> Result<Self> {
        // Checked first: an empty window may start one past the last column or row, where no
        // pixel (and maybe no byte of the buffer) is.
        if width == 0 || height == 0 {
            return Err(MserError::EmptyImage { width, height });
        }
        let inside = x0.checked_add(width).is_some_and(|x1| x1 <= self.width)
            && y0.checked_add(height).is_some_and(|y1| y1 <= self.height);
        if !inside {
            return Err(MserError::InvalidParameter {
                name: "window",
                reason: format!(
                    "{width}×{height} at ({x0}, {y0}) does not lie in a {}×{} image",
                    self.width, self.height
                ),
            });
        }
        // In the buffer: `inside` gives x0 < width and y0 < height, so the start is below
        // `stride * (height - 1) + width`, which `new` checked the buffer holds.
        Self::new(
            &self.data[y0 * self.stride + x0..],
            width,
            height,
            self.stride,
        )
    }

    /// Width in pixels.
    pub fn width(&self) -> usize {
        self.width
    }

    /// Height in pixels.
    pub fn height(&self) -> usize {
        self.height
    }

    /// Row stride in bytes.
    pub fn stride(&self) -> usize {
        self.stride
    }

    /// Row `y` (its `width` pixels). Panics if `y >= height`, like [`get`](Self::get) (the
    /// buffer may hold bytes past the last row, which are no part of the image).
    pub fn row(&self, y: usize) -> &'a [u8] {
        // Also keeps `y * stride` from overflowing: below `height`, it is within the buffer.
        assert!(y < self.height, "row {y} outside the image");
        &self.data[y * self.stride..y * self.stride + self.width]
    }

    /// Pixel `(x, y)`. Panics if outside the image.
    #[inline]
    pub fn get(&self, x: usize, y: usize) -> u8 {
        assert!(
            x < self.width && y < self.height,
            "pixel ({x}, {y}) outside the image"
        );
        self.data[y * self.stride + x]
    }

    /// Pixel `(x, y)` without the bounds assertion on `x` (the slice index still checks).
    #[inline]
    pub(crate) fn at(&self, x: usize, y: usize) -> u8 {
        self.data[y * self.stride + x]
    }

    /// A packed copy with every grey value `g` replaced by `255 - g`.
    pub fn inverted(&self) -> image::GrayImage {
        let mut out = Vec::with_capacity(self.width * self.height);
        for y in 0..self.height {
            out.extend(self.row(y).iter().map(|&g| 255 - g));
        }
        image::GrayImage::from_raw(self.width as u32, self.height as u32, out)
            .expect("buffer has width * height bytes")
    }
}

/// Grey value of an RGB pixel with the ITU-R BT.601 weights `0.299 R + 0.587 G + 0.114 B`, in the
/// 14-bit fixed point that OpenCV's `cvtColor(..., COLOR_RGB2GRAY)` and `imread(...,
/// IMREAD_GRAYSCALE)` use, so both detectors see the same grey image.
#[inline]
pub fn luminance(r: u8, g: u8, b: u8) -> u8 {
    ((r as u32 * 4899 + g as u32 * 9617 + b as u32 * 1868 + (1 << 13)) >> 14) as u8
}

/// Converts any decoded image to 8-bit grey: grey images are kept as they are (16-bit ones are
/// scaled to 8 bits), colour images go through [`luminance`] (alpha is ignored).
pub fn to_gray(img: &image::DynamicImage) -> image::GrayImage {
    match img {
        image::DynamicImage::ImageLuma8(g) => g.clone(),
        image::DynamicImage::ImageLumaA8(_)
        | image::DynamicImage::ImageLuma16(_)
        | image::DynamicImage::ImageLumaA16(_) => img.to_luma8(),
        _ => {
            let rgb = img.to_rgb8();
            let data = rgb.pixels().map(|p| luminance(p[0], p[1], p[2])).collect();
            image::GrayImage::from_raw(rgb.width(), rgb.height(), data)
                .expect("buffer has width * height bytes")
        }
    }
}

/// Reads an image file (PNG) and converts it to grey with [`to_gray`]. The `image` crate's
/// default decoding limits apply (at most 512 MiB allocated, checked from the header before
/// decoding), and [`GrayView::new`] then bounds the size to 2^28 padded pixels.
pub fn load_gray(path: impl AsRef<std::path::Path>) -> Result<image::GrayImage> {
    // A grey file is kept as decoded (no copy).
    Ok(match image::open(path)? {
        image::DynamicImage::ImageLuma8(g) => g,
        other => to_gray(&other),
    })
}
