//! placeholder docs
#![deny(missing_docs)]

mod contour;
mod detector;
mod error;
mod image;
mod oxford;
mod params;
mod pixels;
mod region;
mod select;
mod tree;

pub use contour::trace_outer_contour;
#[cfg(feature = "rayon")]
pub use detector::detect_many;
pub use detector::{Mser, detect};
pub use error::{MserError, Result};
pub use image::{GrayView, load_gray, luminance, to_gray};
pub use oxford::{OxfordRegion, load_regions, read_regions, save_regions, write_regions};
pub use params::{MserParams, Polarities, Variation};
pub use pixels::flood_pixels;
pub use region::{BoundingBox, Ellipse, Moments, Polarity, Region};

#[cfg(feature = "opencv")]
mod opencv_peer;
#[cfg(feature = "opencv")]
pub use opencv_peer::{OpenCvMser, opencv_version, set_opencv_threads};
