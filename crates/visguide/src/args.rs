//! Command-line arguments shared by the `visguide` binary and other programs built on this
//! crate (feature `cli`, on by default): [`MserArgs`], the MSER setting as a clap
//! [`Args`] group (`--preset` and every parameter), flattened into `visguide
//! regions`, `visguide match`, `visguide eval` and `cargo xtask eval paper-a`.

use clap::Args;

use crate::MserSettings;
use crate::preset::{Preset, parse_polarities, parse_variation};

/// The MSER setting: a preset and any parameter overridden (`Default`: Paper A's setting,
/// nothing overridden, as the command line's defaults).
#[derive(Args, Debug, Clone, Default)]
#[command(next_help_heading = "MSER setting")]
pub struct MserArgs {
    /// Base setting: `opencv` (OpenCV MSER::create defaults: delta 5, areas 60..14400),
    /// `larsson2009` (Paper A: delta 15, min area 50, no max area) or `vlfeat` (vl_mser
    /// defaults: delta 5, upward variation, areas 3e-5..0.75 of the image).
    #[arg(long, default_value = "larsson2009", value_parser = parse_preset)]
    pub preset: Preset,
    /// Delta: grey levels between the regions compared by the stability test (≥ 1).
    #[arg(long, value_name = "LEVELS")]
    pub delta: Option<u8>,
    /// Smallest region, pixels (≥ 1).
    #[arg(long, value_name = "PIXELS")]
    pub min_area: Option<usize>,
    /// Largest region, pixels.
    #[arg(long, value_name = "PIXELS")]
    pub max_area: Option<usize>,
    /// Largest accepted area variation (≥ 0).
    #[arg(long, value_name = "V")]
    pub max_variation: Option<f64>,
    /// Duplicate suppression in [0, 1]: drop a region when a selected region inside it covers
    /// more than 1 − this of it.
    #[arg(long, value_name = "D")]
    pub min_diversity: Option<f64>,
    /// Which regions: dark, bright or both.
    #[arg(long, value_parser = parse_pol)]
    pub polarities: Option<mser::Polarities>,
    /// Variation measure: symmetric (Matas, OpenCV) or upward (VLFeat).
    #[arg(long, value_parser = parse_var)]
    pub variation: Option<mser::Variation>,
}

fn parse_preset(s: &str) -> Result<Preset, String> {
    s.parse().map_err(|e: crate::VisguideError| e.to_string())
}
fn parse_pol(s: &str) -> Result<mser::Polarities, String> {
    parse_polarities(s).map_err(|e| e.to_string())
}
fn parse_var(s: &str) -> Result<mser::Variation, String> {
    parse_variation(s).map_err(|e| e.to_string())
}

impl MserArgs {
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
