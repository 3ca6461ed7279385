//! Reading an image file and converting it to 8-bit grey.
//!
//! PNG and the binary Netpbm formats (`.pgm`, `.ppm`, `.pnm`, as the Oxford archives ship them)
//! are decoded by the `image` crate, chosen by the file's content, not its name. Colour is
//! converted by [`mser::to_gray`] (the one home of the conversion: ITU-R BT.601 in OpenCV's
//! 14-bit fixed point, so our detector sees the same grey image as OpenCV's
//! `imread(…, IMREAD_GRAYSCALE)`); grey files are kept as they are.

use std::path::Path;

use image::GrayImage;

use crate::error::{Result, VisguideError, io};

/// The largest width and height an image file may declare (pixels). Checked from the header,
/// before the pixels are allocated; the decoder's allocation is also bounded by
/// [`MAX_DECODE_BYTES`].
pub const MAX_IMAGE_SIDE: u32 = 1 << 15;

/// The most memory the decoder may allocate for one image (512 MiB).
pub const MAX_DECODE_BYTES: u64 = 512 << 20;

/// Decodes image bytes; `path` only names the file in errors. An image without pixels, or one
/// declaring a side above [`MAX_IMAGE_SIDE`] or needing more than [`MAX_DECODE_BYTES`], is an
/// error (from the header, before any pixel is allocated).
pub fn decode_gray(path: &Path, bytes: &[u8]) -> Result<GrayImage> {
    let bad = |reason: String| VisguideError::Image {
        path: path.to_path_buf(),
        reason,
    };
    let format = image::guess_format(bytes).map_err(|e| bad(e.to_string()))?;
    let mut reader = image::ImageReader::with_format(std::io::Cursor::new(bytes), format);
    let mut limits = image::Limits::default();
    limits.max_image_width = Some(MAX_IMAGE_SIDE);
    limits.max_image_height = Some(MAX_IMAGE_SIDE);
    limits.max_alloc = Some(MAX_DECODE_BYTES);
    reader.limits(limits);
    let img = reader.decode().map_err(|e| bad(e.to_string()))?;
    if img.width() == 0 || img.height() == 0 {
        return Err(bad(format!(
            "it has no pixels ({}×{})",
            img.width(),
            img.height()
        )));
    }
    // A grey file is kept as decoded (no copy); anything else is converted.
    Ok(match img {
        image::DynamicImage::ImageLuma8(g) => g,
        other => mser::to_gray(&other),
    })
}

/// Reads an image file (PNG, PGM, PPM) and converts it to grey. A directory, a missing file, an
/// undecodable or empty image are typed errors naming the file.
pub fn load_gray(path: impl AsRef<Path>) -> Result<GrayImage> {
    let path = path.as_ref();
    if path.is_dir() {
        return Err(VisguideError::Image {
            path: path.to_path_buf(),
            reason: "it is a directory, expected an image file".into(),
        });
    }
    let bytes = std::fs::read(path).map_err(io(path))?;
    decode_gray(path, &bytes)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn png_and_ppm_decode_to_the_same_grey_as_mser_luminance() {
        let dir = std::env::temp_dir().join(format!("visguide-imgio-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let rgb =
            image::RgbImage::from_fn(4, 3, |x, y| image::Rgb([x as u8 * 60, y as u8 * 90, 17]));
        let png = dir.join("a.png");
        rgb.save(&png).unwrap();
        let mut ppm = b"P6\n# CREATOR: XV\n4 3\n255\n".to_vec();
        ppm.extend_from_slice(rgb.as_raw());
        // A misleading extension: the content decides.
        let ppm_path = dir.join("a.png.ppm");
        std::fs::write(&ppm_path, ppm).unwrap();
        let (g1, g2) = (load_gray(&png).unwrap(), load_gray(&ppm_path).unwrap());
        assert_eq!(g1, g2);
        assert_eq!(g1.get_pixel(3, 2)[0], mser::luminance(180, 180, 17));
        assert!(matches!(load_gray(&dir), Err(VisguideError::Image { .. })));
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn unreadable_files_are_typed_errors() {
        let p = Path::new("/nonexistent/visguide/img1.png");
        assert!(matches!(load_gray(p), Err(VisguideError::Io { .. })));
        for bad in [
            &b"not a png"[..],
            b"P5 1 1 255\n",
            b"",
            b"\x89PNG\r\n\x1a\n",
        ] {
            assert!(matches!(
                decode_gray(Path::new("x.png"), bad),
                Err(VisguideError::Image { .. })
            ));
        }
    }

    #[test]
    fn a_header_declaring_a_huge_image_is_refused_before_decoding() {
        // 40,000 × 40,000 grey pixels (1.6 GB) declared by a 20-byte PGM header.
        let pgm = b"P5\n40000 40000\n255\n\x00";
        let err = decode_gray(Path::new("huge.pgm"), pgm).unwrap_err();
        assert!(matches!(err, VisguideError::Image { .. }), "{err}");
        assert!(err.to_string().to_lowercase().contains("limit"), "{err}");
        // Within the side limit but beyond the allocation limit: 30,000² bytes = 900 MB.
        let pgm = b"P5\n30000 30000\n255\n\x00";
        let err = decode_gray(Path::new("big.pgm"), pgm).unwrap_err();
        assert!(err.to_string().to_lowercase().contains("limit"), "{err}");
        // A small image cut short fails for another reason (not a limit).
        let err = decode_gray(Path::new("short.pgm"), b"P5\n4 4\n255\n\x00").unwrap_err();
        assert!(!err.to_string().to_lowercase().contains("limit"), "{err}");
    }
}
