//! Reading a benchmark image and converting it to 8-bit grey.
//!
//! PNG files are decoded by the `image` crate; the original `.ppm`/`.pgm` files of the Oxford
//! archives by [`crate::data_fetch::pnm`]. Colour is converted as the `mser` crate documents
//! (`mser::luminance`): ITU-R BT.601 weights `0.299 R + 0.587 G + 0.114 B` in OpenCV's 14-bit
//! fixed point (`(4899 R + 9617 G + 1868 B + 2¹³) >> 14`), so our detector sees the same grey
//! image as OpenCV's `imread(…, IMREAD_GRAYSCALE)`. Grey files are kept as they are.

use std::path::Path;

use image::{DynamicImage, GrayImage};

use super::error::PaperAError;
use crate::data_fetch::pnm;

/// Grey value of an RGB pixel: BT.601 in 14-bit fixed point (identical to `mser::luminance`).
#[inline]
pub fn luminance(r: u8, g: u8, b: u8) -> u8 {
    ((r as u32 * 4899 + g as u32 * 9617 + b as u32 * 1868 + (1 << 13)) >> 14) as u8
}

/// Converts a decoded image to grey with [`luminance`]; grey images are kept (16-bit scaled).
pub fn to_gray(img: &DynamicImage) -> GrayImage {
    match img {
        DynamicImage::ImageLuma8(g) => g.clone(),
        DynamicImage::ImageLumaA8(_)
        | DynamicImage::ImageLuma16(_)
        | DynamicImage::ImageLumaA16(_) => img.to_luma8(),
        _ => {
            let rgb = img.to_rgb8();
            let data = rgb.pixels().map(|p| luminance(p[0], p[1], p[2])).collect();
            GrayImage::from_raw(rgb.width(), rgb.height(), data).expect("w*h bytes")
        }
    }
}

/// Decodes an image file by its extension (`.png`, `.ppm`, `.pgm`, `.pnm`).
pub fn load(path: &Path) -> Result<DynamicImage, PaperAError> {
    let bytes = std::fs::read(path).map_err(|source| PaperAError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    decode(path, &bytes)
}

/// Decodes image bytes; `path` names the file (its extension picks the decoder).
pub fn decode(path: &Path, bytes: &[u8]) -> Result<DynamicImage, PaperAError> {
    let bad = |reason: String| PaperAError::Image {
        path: path.to_path_buf(),
        reason,
    };
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    match ext.as_deref() {
        Some("ppm" | "pgm" | "pnm") => pnm::decode(bytes).map_err(|e| bad(e.to_string())),
        _ => image::load_from_memory_with_format(bytes, image::ImageFormat::Png)
            .map_err(|e| bad(e.to_string())),
    }
}

/// Reads an image file and converts it to grey.
pub fn load_gray(path: &Path) -> Result<GrayImage, PaperAError> {
    Ok(to_gray(&load(path)?))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn luminance_is_bt601_fixed_point() {
        assert_eq!(luminance(0, 0, 0), 0);
        assert_eq!(luminance(255, 255, 255), 255);
        assert_eq!(luminance(255, 0, 0), 76); // 0.299 · 255 = 76.2
        assert_eq!(luminance(0, 255, 0), 150); // 0.587 · 255 = 149.7
        assert_eq!(luminance(0, 0, 255), 29); // 0.114 · 255 = 29.1
        for (r, g, b) in [(10, 200, 30), (255, 128, 1), (77, 77, 77)] {
            assert_eq!(luminance(r, g, b), mser::luminance(r, g, b));
        }
    }

    #[test]
    fn png_and_pnm_decode_to_the_same_grey() {
        let dir = std::env::temp_dir().join(format!("visguide-imgio-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let rgb =
            image::RgbImage::from_fn(4, 3, |x, y| image::Rgb([x as u8 * 60, y as u8 * 90, 17]));
        let png = dir.join("a.png");
        rgb.save(&png).unwrap();
        let mut ppm = b"P6\n# CREATOR: XV\n4 3\n255\n".to_vec();
        ppm.extend_from_slice(rgb.as_raw());
        let ppm_path = dir.join("a.ppm");
        std::fs::write(&ppm_path, ppm).unwrap();
        let (g1, g2) = (load_gray(&png).unwrap(), load_gray(&ppm_path).unwrap());
        assert_eq!(g1, g2);
        assert_eq!(g1.get_pixel(3, 2)[0], luminance(180, 180, 17));
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn unreadable_files_are_typed_errors() {
        let p = Path::new("/nonexistent/visguide/img1.png");
        assert!(matches!(load_gray(p), Err(PaperAError::Io { .. })));
        assert!(matches!(
            decode(Path::new("x.png"), b"not a png"),
            Err(PaperAError::Image { .. })
        ));
        assert!(matches!(
            decode(Path::new("x.pgm"), b"P5 1 1 255\n"),
            Err(PaperAError::Image { .. })
        ));
    }
}
