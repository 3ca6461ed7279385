//! The model files of the command line: a JSON envelope `{"format", "version", …}` around the
//! method crates' own serialised models, so that a file from another program or another version
//! is refused with a clear message instead of being misread.
//!
//! - [`LwprFile`] (`visguide-lwpr`): column names and an [`lwpr::Lwpr`] model (the crate's own
//!   versioned JSON, validated on load).
//! - [`TrackModelFile`] (`visguide-cbt`): the CBT model ([`cbt_tracker::CbtModel`], validated as
//!   a whole on load), the baselines' calibration and the image extent it was learned on.

use std::path::Path;

use cbt_tracker::{Calibration, CbtModel};
use serde::{Deserialize, Serialize};

use crate::error::{Result, VisguideError, io};
use crate::output::atomic::write_bytes;

/// The version of both envelopes written by this build.
pub const MODEL_VERSION: u32 = 1;

/// Name of the LWPR envelope.
pub const LWPR_FORMAT: &str = "visguide-lwpr";
/// Name of the CBT envelope.
pub const CBT_FORMAT: &str = "visguide-cbt";

#[derive(Deserialize)]
struct Header {
    format: Option<String>,
    version: Option<u32>,
}

/// Reads a model file's JSON and checks its envelope.
fn read_checked(path: &Path, format: &str) -> Result<String> {
    let bad = |reason: String| VisguideError::Model {
        path: path.to_path_buf(),
        reason,
    };
    if path.is_dir() {
        return Err(bad("it is a directory, expected a model file".into()));
    }
    let text = std::fs::read_to_string(path).map_err(io(path))?;
    let h: Header = serde_json::from_str(&text).map_err(|e| bad(format!("not JSON: {e}")))?;
    match (h.format.as_deref(), h.version) {
        (Some(f), _) if f != format => Err(bad(format!("it is a `{f}` file, expected `{format}`"))),
        (None, _) => Err(bad(format!(
            "no `format` field; expected a `{format}` file"
        ))),
        (_, Some(v)) if v != MODEL_VERSION => Err(bad(format!(
            "version {v}, but this visguide reads version {MODEL_VERSION}"
        ))),
        (_, None) => Err(bad("no `version` field".into())),
        _ => Ok(text),
    }
}

/// A saved LWPR model with its column names.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct LwprFile {
    /// Always [`LWPR_FORMAT`].
    pub format: String,
    /// Always [`MODEL_VERSION`] when written.
    pub version: u32,
    /// Input column names.
    pub inputs: Vec<String>,
    /// Output column names.
    pub outputs: Vec<String>,
    /// The model, in `lwpr`'s own JSON.
    pub model: serde_json::Value,
}

impl LwprFile {
    /// Wraps a model.
    pub fn new(inputs: Vec<String>, outputs: Vec<String>, model: &lwpr::Lwpr) -> Result<Self> {
        let model = serde_json::from_str(&model.to_json()).map_err(|e| VisguideError::Invalid {
            name: "model",
            reason: e.to_string(),
        })?;
        Ok(LwprFile {
            format: LWPR_FORMAT.into(),
            version: MODEL_VERSION,
            inputs,
            outputs,
            model,
        })
    }

    /// Saves atomically.
    pub fn save(&self, path: &Path) -> Result<()> {
        let text = serde_json::to_string(self).map_err(|e| VisguideError::Invalid {
            name: "model",
            reason: e.to_string(),
        })?;
        write_bytes(path, text.as_bytes())
    }

    /// Loads and checks a file; returns it with the decoded model.
    pub fn load(path: &Path) -> Result<(Self, lwpr::Lwpr)> {
        let text = read_checked(path, LWPR_FORMAT)?;
        let bad = |reason: String| VisguideError::Model {
            path: path.to_path_buf(),
            reason,
        };
        let file: LwprFile = serde_json::from_str(&text).map_err(|e| bad(e.to_string()))?;
        let model =
            lwpr::Lwpr::from_json(&file.model.to_string()).map_err(|e| bad(e.to_string()))?;
        if model.n_in() != file.inputs.len() || model.n_out() != file.outputs.len() {
            return Err(bad(format!(
                "{} input and {} output names for a {}→{} model",
                file.inputs.len(),
                file.outputs.len(),
                model.n_in(),
                model.n_out()
            )));
        }
        Ok((file, model))
    }
}

