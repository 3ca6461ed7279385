//! Reading an image file and converting it to 8-bit grey.
//!
//! PNG and the binary Netpbm formats (`.pgm`, `.ppm`, `.pnm`, as the Oxford archives ship them)
//! are decoded by the `image` crate, chosen by the file's content, not its name. Colour is
//! converted by [`mser::to_gray`] (the one home of the conversion: ITU-R BT.601 in OpenCV's
//! 14-bit fixed point, so our detector sees the same grey image as OpenCV's
//! `imread(…, IMREAD_GRAYSCALE)`); grey files are kept as they are.
//!
//! [`GrayReader`] reads many files one after the other with the same result as [`load_gray`],
//! keeping its buffers between files: the file's bytes and the grey pixels are read into
//! memory it already holds, and an 8-bit grey PNG is decoded by the `png` crate directly into
//! the pixel buffer with the settings the `image` crate uses (no zero-filled allocation per
//! image, no copy). Anything else, and every file the direct path declines or fails on, goes
//! through [`decode_gray`], so pixels and error messages are those of [`load_gray`].

use std::io::Read;
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

/// The eight bytes every PNG file starts with.
const PNG_SIGNATURE: &[u8] = b"\x89PNG\r\n\x1a\n";

/// Reads image files one after the other into buffers it keeps (one per thread for a batch).
/// Each [`read`](Self::read) gives exactly [`load_gray`]'s image or error.
#[derive(Debug, Default)]
pub struct GrayReader {
    /// The bytes of the last file.
    file: Vec<u8>,
    /// The last image; its pixel buffer is reused by the next 8-bit grey PNG.
    image: GrayImage,
}

impl GrayReader {
    /// A reader with empty buffers.
    pub fn new() -> Self {
        Self::default()
    }

    /// Reads `path` as [`load_gray`] does (same pixels, same typed errors); the image is
    /// borrowed from the reader until the next read.
    pub fn read(&mut self, path: &Path) -> Result<&GrayImage> {
        if path.is_dir() {
            return Err(VisguideError::Image {
                path: path.to_path_buf(),
                reason: "it is a directory, expected an image file".into(),
            });
        }
        self.file.clear();
        std::fs::File::open(path)
            .and_then(|mut f| f.read_to_end(&mut self.file))
            .map_err(io(path))?;
        if !self.decode_gray8_png() {
            self.image = decode_gray(path, &self.file)?;
        }
        Ok(&self.image)
    }

    /// Decodes the file as an 8-bit grey PNG into the kept pixel buffer, with the `image`
    /// crate's settings (its decoding limits, `EXPAND`, text chunks read); `false` (nothing
    /// decoded) for any other file, a PNG that is not 8-bit grey once expanded (a `tRNS` chunk
    /// adds alpha), one beyond [`MAX_IMAGE_SIDE`] or [`MAX_DECODE_BYTES`], or any decoding
    /// error, which [`decode_gray`] then reports in its own words.
    fn decode_gray8_png(&mut self) -> bool {
        use png::{BitDepth, ColorType};
        if !self.file.starts_with(PNG_SIGNATURE) {
            return false;
        }
        let limits = png::Limits {
            bytes: usize::try_from(MAX_DECODE_BYTES).unwrap_or(usize::MAX),
        };
        let mut decoder = png::Decoder::new_with_limits(std::io::Cursor::new(&self.file), limits);
        decoder.set_ignore_text_chunk(false);
        let Ok(header) = decoder.read_header_info() else {
            return false;
        };
        let (w, h) = (header.width, header.height);
        if (header.color_type, header.bit_depth) != (ColorType::Grayscale, BitDepth::Eight)
            || w > MAX_IMAGE_SIDE
            || h > MAX_IMAGE_SIDE
            || u64::from(w) * u64::from(h) > MAX_DECODE_BYTES
        {
            return false;
        }
        decoder.set_transformations(png::Transformations::EXPAND);
        let Ok(mut reader) = decoder.read_info() else {
            return false;
        };
        let n = w as usize * h as usize;
        if reader.output_color_type() != (ColorType::Grayscale, BitDepth::Eight)
            || reader.output_buffer_size() != Some(n)
            || n == 0
        {
            return false;
        }
        let mut pixels = std::mem::take(&mut self.image).into_raw();
        // Every byte is overwritten by the decoder; only a larger image grows the buffer.
        pixels.resize(n, 0);
        if reader.next_frame(&mut pixels).is_err() {
            return false;
        }
        match GrayImage::from_raw(w, h, pixels) {
            Some(img) => {
                self.image = img;
                true
            }
            None => false,
        }
    }
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

