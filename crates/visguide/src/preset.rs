//! MSER settings by name, with any parameter overridden: `opencv` (OpenCV's `MSER::create()`
//! defaults), `larsson2009` (Paper A's setting, [`mser::MserParams::larsson2009`]) and `vlfeat`
//! (VLFeat's `vl_mser` defaults: Δ = 5, upward variation, areas relative to the image — at least
//! 3·10⁻⁵ of its pixels (and at least 1) and at most 0.75 of them (but never below the minimum,
//! which on an image of one to three pixels is more than 0.75 of them) —, max variation 0.25,
//! min diversity 0.2, both polarities). Relative areas make a setting depend on the image size, so a setting is
//! resolved per image by [`MserSettings::resolve`].

use std::fmt;
use std::str::FromStr;

use mser::{MserParams, Polarities, Variation};

use crate::error::{Result, VisguideError};

/// A named MSER setting.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Preset {
    /// OpenCV 4.x `MSER::create()`: Δ 5, areas 60 ..= 14400, max variation 0.25, min diversity
    /// 0.2, symmetric variation.
    Opencv,
    /// Paper A (Larsson et al. 2009): Δ 15, min area 50, no max area, otherwise OpenCV's.
    #[default]
    Larsson2009,
    /// VLFeat `vl_mser` defaults (relative areas, upward variation).
    Vlfeat,
}

impl Preset {
    /// Every preset, in the order of the documentation.
    pub const ALL: [Preset; 3] = [Preset::Opencv, Preset::Larsson2009, Preset::Vlfeat];

    /// Its name on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Preset::Opencv => "opencv",
            Preset::Larsson2009 => "larsson2009",
            Preset::Vlfeat => "vlfeat",
        }
    }

    /// The parameters for a `width × height` image.
    pub fn params(self, width: u32, height: u32) -> MserParams {
        match self {
            Preset::Opencv => MserParams::opencv(),
            Preset::Larsson2009 => MserParams::larsson2009(),
            Preset::Vlfeat => {
                let pixels = width as f64 * height as f64;
                let min_area = ((3e-5 * pixels).ceil() as usize).max(1);
                let max_area = ((0.75 * pixels).floor() as usize).max(min_area);
                MserParams {
                    delta: 5,
                    min_area,
                    max_area,
                    max_variation: 0.25,
                    min_diversity: 0.2,
                    polarities: Polarities::Both,
                    variation: Variation::Upward,
                }
            }
        }
    }
}

impl fmt::Display for Preset {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Preset {
    type Err = VisguideError;

    fn from_str(s: &str) -> Result<Self> {
        Preset::ALL
            .into_iter()
            .find(|p| p.name() == s)
            .ok_or_else(|| VisguideError::Invalid {
                name: "preset",
                reason: format!("`{s}`: expected opencv, larsson2009 or vlfeat"),
            })
    }
}

/// A preset with optional overrides of every parameter.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct MserSettings {
    /// The base setting.
    pub preset: Preset,
    /// Δ.
    pub delta: Option<u8>,
    /// Smallest region, pixels.
    pub min_area: Option<usize>,
    /// Largest region, pixels.
    pub max_area: Option<usize>,
    /// Largest variation.
    pub max_variation: Option<f64>,
    /// Duplicate suppression.
    pub min_diversity: Option<f64>,
    /// Polarities.
    pub polarities: Option<Polarities>,
    /// Variation measure.
    pub variation: Option<Variation>,
}

impl MserSettings {
    /// A preset without overrides.
    pub fn preset(preset: Preset) -> Self {
        MserSettings {
            preset,
            ..Self::default()
        }
    }

    /// The checked parameters for a `width × height` image.
    pub fn resolve(&self, width: u32, height: u32) -> Result<MserParams> {
        let mut p = self.preset.params(width, height);
        if let Some(v) = self.delta {
            p.delta = v;
        }
        if let Some(v) = self.min_area {
            p.min_area = v;
        }
        if let Some(v) = self.max_area {
            p.max_area = v;
        }
        if let Some(v) = self.max_variation {
            p.max_variation = v;
        }
        if let Some(v) = self.min_diversity {
            p.min_diversity = v;
        }
        if let Some(v) = self.polarities {
            p.polarities = v;
        }
        if let Some(v) = self.variation {
            p.variation = v;
        }
        p.validate()?;
        Ok(p)
    }

    /// Whether the parameters do not depend on the image size (so one resolution serves all).
    pub fn is_size_independent(&self) -> bool {
        self.preset != Preset::Vlfeat || (self.min_area.is_some() && self.max_area.is_some())
    }
}

/// Parses `dark`, `bright` or `both`.
pub fn parse_polarities(s: &str) -> Result<Polarities> {
    match s {
        "dark" => Ok(Polarities::Dark),
        "bright" => Ok(Polarities::Bright),
        "both" => Ok(Polarities::Both),
        _ => Err(VisguideError::Invalid {
            name: "polarities",
            reason: format!("`{s}`: expected dark, bright or both"),
        }),
    }
}

/// Parses `symmetric` or `upward`.
pub fn parse_variation(s: &str) -> Result<Variation> {
    match s {
        "symmetric" => Ok(Variation::Symmetric),
        "upward" => Ok(Variation::Upward),
        _ => Err(VisguideError::Invalid {
            name: "variation",
            reason: format!("`{s}`: expected symmetric or upward"),
        }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn presets_and_overrides() {
        let s = MserSettings::preset(Preset::Larsson2009);
        assert_eq!(s.resolve(10, 10).unwrap(), MserParams::larsson2009());
        assert_eq!(
            MserSettings::preset(Preset::Opencv).resolve(1, 1).unwrap(),
            MserParams::opencv()
        );
        let v = Preset::Vlfeat.params(800, 640);
        assert_eq!((v.min_area, v.max_area), (16, 384_000));
        assert_eq!(v.variation, Variation::Upward);
        let o = MserSettings {
            max_variation: Some(0.5),
            delta: Some(7),
            ..s.clone()
        };
        let p = o.resolve(5, 5).unwrap();
        assert_eq!((p.delta, p.max_variation, p.min_area), (7, 0.5, 50));
        let bad = MserSettings {
            min_diversity: Some(2.0),
            ..s
        };
        assert!(bad.resolve(5, 5).is_err());
        for p in Preset::ALL {
            assert_eq!(p.name().parse::<Preset>().unwrap(), p);
        }
        assert!("sift".parse::<Preset>().is_err());
        assert!(!MserSettings::preset(Preset::Vlfeat).is_size_independent());
    }
}
