//! Detector parameters: OpenCV's `MSER::create` defaults and the thesis setting of Paper A.

use crate::error::{MserError, Result};

/// Which regions to detect.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Polarities {
    /// Only regions darker than their surround (VLFeat `dark_on_bright`, OpenCV's first pass).
    Dark,
    /// Only regions brighter than their surround (VLFeat `bright_on_dark`, OpenCV `pass2Only`).
    Bright,
    /// Both, dark regions first.
    Both,
}

/// How the area variation of a region is measured (see the crate docs for the exact definitions).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Variation {
    /// Matas et al. (2002): `v(Q_g) = (|Q_{g+Δ}| − |Q_{g−Δ}|) / |Q_g|`, where `Q_{g−Δ}` follows the
    /// largest child. The measure OpenCV 3+ uses on grey images (up to the detail explained in the
    /// crate docs).
    Symmetric,
    /// VLFeat's one-sided measure `v(Q_g) = (|Q_{g+Δ}| − |Q_g|) / |Q_g|`, which needs no choice of
    /// child.
    Upward,
}

/// Parameters of the detector, with the meaning of OpenCV's `MSER::create(delta, min_area,
/// max_area, max_variation, min_diversity)` (grey-image parameters only).
#[derive(Debug, Clone, PartialEq)]
pub struct MserParams {
    /// Δ: the stability test compares regions Δ grey levels apart. At least 1.
    pub delta: u8,
    /// Smallest reported region, in pixels. At least 1.
    pub min_area: usize,
    /// Largest reported region, in pixels. At least `min_area`.
    pub max_area: usize,
    /// Largest accepted variation `v` (finite, non-negative).
    pub max_variation: f64,
    /// A region is dropped when it contains a smaller selected region that covers more than
    /// `1 − min_diversity` of it, i.e. `(|Q| − |D|) / |Q| < min_diversity`. In `[0, 1]`; 0 keeps
    /// all nested regions.
    pub min_diversity: f64,
    /// Which polarities to detect.
    pub polarities: Polarities,
    /// Which variation measure to use.
    pub variation: Variation,
}

impl Default for MserParams {
    /// OpenCV's defaults: Δ = 5, areas 60..=14400, max variation 0.25, min diversity 0.2, both
    /// polarities, symmetric variation.
    fn default() -> Self {
        MserParams {
            delta: 5,
            min_area: 60,
            max_area: 14_400,
            max_variation: 0.25,
            min_diversity: 0.2,
            polarities: Polarities::Both,
            variation: Variation::Symmetric,
        }
    }
}

impl MserParams {
    /// OpenCV's `MSER::create()` defaults (the same as [`Default`]).
    pub fn opencv() -> Self {
        Self::default()
    }

    /// The setting of Paper A (Larsson, Felsberg & Forssén 2009, footnote 3: "minimum margin = 30
    /// and minimum region size = 50"): Δ = 15 with the [`Variation::Symmetric`] measure, so the
    /// stability window `[g − Δ, g + Δ]` is 30 grey levels wide, and `min_area = 50`. No largest
    /// size is named in the paper, so `max_area` is unlimited (the whole-image region is never
    /// reported anyway); `max_variation` and `min_diversity` keep OpenCV's defaults. The crate
    /// docs ("The thesis setting") give the reasoning.
    pub fn larsson2009() -> Self {
        MserParams {
            delta: 15,
            min_area: 50,
            max_area: usize::MAX,
            ..Self::default()
        }
    }

    /// Checks the parameters; every detection entry point calls this.
    pub fn validate(&self) -> Result<()> {
        let bad = |name, reason: String| Err(MserError::InvalidParameter { name, reason });
        if self.delta == 0 {
            return bad("delta", "must be at least 1".into());
        }
        if self.min_area == 0 {
            return bad("min_area", "must be at least 1".into());
        }
        if self.min_area > self.max_area {
            return bad(
                "min_area",
                format!("min_area {} > max_area {}", self.min_area, self.max_area),
            );
        }
        if !self.max_variation.is_finite() || self.max_variation < 0.0 {
            return bad(
                "max_variation",
                format!("{} is not a finite non-negative number", self.max_variation),
            );
        }
        if !(0.0..=1.0).contains(&self.min_diversity) {
            return bad(
                "min_diversity",
                format!("{} is not in [0, 1]", self.min_diversity),
            );
        }
        Ok(())
    }
}
