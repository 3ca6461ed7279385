//! Regions together with their pixel lists, as slices of the flood order
//! ([`Mser::detect_with_pixels`](crate::Mser::detect_with_pixels)).

use crate::region::{Polarity, Region};

/// Detected regions and, for each, its pixels `(x, y)`: a slice of the detector's flood order
/// (one array per polarity, borrowed from the [`Mser`](crate::Mser) that produced it; nested
/// regions share pixels). Pixels are in flood order, not raster order; each list holds exactly
/// the pixels of [`Region::pixels`].
#[derive(Debug, Clone)]
pub struct RegionsWithPixels<'a> {
    regions: Vec<Region>,
    /// Start of each region's run in its polarity's array.
    starts: Vec<u32>,
    /// Dark, bright.
    xy: [&'a [(u32, u32)]; 2],
}

impl<'a> RegionsWithPixels<'a> {
    /// The dark and the bright regions (each with its run's start), dark ones indexing `xy[0]`,
    /// bright ones `xy[1]`.
    pub(crate) fn new(
        dark: Vec<(Region, u32)>,
        bright: Vec<(Region, u32)>,
        xy: [&'a [(u32, u32)]; 2],
    ) -> Self {
        debug_assert!(dark.iter().all(|(r, _)| r.polarity == Polarity::Dark));
        debug_assert!(bright.iter().all(|(r, _)| r.polarity == Polarity::Bright));
        let (regions, starts) = dark.into_iter().chain(bright).unzip();
        RegionsWithPixels {
            regions,
            starts,
            xy,
        }
    }

    /// The regions, in the order of [`Mser::detect`](crate::Mser::detect) and equal to its.
    pub fn regions(&self) -> &[Region] {
        &self.regions
    }

    /// Number of regions.
    pub fn len(&self) -> usize {
        self.regions.len()
    }

    /// True when no region was found.
    pub fn is_empty(&self) -> bool {
        self.regions.is_empty()
    }

    /// The pixels of region `i`, in flood order. Panics if `i >= len()`, like slice indexing.
    pub fn pixels(&self, i: usize) -> &'a [(u32, u32)] {
        let r = &self.regions[i];
        let xy = self.xy[(r.polarity == Polarity::Bright) as usize];
        let s = self.starts[i] as usize;
        &xy[s..s + r.area as usize]
    }

    /// Every region with its pixels.
    pub fn iter(&self) -> impl ExactSizeIterator<Item = (&Region, &'a [(u32, u32)])> + '_ {
        (0..self.len()).map(|i| (&self.regions[i], self.pixels(i)))
    }

    /// The regions alone, releasing the borrow of the detector.
    pub fn into_regions(self) -> Vec<Region> {
        self.regions
    }
}
