//! A decoder for the binary Netpbm images the Oxford archives hold: `P5` (8-bit grey, `.pgm`)
//! and `P6` (8-bit RGB, `.ppm`), with `#` comments anywhere in the header (the benchmark's files
//! carry `# CREATOR: XV …` lines). 16-bit samples (maxval > 255) are scaled to 8 bits; a maxval
//! below 255 is stretched to the full 8-bit range.

use image::{DynamicImage, GrayImage, RgbImage};

/// Why a file is not a supported Netpbm image.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("not a supported PNM image: {0}")]
pub struct PnmError(pub String);

fn err<T>(msg: impl Into<String>) -> Result<T, PnmError> {
    Err(PnmError(msg.into()))
}

/// Reads the next header token, skipping whitespace and comments; returns it and the position
/// after it.
fn token(data: &[u8], mut pos: usize) -> Result<(&[u8], usize), PnmError> {
    loop {
        match data.get(pos) {
            None => return err("header ends early"),
            Some(b'#') => {
                while data.get(pos).is_some_and(|&c| c != b'\n' && c != b'\r') {
                    pos += 1;
                }
            }
            Some(c) if c.is_ascii_whitespace() => pos += 1,
            Some(_) => break,
        }
    }
    let start = pos;
    while data
        .get(pos)
        .is_some_and(|c| !c.is_ascii_whitespace() && *c != b'#')
    {
        pos += 1;
    }
    Ok((&data[start..pos], pos))
}

fn number(data: &[u8], pos: usize, what: &str) -> Result<(u32, usize), PnmError> {
    let (tok, pos) = token(data, pos)?;
    let text = std::str::from_utf8(tok).map_err(|_| PnmError(format!("bad {what}")))?;
    match text.parse::<u32>() {
        Ok(n) => Ok((n, pos)),
        Err(_) => err(format!("bad {what} `{text}`")),
    }
}

/// Decodes a `P5` or `P6` file.
pub fn decode(data: &[u8]) -> Result<DynamicImage, PnmError> {
    let (magic, pos) = token(data, 0)?;
    let channels = match magic {
        b"P5" => 1usize,
        b"P6" => 3,
        _ => return err("only binary P5 (grey) and P6 (RGB) are supported"),
    };
    let (width, pos) = number(data, pos, "width")?;
    let (height, pos) = number(data, pos, "height")?;
    let (maxval, pos) = number(data, pos, "maxval")?;
    if width == 0 || height == 0 {
        return err(format!("empty image {width}x{height}"));
    }
    if maxval == 0 || maxval > 65535 {
        return err(format!("maxval {maxval} out of range"));
    }
    // Exactly one whitespace byte separates the header from the samples.
    if !data.get(pos).is_some_and(|c| c.is_ascii_whitespace()) {
        return err("no whitespace after the header");
    }
    let body = &data[pos + 1..];
    let bytes_per_sample = if maxval > 255 { 2 } else { 1 };
    let samples = (width as usize)
        .checked_mul(height as usize)
        .and_then(|n| n.checked_mul(channels))
        .ok_or_else(|| PnmError("image too large".into()))?;
    if body.len() < samples * bytes_per_sample {
        return err(format!(
            "pixel data holds {} bytes, {width}x{height} needs {}",
            body.len(),
            samples * bytes_per_sample
        ));
    }
    let scale = |v: u32| -> u8 { ((v * 255 + maxval / 2) / maxval) as u8 };
    let pixels: Vec<u8> = if bytes_per_sample == 1 {
        if maxval == 255 {
            body[..samples].to_vec()
        } else {
            body[..samples]
                .iter()
                .map(|&v| scale(v.min(maxval as u8) as u32))
                .collect()
        }
    } else {
        body[..2 * samples]
            .chunks_exact(2)
            .map(|b| scale((u16::from_be_bytes([b[0], b[1]]) as u32).min(maxval)))
            .collect()
    };
    Ok(if channels == 1 {
        DynamicImage::ImageLuma8(GrayImage::from_raw(width, height, pixels).expect("sized"))
    } else {
        DynamicImage::ImageRgb8(RgbImage::from_raw(width, height, pixels).expect("sized"))
    })
}

/// Encodes an 8-bit grey image as `P5` (used by tests to build archives like the benchmark's).
#[cfg(test)]
pub fn encode_p5(img: &GrayImage) -> Vec<u8> {
    let mut out = format!(
        "P5\n# CREATOR: visguide test\n{} {}\n255\n",
        img.width(),
        img.height()
    )
    .into_bytes();
    out.extend_from_slice(img.as_raw());
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn decodes_grey_and_rgb_with_comments() {
        let g =
            decode(b"P5\n# CREATOR: XV\n# # comments\n3 2\n255\n\x00\x01\x02\x03\x04\xff").unwrap();
        assert_eq!(g.to_luma8().as_raw(), &[0, 1, 2, 3, 4, 255]);
        let c = decode(b"P6 1 2 255\n\x01\x02\x03\x04\x05\x06").unwrap();
        assert_eq!(c.as_rgb8().unwrap().as_raw(), &[1, 2, 3, 4, 5, 6]);
    }

    #[test]
    fn scales_other_maxvals() {
        let g = decode(b"P5 2 1 15 \x00\x0f").unwrap();
        assert_eq!(g.to_luma8().as_raw(), &[0, 255]);
        let w = decode(b"P5 2 1 65535 \x00\x00\xff\xff").unwrap();
        assert_eq!(w.to_luma8().as_raw(), &[0, 255]);
    }

    #[test]
    fn round_trips_p5() {
        let img = GrayImage::from_fn(5, 4, |x, y| image::Luma([(x * 40 + y) as u8]));
        assert_eq!(decode(&encode_p5(&img)).unwrap().to_luma8(), img);
    }

    #[test]
    fn rejects_bad_files() {
        for bad in [
            &b""[..],
            b"P3 1 1 255 1 2 3",
            b"P5 0 1 255 ",
            b"P5 2 2 255\n\x00",
            b"P5 x 2 255\n\x00",
            b"P6 1 1 70000\n\x00\x00\x00\x00\x00\x00",
            b"P5 1 1",
        ] {
            assert!(decode(bad).is_err(), "{bad:?} accepted");
        }
    }
}
