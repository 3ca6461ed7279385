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

    /// Only what is the xtask's own: its PNM decoder (data fetch) gives the grey image
    /// `visguide::load_gray` gives (whose PNG/PNM agreement and luminance are tested in
    /// `visguide::image_io`), and its errors are typed.
    #[test]
    fn the_fetch_decoder_agrees_with_visguide_and_fails_typed() {
        let dir = std::env::temp_dir().join(format!("visguide-imgio-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let rgb =
            image::RgbImage::from_fn(4, 3, |x, y| image::Rgb([x as u8 * 60, y as u8 * 90, 17]));
        let mut ppm = b"P6\n# CREATOR: XV\n4 3\n255\n".to_vec();
        ppm.extend_from_slice(rgb.as_raw());
        let ppm_path = dir.join("a.ppm");
        std::fs::write(&ppm_path, &ppm).unwrap();
        assert_eq!(
            mser::to_gray(&decode(&ppm_path, &ppm).unwrap()),
            load_gray(&ppm_path).unwrap()
        );
        std::fs::remove_dir_all(&dir).unwrap();
        let p = Path::new("/nonexistent/visguide/img1.png");
        assert!(matches!(load_gray(p), Err(PaperAError::Visguide(_))));
        for (name, bytes) in [("x.png", &b"not a png"[..]), ("x.pgm", b"P5 1 1 255\n")] {
            assert!(matches!(
                decode(Path::new(name), bytes),
                Err(PaperAError::Image { .. })
            ));
        }
    }
}
