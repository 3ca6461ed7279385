//! Region files of one image in three formats:
//!
//! - **Oxford** (`.mser`): the benchmark's region file ([`mser::write_regions`]): `1.0`, the
//!   count, then `u v a b c` per region with the ellipse `a(x−u)² + 2b(x−u)(y−v) + c(y−v)² = 1`
//!   of [`mser::Region::ellipse`] (about the region's own area), 0-based pixel coordinates.
//! - **JSON**: a [`RegionFile`]: image, size, parameters and every region's record (polarity,
//!   level, seed, area, variation, bounding box, centroid, ellipse, and the contour on request).
//! - **CSV**: one header line and one row per region with the same fields; the contour, on
//!   request, is one column of `x y` pairs separated by `;`.
//!
//! Numbers are written with Rust's shortest round-trip formatting, so reading a file back gives
//! the same values.

use std::io::Write;

use mser::{MserParams, Polarities, Polarity, Region, Variation};
use serde::{Deserialize, Serialize};

use crate::error::{Result, VisguideError};
use crate::features::Features;

/// The detector parameters as written.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ParamsRecord {
    /// Δ.
    pub delta: u8,
    /// Smallest region.
    pub min_area: usize,
    /// Largest region (absent: unlimited).
    pub max_area: Option<usize>,
    /// Largest variation.
    pub max_variation: f64,
    /// Duplicate suppression.
    pub min_diversity: f64,
    /// `dark`, `bright` or `both`.
    pub polarities: String,
    /// `symmetric` or `upward`.
    pub variation: String,
}

impl ParamsRecord {
    /// From the parameters.
    pub fn new(p: &MserParams) -> Self {
        ParamsRecord {
            delta: p.delta,
            min_area: p.min_area,
            max_area: (p.max_area != usize::MAX).then_some(p.max_area),
            max_variation: p.max_variation,
            min_diversity: p.min_diversity,
            polarities: match p.polarities {
                Polarities::Dark => "dark",
                Polarities::Bright => "bright",
                Polarities::Both => "both",
            }
            .into(),
            variation: match p.variation {
                Variation::Symmetric => "symmetric",
                Variation::Upward => "upward",
            }
            .into(),
        }
    }
}

/// One region as written.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RegionRecord {
    /// `dark` or `bright`.
    pub polarity: String,
    /// Threshold level.
    pub level: u8,
    /// First pixel in raster order.
    pub seed: (u32, u32),
    /// Pixels.
    pub area: u32,
    /// Stability measure.
    pub variation: f64,
    /// Inclusive bounding box `(x_min, y_min, x_max, y_max)`.
    pub bbox: (u32, u32, u32, u32),
    /// Centroid.
    pub centroid: (f64, f64),
    /// Oxford ellipse `(u, v, a, b, c)` of [`Region::ellipse`].
    pub ellipse: (f64, f64, f64, f64, f64),
    /// Outer contour, when asked for.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub contour: Option<Vec<(u32, u32)>>,
}

impl RegionRecord {
    /// From a region (and its contour). Errors: a region without an ellipse (moments no pixel
    /// set has; never one from the detector).
    pub fn new(r: &Region, contour: Option<&[(u32, u32)]>) -> Result<Self> {
        let e = r.ellipse()?;
        Ok(RegionRecord {
            polarity: match r.polarity {
                Polarity::Dark => "dark",
                Polarity::Bright => "bright",
            }
            .into(),
            level: r.level,
            seed: r.seed,
            area: r.area,
            variation: r.variation,
            bbox: (r.bbox.x_min, r.bbox.y_min, r.bbox.x_max, r.bbox.y_max),
            centroid: r.centroid(),
            ellipse: (e.u, e.v, e.a, e.b, e.c),
            contour: contour.map(<[_]>::to_vec),
        })
    }
}

/// A JSON region file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RegionFile {
    /// The image, as given.
    pub image: String,
    /// Width and height.
    pub size: (u32, u32),
    /// Detector parameters.
    pub params: ParamsRecord,
    /// The regions, in the detector's order.
    pub regions: Vec<RegionRecord>,
}

/// Output format.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Format {
    /// Oxford `.mser`.
    Oxford,
    /// JSON.
    Json,
    /// CSV.
    Csv,
}

impl Format {
    /// The file extension.
    pub fn extension(self) -> &'static str {
        match self {
            Format::Oxford => "mser",
            Format::Json => "json",
            Format::Csv => "csv",
        }
    }
}

/// The CSV header.
pub const CSV_HEADER: &str = "index,polarity,level,seed_x,seed_y,area,variation,x_min,y_min,x_max,y_max,centroid_x,centroid_y,u,v,a,b,c,contour";

