//! Unpacking one sequence archive (`<seq>.tar.gz`) into a folder: every `imgN.ppm|pgm|png` is
//! decoded (so every image is checked) and written as a lossless PNG `imgN.png`; every
//! `H1toNp` is parsed as a homography and copied byte for byte. Other files are ignored. The
//! archive may hold the files at its top level or below one folder.

use std::io::Read;
use std::path::Path;

use crate::eval::paper_a::homography::Homography;
use crate::eval::paper_a::image_io::decode as decode_image;

/// What was unpacked.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Unpacked {
    /// Image numbers written (`imgN.png`), ascending.
    pub images: Vec<u32>,
    /// Homography numbers written (`H1toNp`), ascending.
    pub homographies: Vec<u32>,
}

/// `imgN.<ext>` → N for an image extension.
fn image_number(name: &str) -> Option<u32> {
    let (stem, ext) = name.rsplit_once('.')?;
    if !matches!(
        ext.to_ascii_lowercase().as_str(),
        "ppm" | "pgm" | "pnm" | "png"
    ) {
        return None;
    }
    stem.strip_prefix("img")?.parse().ok()
}

/// `H1toNp` → N.
fn homography_number(name: &str) -> Option<u32> {
    name.strip_prefix("H1to")?.strip_suffix('p')?.parse().ok()
}

/// Unpacks a gzip-compressed tar stream into `dir` (which must exist). Fails on a truncated or
/// corrupt archive, an image that does not decode, a malformed homography, or a sequence
/// without img1, img2 and H1to2p, or with an `imgN` (N ≥ 2) lacking its `H1toNp`.
pub fn unpack(stream: impl Read, dir: &Path) -> crate::Result<Unpacked> {
    let mut archive = tar::Archive::new(flate2::read::GzDecoder::new(stream));
    let mut out = Unpacked::default();
    for entry in archive.entries()? {
        let mut entry = entry?;
        if !entry.header().entry_type().is_file() {
            continue;
        }
        let path = entry.path()?.into_owned();
        let Some(name) = path
            .file_name()
            .and_then(|n| n.to_str())
            .map(str::to_string)
        else {
            continue;
        };
        let mut bytes = Vec::new();
        entry.read_to_end(&mut bytes)?;
        if let Some(n) = image_number(&name) {
            let img = decode_image(Path::new(&name), &bytes)?;
            // Encoded in memory and written with the error checked (`save_with_format` leaves
            // the file's end to a dropped buffer, which ignores a failed write).
            let png = dir.join(format!("img{n}.png"));
            let mut encoded = Vec::new();
            img.write_to(
                &mut std::io::Cursor::new(&mut encoded),
                image::ImageFormat::Png,
            )?;
            std::fs::write(&png, &encoded).map_err(|e| format!("{}: {e}", png.display()))?;
            out.images.push(n);
        } else if let Some(n) = homography_number(&name) {
            let text =
                String::from_utf8(bytes.clone()).map_err(|_| format!("{name} is not text"))?;
            Homography::parse(&text).map_err(|e| format!("{name}: {e}"))?;
            let h = dir.join(&name);
            std::fs::write(&h, &bytes).map_err(|e| format!("{}: {e}", h.display()))?;
            out.homographies.push(n);
        }
    }
    out.images.sort_unstable();
    out.images.dedup();
    out.homographies.sort_unstable();
    out.homographies.dedup();
    if !out.images.contains(&1) || !out.images.contains(&2) || !out.homographies.contains(&2) {
        return Err("archive lacks img1, img2 or H1to2p".into());
    }
    if let Some(n) = out
        .images
        .iter()
        .find(|&&n| n >= 2 && !out.homographies.contains(&n))
    {
        return Err(format!("archive has img{n} but no H1to{n}p").into());
    }
    Ok(out)
}

/// Checks an unpacked sequence folder: img1 … imgK decode (PNG), H1to2p … H1toKp parse, at
/// least one pair. Returns the number of images.
pub fn verify(dir: &Path) -> crate::Result<usize> {
    let mut k = 0;
    loop {
        let img = dir.join(format!("img{}.png", k + 1));
        if !img.is_file() {
            break;
        }
        let bytes = std::fs::read(&img)?;
        decode_image(&img, &bytes)?;
        if k >= 1 {
            let h = dir.join(format!("H1to{}p", k + 1));
            let text = std::fs::read_to_string(&h).map_err(|e| format!("{}: {e}", h.display()))?;
            Homography::parse(&text).map_err(|e| format!("{}: {e}", h.display()))?;
        }
        k += 1;
    }
    if k < 2 {
        return Err(format!("{}: no img1/img2 pair", dir.display()).into());
    }
    Ok(k)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names() {
        assert_eq!(image_number("img3.ppm"), Some(3));
        assert_eq!(image_number("img12.PGM"), Some(12));
        assert_eq!(image_number("img3.txt"), None);
        assert_eq!(image_number("image3.ppm"), None);
        assert_eq!(homography_number("H1to6p"), Some(6));
        assert_eq!(homography_number("H1to6"), None);
        assert_eq!(homography_number("H2to6p"), None);
    }
}