    /// A PNG written by the `png` crate's encoder (with a text chunk), `raw` the packed rows.
    fn png_file(
        (w, h): (u32, u32),
        (color, depth): (png::ColorType, png::BitDepth),
        raw: &[u8],
        trns: Option<&[u8]>,
        palette: Option<&[u8]>,
    ) -> Vec<u8> {
        let mut out = Vec::new();
        let mut e = png::Encoder::new(&mut out, w, h);
        e.set_color(color);
        e.set_depth(depth);
        if let Some(t) = trns {
            e.set_trns(t.to_vec());
        }
        if let Some(p) = palette {
            e.set_palette(p.to_vec());
        }
        e.add_text_chunk("Comment".into(), "visguide test".into())
            .unwrap();
        let mut wr = e.write_header().unwrap();
        wr.write_image_data(raw).unwrap();
        wr.finish().unwrap();
        out
    }

    /// One PNG chunk: length, type, data, CRC-32.
    fn chunk(out: &mut Vec<u8>, kind: &[u8; 4], data: &[u8]) {
        let mut crc = !0u32;
        for &b in kind.iter().chain(data) {
            crc ^= u32::from(b);
            for _ in 0..8 {
                crc = if crc & 1 == 1 {
                    (crc >> 1) ^ 0xEDB8_8320
                } else {
                    crc >> 1
                };
            }
        }
        out.extend_from_slice(&(data.len() as u32).to_be_bytes());
        out.extend_from_slice(kind);
        out.extend_from_slice(data);
        out.extend_from_slice(&(!crc).to_be_bytes());
    }

    /// An 8-bit grey PNG header declaring `w × h` (`interlace` 1: Adam7) with `idat` as its
    /// zlib stream.
    fn gray8_png(w: u32, h: u32, interlace: u8, idat: &[u8]) -> Vec<u8> {
        let mut out = PNG_SIGNATURE.to_vec();
        let mut ihdr = w.to_be_bytes().to_vec();
        ihdr.extend_from_slice(&h.to_be_bytes());
        ihdr.extend_from_slice(&[8, 0, 0, 0, interlace]);
        chunk(&mut out, b"IHDR", &ihdr);
        chunk(&mut out, b"IDAT", idat);
        chunk(&mut out, b"IEND", &[]);
        out
    }

    /// An Adam7-interlaced 8-bit grey PNG of `px` (the `png` crate's encoder writes no
    /// interlaced files): the seven passes, filter 0, in stored deflate blocks.
    fn interlaced_gray8(w: u32, h: u32, px: &[u8]) -> Vec<u8> {
        const PASSES: [(u32, u32, usize, usize); 7] = [
            (0, 0, 8, 8),
            (4, 0, 8, 8),
            (0, 4, 4, 8),
            (2, 0, 4, 4),
            (0, 2, 2, 4),
            (1, 0, 2, 2),
            (0, 1, 1, 2),
        ];
        let mut raw = Vec::new();
        for (x0, y0, dx, dy) in PASSES {
            if x0 >= w || y0 >= h {
                continue;
            }
            for y in (y0..h).step_by(dy) {
                raw.push(0);
                raw.extend((x0..w).step_by(dx).map(|x| px[(y * w + x) as usize]));
            }
        }
        let mut z = vec![0x78, 0x01];
        let blocks: Vec<&[u8]> = raw.chunks(65_535).collect();
        for (i, b) in blocks.iter().enumerate() {
            z.push(u8::from(i + 1 == blocks.len()));
            let n = b.len() as u16;
            z.extend_from_slice(&n.to_le_bytes());
            z.extend_from_slice(&(!n).to_le_bytes());
            z.extend_from_slice(b);
        }
        let (mut s1, mut s2) = (1u32, 0u32);
        for &b in &raw {
            s1 = (s1 + u32::from(b)) % 65_521;
            s2 = (s2 + s1) % 65_521;
        }
        z.extend_from_slice(&((s2 << 16) | s1).to_be_bytes());
        gray8_png(w, h, 1, &z)
    }

