//! `--preset` and the MSER parameters of `cargo xtask eval paper-a` (the same options as
//! `visguide regions` / `visguide match`, resolved by `visguide::MserSettings`).

use clap::Args;
use visguide::preset::{Preset, parse_polarities, parse_variation};
use visguide::{MserSettings, VisguideError};

/// The MSER setting of the study.
#[derive(Args, Clone, Debug, Default)]
pub struct MserOptions {
    /// Base setting: larsson2009 (Paper A, the default and the fixtures' setting), opencv
    /// (OpenCV's MSER::create defaults) or vlfeat (vl_mser defaults).
    #[arg(long, default_value = "larsson2009", value_parser = parse_preset)]
    pub preset: Preset,
    /// Delta (grey levels).
    #[arg(long)]
    pub delta: Option<u8>,
    /// Smallest region, pixels.
    #[arg(long)]
    pub min_area: Option<usize>,
    /// Largest region, pixels.
    #[arg(long)]
    pub max_area: Option<usize>,
    /// Largest accepted variation.
    #[arg(long)]
    pub max_variation: Option<f64>,
    /// Duplicate suppression in [0, 1].
    #[arg(long)]
    pub min_diversity: Option<f64>,
    /// dark, bright or both.
    #[arg(long, value_parser = |s: &str| parse_polarities(s).map_err(|e| e.to_string()))]
    pub polarities: Option<mser::Polarities>,
    /// symmetric or upward.
    #[arg(long, value_parser = |s: &str| parse_variation(s).map_err(|e| e.to_string()))]
    pub variation: Option<mser::Variation>,
}

fn parse_preset(s: &str) -> Result<Preset, String> {
    s.parse().map_err(|e: VisguideError| e.to_string())
}

impl MserOptions {
    /// The settings.
    pub fn settings(&self) -> MserSettings {
        MserSettings {
            preset: self.preset,
            delta: self.delta,
            min_area: self.min_area,
            max_area: self.max_area,
            max_variation: self.max_variation,
            min_diversity: self.min_diversity,
            polarities: self.polarities,
            variation: self.variation,
        }
    }
}