/// A saved tracking model: CBT, the baselines' calibration, the image extent.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct TrackModelFile {
    /// Always [`CBT_FORMAT`].
    pub format: String,
    /// Always [`MODEL_VERSION`] when written.
    pub version: u32,
    /// `[x_lo, x_hi, y_lo, y_hi]` of the grid.
    pub extent: [f64; 4],
    /// Training sequences it was learned from.
    pub sequences: usize,
    /// The learned CBT model.
    pub cbt: CbtModel,
    /// Kalman / particle-filter calibration from the same training data.
    pub calibration: Calibration,
}

impl TrackModelFile {
    /// Saves atomically.
    pub fn save(&self, path: &Path) -> Result<()> {
        let text = serde_json::to_string(self).map_err(|e| VisguideError::Invalid {
            name: "model",
            reason: e.to_string(),
        })?;
        write_bytes(path, text.as_bytes())
    }

    /// Loads and checks a file (the CBT model and the calibration are validated by their own
    /// deserialisers): the extent must be finite with `lo < hi` on both axes and lie within
    /// the CBT model's 2-D state grid (it is the grid's range when `visguide track learn`
    /// writes it).
    pub fn load(path: &Path) -> Result<Self> {
        let text = read_checked(path, CBT_FORMAT)?;
        let bad = |reason: String| VisguideError::Model {
            path: path.to_path_buf(),
            reason,
        };
        let file: TrackModelFile = serde_json::from_str(&text).map_err(|e| bad(e.to_string()))?;
        let space = file.cbt.space();
        if space.dims() != 2 {
            return Err(bad(format!(
                "a tracking model needs a 2-D state grid, this one has {} dimension(s)",
                space.dims()
            )));
        }
        for d in 0..2 {
            let (lo, hi) = (file.extent[2 * d], file.extent[2 * d + 1]);
            let (glo, ghi) = space.state_basis(d).representable_range();
            let slack = 1e-9 * (ghi - glo);
            if !(lo.is_finite()
                && hi.is_finite()
                && lo < hi
                && lo >= glo - slack
                && hi <= ghi + slack)
            {
                return Err(bad(format!(
                    "extent [{lo}, {hi}] on axis {d} is not a finite range within the model's grid [{glo}, {ghi}]"
                )));
            }
        }
        Ok(file)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lwpr_round_trip_and_foreign_files_are_refused() {
        let dir = std::env::temp_dir().join(format!("visguide-models-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let mut m = lwpr::LwprBuilder::new(1, 1).build().unwrap();
        for k in 0..200 {
            let x = k as f64 / 200.0;
            m.update(&[x], &[2.0 * x]).unwrap();
        }
        let p = dir.join("m.json");
        LwprFile::new(vec!["x".into()], vec!["y".into()], &m)
            .unwrap()
            .save(&p)
            .unwrap();
        let (f, back) = LwprFile::load(&p).unwrap();
        assert_eq!(back, m);
        assert_eq!(f.inputs, vec!["x"]);
        let text = std::fs::read_to_string(&p).unwrap();
        std::fs::write(&p, text.replacen("\"version\":1", "\"version\":7", 1)).unwrap();
        let e = LwprFile::load(&p).unwrap_err().to_string();
        assert!(e.contains("version 7"), "{e}");
        std::fs::write(&p, "{\"format\":\"visguide-cbt\",\"version\":1}").unwrap();
        assert!(
            LwprFile::load(&p)
                .unwrap_err()
                .to_string()
                .contains("visguide-cbt")
        );
        std::fs::write(&p, "garbage").unwrap();
        assert!(
            LwprFile::load(&p)
                .unwrap_err()
                .to_string()
                .contains("not JSON")
        );
        assert!(TrackModelFile::load(&dir).is_err());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
