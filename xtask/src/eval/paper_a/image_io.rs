//! Reading a benchmark image as 8-bit grey.
//!
//! The study reads its images with `visguide::load_gray` (PNG and Netpbm by content, colour
//! to grey by `mser::to_gray`, the one home of the BT.601 conversion). [`decode`] is kept for
//! `cargo xtask data fetch`, which checks every image of an archive with the xtask's own PNM
//! decoder (it handles the archives' 16-bit and low-maxval files) before writing it as PNG.

use std::path::Path;

use image::{DynamicImage, GrayImage};

use super::error::PaperAError;
use crate::data_fetch::pnm;

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

/// Reads an image file and converts it to grey (`visguide::load_gray`).
pub fn load_gray(path: &Path) -> Result<GrayImage, PaperAError> {
    Ok(visguide::load_gray(path)?)
}

#[cfg(test)]
mod tests {
    use super::*;

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
        std::fs::write(&ppm_path, &ppm).unwrap();
        let (g1, g2) = (load_gray(&png).unwrap(), load_gray(&ppm_path).unwrap());
        assert_eq!(g1, g2);
        assert_eq!(g1.get_pixel(3, 2)[0], mser::luminance(180, 180, 17));
        // The xtask's decoder (data fetch) gives the same grey image.
        assert_eq!(mser::to_gray(&decode(&ppm_path, &ppm).unwrap()), g1);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn unreadable_files_are_typed_errors() {
        let p = Path::new("/nonexistent/visguide/img1.png");
        assert!(matches!(load_gray(p), Err(PaperAError::Visguide(_))));
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