    /// `GrayReader` gives `load_gray`'s image or error for every kind of file, one reader
    /// reading them all in turn (buffers growing, shrinking, and coming back from the other
    /// path); 8-bit grey PNGs are decoded into the reused buffer.
    #[test]
    fn the_reader_equals_load_gray_on_every_kind_of_file() {
        use png::{BitDepth as D, ColorType as C};
        let dir = std::env::temp_dir().join(format!("visguide-reader-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let bytes = |n: usize, seed: usize| -> Vec<u8> {
            (0..n)
                .map(|i| ((i * 37 + seed * 101) % 251) as u8)
                .collect()
        };
        let gray = |w: u32, h: u32, seed| {
            png_file(
                (w, h),
                (C::Grayscale, D::Eight),
                &bytes((w * h) as usize, seed),
                None,
                None,
            )
        };
        let good = gray(64, 48, 1);
        let mut files: Vec<(&str, Vec<u8>)> = vec![
            ("g37x23", gray(37, 23, 0)),
            ("g64x48", good.clone()),
            ("g64x48b", gray(64, 48, 2)),
            ("g5x3", gray(5, 3, 3)),
            ("interlaced", interlaced_gray8(13, 11, &bytes(13 * 11, 4))),
            (
                "rgb",
                png_file((20, 10), (C::Rgb, D::Eight), &bytes(600, 5), None, None),
            ),
            ("g20x10", gray(20, 10, 6)),
            (
                "g16",
                png_file(
                    (9, 7),
                    (C::Grayscale, D::Sixteen),
                    &bytes(126, 7),
                    None,
                    None,
                ),
            ),
            (
                "g4",
                png_file((9, 7), (C::Grayscale, D::Four), &bytes(35, 8), None, None),
            ),
            (
                "ga8",
                png_file(
                    (9, 7),
                    (C::GrayscaleAlpha, D::Eight),
                    &bytes(126, 9),
                    None,
                    None,
                ),
            ),
            (
                "rgba",
                png_file((9, 7), (C::Rgba, D::Eight), &bytes(252, 10), None, None),
            ),
            (
                "trns",
                png_file(
                    (9, 7),
                    (C::Grayscale, D::Eight),
                    &bytes(63, 11),
                    Some(&[0, 40]),
                    None,
                ),
            ),
            (
                "palette",
                png_file(
                    (9, 7),
                    (C::Indexed, D::Eight),
                    &bytes(63, 12).iter().map(|b| b % 4).collect::<Vec<_>>(),
                    None,
                    Some(&bytes(12, 13)),
                ),
            ),
            ("corrupt", b"\x89PNG\r\n\x1a\nthis is not a png".to_vec()),
            ("truncated", good[..good.len() / 2].to_vec()),
            ("huge", gray8_png(40_000, 40_000, 0, &[])),
            ("big", gray8_png(30_000, 30_000, 0, &[])),
            ("empty.pgm", b"P5\n0 0\n255\n".to_vec()),
            (
                "g.pgm",
                [b"P5\n3 2\n255\n".as_slice(), &[1, 2, 3, 4, 5, 6]].concat(),
            ),
            ("g64x48c", gray(64, 48, 14)),
        ];
        files.push(("g64x48d", gray(64, 48, 15)));
        let mut reader = GrayReader::new();
        let mut paths: Vec<std::path::PathBuf> = files
            .iter()
            .map(|(name, data)| {
                let p = dir.join(format!("{name}.png"));
                std::fs::write(&p, data).unwrap();
                p
            })
            .collect();
        paths.push(dir.join("missing.png"));
        paths.push(dir.clone());
        let mut decoded = 0;
        for p in &paths {
            match (reader.read(p), load_gray(p)) {
                (Ok(got), Ok(want)) => {
                    assert!(got == &want, "{}: the images differ", p.display());
                    decoded += 1;
                }
                (Err(got), Err(want)) => assert_eq!(got.to_string(), want.to_string()),
                (got, want) => panic!("{}: {got:?} vs {want:?}", p.display()),
            }
        }
        assert_eq!(decoded, files.len() - 5);
        // Two 8-bit grey PNGs of the same size in a row: the second lands in the first's
        // pixel buffer (the direct path, no allocation).
        let first = reader.read(&paths[1]).unwrap().as_raw().as_ptr();
        let second = reader.read(&paths[2]).unwrap().as_raw().as_ptr();
        assert_eq!(first, second);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