fn werr(e: std::io::Error) -> VisguideError {
    VisguideError::Io {
        path: "<output>".into(),
        source: e,
    }
}

/// Writes the regions of one image in `format` (`with_contours`: JSON and CSV only; the Oxford
/// format has no place for them).
///
/// Errors: a region without an ellipse (moments no pixel set has), found before anything is
/// written, so `w` is left as it was; an I/O error of `w` itself.
pub fn write(
    w: &mut dyn Write,
    format: Format,
    image: &str,
    size: (u32, u32),
    params: &MserParams,
    f: &Features,
    with_contours: bool,
) -> Result<()> {
    match format {
        Format::Oxford => {
            let ellipses = f
                .regions
                .iter()
                .map(Region::ellipse)
                .collect::<mser::Result<Vec<_>>>()?;
            mser::write_regions(w, &ellipses)?;
        }
        Format::Json => {
            let file = RegionFile {
                image: image.into(),
                size,
                params: ParamsRecord::new(params),
                regions: records(f, with_contours)?,
            };
            serde_json::to_writer_pretty(&mut *w, &file).map_err(|e| werr(e.into()))?;
            writeln!(w).map_err(werr)?;
        }
        Format::Csv => {
            // Every record before the header: a refused region leaves `w` as it was.
            let records = records(f, with_contours)?;
            writeln!(w, "{CSV_HEADER}").map_err(werr)?;
            for (k, r) in records.iter().enumerate() {
                let contour = r.contour.as_ref().map_or(String::new(), |c| {
                    c.iter()
                        .map(|(x, y)| format!("{x} {y}"))
                        .collect::<Vec<_>>()
                        .join(";")
                });
                let (u, v, a, b, c) = r.ellipse;
                writeln!(
                    w,
                    "{k},{},{},{},{},{},{},{},{},{},{},{},{},{u},{v},{a},{b},{c},{contour}",
                    r.polarity,
                    r.level,
                    r.seed.0,
                    r.seed.1,
                    r.area,
                    r.variation,
                    r.bbox.0,
                    r.bbox.1,
                    r.bbox.2,
                    r.bbox.3,
                    r.centroid.0,
                    r.centroid.1,
                )
                .map_err(werr)?;
            }
        }
    }
    Ok(())
}

fn records(f: &Features, with_contours: bool) -> Result<Vec<RegionRecord>> {
    f.regions
        .iter()
        .enumerate()
        .map(|(k, r)| {
            let c = with_contours
                .then(|| f.contours.get(k).map(Vec::as_slice))
                .flatten();
            RegionRecord::new(r, c)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A region found by the detector, and one whose moments no pixel set has (`Features`'
    /// fields are public): the second has no ellipse.
    fn features_with_a_bad_region() -> (Features, MserParams) {
        let img = image::GrayImage::from_fn(40, 30, |x, y| {
            image::Luma([if (10..25).contains(&x) && (8..20).contains(&y) {
                30
            } else {
                220
            }])
        });
        let params = MserParams::default();
        let mut f = crate::features::detect(&img, &params).unwrap();
        assert!(!f.is_empty(), "the square is a region");
        let mut bad = f.regions[0].clone();
        // The moments of no pixel at all.
        bad.moments = mser::Moments::of_pixels(&[]).unwrap();
        assert!(bad.ellipse().is_err());
        f.regions.push(bad);
        f.frames.push(f.frames[0]);
        f.contours.push(f.contours[0].clone());
        (f, params)
    }

    /// A region without an ellipse is refused in every format, with or without contours, and
    /// nothing is written to the writer: what it held stays as it was. (The CSV header used to
    /// be written before the regions were checked, so a refused call left it in the output.)
    #[test]
    fn a_refused_write_leaves_the_writer_as_it_was() {
        let (f, params) = features_with_a_bad_region();
        for format in [Format::Oxford, Format::Json, Format::Csv] {
            for contours in [false, true] {
                let mut out = b"kept\n".to_vec();
                let r = write(&mut out, format, "a.png", (40, 30), &params, &f, contours);
                assert!(r.is_err(), "{format:?}, contours {contours}");
                assert_eq!(
                    String::from_utf8_lossy(&out),
                    "kept\n",
                    "{format:?}, contours {contours}"
                );
            }
        }
        // Without the bad region every format writes.
        let good = Features {
            regions: f.regions[..1].to_vec(),
            frames: f.frames[..1].to_vec(),
            contours: f.contours[..1].to_vec(),
        };
        for format in [Format::Oxford, Format::Json, Format::Csv] {
            let mut out = Vec::new();
            write(&mut out, format, "a.png", (40, 30), &params, &good, true).unwrap();
            assert!(!out.is_empty(), "{format:?}");
        }
    }
}
