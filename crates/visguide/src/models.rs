//! The model files of the command line: a JSON envelope `{"format", "version", …}` around the
//! method crates' own serialised models, so that a file from another program or another version
//! is refused with a clear message instead of being misread.
//!
//! - [`LwprFile`] (`visguide-lwpr`): column names and an [`lwpr::Lwpr`] model (the crate's own
//!   versioned JSON, validated on load).
//! - [`TrackModelFile`] (`visguide-cbt`): the CBT model ([`cbt_tracker::CbtModel`], validated as
//!   a whole on load), the baselines' calibration and the image extent it was learned on (the
//!   contents are checked whenever the file is deserialised, [`TrackModelFile::validate`]).

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
    let Some(f) = h.format.as_deref() else {
        return Err(bad(format!(
            "no `format` field; expected a `{format}` file"
        )));
    };
    // Another format is named before a missing version.
    if let Some(reason) = envelope_fault(f, h.version.unwrap_or(MODEL_VERSION), format) {
        return Err(bad(reason));
    }
    if h.version.is_none() {
        return Err(bad("no `version` field".into()));
    }
    Ok(text)
}

/// What is wrong with a file's envelope (`format`, `version`) for a `want` file, if anything.
fn envelope_fault(format: &str, version: u32, want: &str) -> Option<String> {
    if format != want {
        Some(format!("it is a `{format}` file, expected `{want}`"))
    } else if version != MODEL_VERSION {
        Some(format!(
            "version {version}, but this visguide reads version {MODEL_VERSION}"
        ))
    } else {
        None
    }
}

/// Refuses to save what loading would refuse (the fields are public): the envelope, then
/// `contents`' own check.
fn check_saved(
    format: &str,
    version: u32,
    want: &str,
    contents: impl FnOnce() -> std::result::Result<(), String>,
) -> Result<()> {
    envelope_fault(format, version, want)
        .map_or_else(contents, Err)
        .map_err(|reason| VisguideError::Invalid {
            name: "model",
            reason,
        })
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

    /// Saves atomically. What [`Self::load`] would refuse (the fields are public: another
    /// format or version, a model `lwpr` does not read, column names of another count) is
    /// refused first ([`VisguideError::Invalid`] naming `model`), and no file is touched.
    pub fn save(&self, path: &Path) -> Result<()> {
        check_saved(&self.format, self.version, LWPR_FORMAT, || {
            self.decode().map(drop)
        })?;
        let text = serde_json::to_string(self).map_err(|e| VisguideError::Invalid {
            name: "model",
            reason: e.to_string(),
        })?;
        write_bytes(path, text.as_bytes())
    }

    /// The model, decoded and checked against the column names.
    fn decode(&self) -> std::result::Result<lwpr::Lwpr, String> {
        let model = lwpr::Lwpr::from_json(&self.model.to_string()).map_err(|e| e.to_string())?;
        if model.n_in() != self.inputs.len() || model.n_out() != self.outputs.len() {
            return Err(format!(
                "{} input and {} output names for a {}→{} model",
                self.inputs.len(),
                self.outputs.len(),
                model.n_in(),
                model.n_out()
            ));
        }
        Ok(model)
    }

    /// Loads and checks a file; returns it with the decoded model.
    pub fn load(path: &Path) -> Result<(Self, lwpr::Lwpr)> {
        let text = read_checked(path, LWPR_FORMAT)?;
        let bad = |reason: String| VisguideError::Model {
            path: path.to_path_buf(),
            reason,
        };
        let file: LwprFile = serde_json::from_str(&text).map_err(|e| bad(e.to_string()))?;
        let model = file.decode().map_err(bad)?;
        Ok((file, model))
    }
}

/// A saved tracking model: CBT, the baselines' calibration, the image extent.
///
/// Deserialisation applies [`TrackModelFile::validate`] (a 2-D state grid, the extent a finite
/// range within it; [`VisguideError::Invalid`] naming `cbt` or `extent`), so a file read by
/// `serde` alone cannot hold what [`TrackModelFile::load`] refuses (it used to: the extent
/// was checked by the loader only). The envelope (`format`, `version`) is checked by the
/// loader alone, before.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(try_from = "TrackModelSpec")]
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

/// The serialised form of a [`TrackModelFile`], checked by [`TrackModelFile::validate`] on
/// deserialisation.
#[derive(Deserialize)]
struct TrackModelSpec {
    format: String,
    version: u32,
    extent: [f64; 4],
    sequences: usize,
    cbt: CbtModel,
    calibration: Calibration,
}

impl TryFrom<TrackModelSpec> for TrackModelFile {
    type Error = VisguideError;
    fn try_from(s: TrackModelSpec) -> Result<Self> {
        let file = TrackModelFile {
            format: s.format,
            version: s.version,
            extent: s.extent,
            sequences: s.sequences,
            cbt: s.cbt,
            calibration: s.calibration,
        };
        file.validate()?;
        Ok(file)
    }
}

impl TrackModelFile {
    /// Checks the contents: the CBT model's state grid is 2-D (`cbt`), and the extent is finite
    /// with `lo < hi` on both axes and lies within that grid (`extent`; it is the grid's range
    /// when `visguide track learn` writes it); [`VisguideError::Invalid`] otherwise.
    /// Deserialisation applies it.
    pub fn validate(&self) -> Result<()> {
        let space = self.cbt.space();
        if space.dims() != 2 {
            return Err(VisguideError::Invalid {
                name: "cbt",
                reason: format!(
                    "a tracking model needs a 2-D state grid, this one has {} dimension(s)",
                    space.dims()
                ),
            });
        }
        for d in 0..2 {
            let (lo, hi) = (self.extent[2 * d], self.extent[2 * d + 1]);
            let (glo, ghi) = space.state_basis(d).representable_range();
            let slack = 1e-9 * (ghi - glo);
            if !(lo.is_finite()
                && hi.is_finite()
                && lo < hi
                && lo >= glo - slack
                && hi <= ghi + slack)
            {
                return Err(VisguideError::Invalid {
                    name: "extent",
                    reason: format!(
                        "[{lo}, {hi}] on axis {d} is not a finite range within the model's grid [{glo}, {ghi}]"
                    ),
                });
            }
        }
        Ok(())
    }

    /// Saves atomically. What [`Self::load`] would refuse (the fields are public: another
    /// format or version, or what [`Self::validate`] refuses) is refused first
    /// ([`VisguideError::Invalid`]), and no file is touched.
    pub fn save(&self, path: &Path) -> Result<()> {
        check_saved(&self.format, self.version, CBT_FORMAT, || Ok(()))?;
        self.validate()?;
        let text = serde_json::to_string(self).map_err(|e| VisguideError::Invalid {
            name: "model",
            reason: e.to_string(),
        })?;
        write_bytes(path, text.as_bytes())
    }

    /// Loads and checks a file: its envelope, then its contents as deserialisation checks them
    /// (the CBT model and the calibration by their own deserialisers, the rest by
    /// [`Self::validate`]: a 2-D state grid, an extent that is a finite range with `lo < hi` on
    /// both axes within that grid). Errors: [`VisguideError::Model`] naming the file.
    pub fn load(path: &Path) -> Result<Self> {
        let text = read_checked(path, CBT_FORMAT)?;
        serde_json::from_str(&text).map_err(|e| VisguideError::Model {
            path: path.to_path_buf(),
            reason: e.to_string(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A tracking model file of a tracker learned on a 100×80 image canvas (the grid's range,
    /// as `visguide track learn` writes it).
    fn track_file() -> TrackModelFile {
        let walk: crate::pipeline::Walk = (0..30)
            .map(|k| {
                let t = [40.0 + f64::from(k % 7), 30.0 + f64::from(k % 5)];
                let vote = crate::pipeline::Vote {
                    position: [t[0] + 0.3 * f64::from(k % 3), t[1] - 0.2 * f64::from(k % 2)],
                    weight: 0.8,
                    error: 0.05,
                    rotation: 0.0,
                    region: 0,
                };
                (Some(t), vec![vote])
            })
            .collect();
        let cbt = crate::pipeline::learn_tracker([100, 80], &[walk]).unwrap();
        TrackModelFile {
            format: CBT_FORMAT.into(),
            version: MODEL_VERSION,
            extent: [0.0, 100.0, 0.0, 80.0],
            sequences: 1,
            cbt,
            calibration: Calibration {
                accel_sigma: 1.0,
                meas_sigma: 0.5,
                p_detect: 0.9,
                clutter_rate: 0.2,
            },
        }
    }

    /// Deserialising a tracking model file applies the checks `TrackModelFile::load` makes (an
    /// extent that is not a finite range within the model's grid is a typed error); it used to
    /// give a file whose extent lay off or across the grid, which saved, and then did not load.
    /// A valid file reads back to the same bytes.
    #[test]
    fn a_track_model_file_with_an_extent_off_its_grid_does_not_deserialise() {
        let text = serde_json::to_string(&track_file()).unwrap();
        let back: TrackModelFile = serde_json::from_str(&text).unwrap();
        assert_eq!(serde_json::to_string(&back).unwrap(), text);
        let v: serde_json::Value = serde_json::from_str(&text).unwrap();
        for extent in [
            [100.0, 0.0, 0.0, 80.0],
            [0.0, 100.0, 80.0, 80.0],
            [1e6, 2e6, 0.0, 80.0],
            [-10.0, 100.0, 0.0, 80.0],
            [0.0, 100.0, 0.0, 1e300],
        ] {
            let mut e = v.clone();
            e["extent"] = serde_json::json!(extent);
            let r = serde_json::from_str::<TrackModelFile>(&e.to_string());
            let err = r.err().unwrap_or_else(|| panic!("{extent:?} was taken"));
            assert!(err.to_string().contains("extent"), "{err}");
        }
    }

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
        // A missing field is named; another format is named before a missing version.
        for (text, want) in [
            ("{\"format\":\"visguide-lwpr\"}", "no `version` field"),
            ("{\"version\":1}", "no `format` field"),
            ("{\"format\":\"visguide-cbt\"}", "`visguide-cbt` file"),
        ] {
            std::fs::write(&p, text).unwrap();
            let e = LwprFile::load(&p).unwrap_err().to_string();
            assert!(e.contains(want), "{text}: {e}");
        }
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

    /// Saving refuses what loading would refuse (the fields are public), before any file is
    /// touched: each used to be written, over a good file too, as a file that did not load.
    #[test]
    fn a_file_that_would_not_load_is_not_saved() {
        let dir = std::env::temp_dir().join(format!("visguide-unsaved-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let listing = || {
            let mut v: Vec<_> = std::fs::read_dir(&dir)
                .unwrap()
                .map(|e| {
                    let p = e.unwrap().path();
                    (p.clone(), std::fs::read(p).unwrap())
                })
                .collect();
            v.sort();
            v
        };
        let m = lwpr::LwprBuilder::new(2, 1).build().unwrap();
        let good = LwprFile::new(vec!["a".into(), "b".into()], vec!["y".into()], &m).unwrap();
        let (lp, tp) = (dir.join("m.json"), dir.join("t.json"));
        good.save(&lp).unwrap();
        assert!(LwprFile::load(&lp).is_ok());
        let track = track_file();
        track.save(&tp).unwrap();
        assert!(TrackModelFile::load(&tp).is_ok());
        let before = listing();
        let mut bad_lwpr = Vec::new();
        for edit in [
            |f: &mut LwprFile| f.format = CBT_FORMAT.into(),
            |f: &mut LwprFile| f.version = 7,
            |f: &mut LwprFile| f.inputs.pop().map(drop).unwrap(),
            |f: &mut LwprFile| f.outputs.push("z".into()),
            |f: &mut LwprFile| f.model = serde_json::json!({"not": "a model"}),
        ] {
            let mut f = good.clone();
            edit(&mut f);
            bad_lwpr.push(f);
        }
        for f in &bad_lwpr {
            for path in [&lp, &dir.join("new.json")] {
                let e = f.save(path).unwrap_err();
                assert!(
                    matches!(e, VisguideError::Invalid { name: "model", .. }),
                    "{e}"
                );
            }
        }
        let mut bad_track = Vec::new();
        for edit in [
            |f: &mut TrackModelFile| f.format = LWPR_FORMAT.into(),
            |f: &mut TrackModelFile| f.version = 0,
            |f: &mut TrackModelFile| f.extent = [100.0, 0.0, 0.0, 80.0],
            |f: &mut TrackModelFile| f.extent[3] = f64::NAN,
        ] {
            let mut f = track.clone();
            edit(&mut f);
            bad_track.push(f);
        }
        for f in &bad_track {
            for path in [&tp, &dir.join("new.json")] {
                assert!(
                    matches!(f.save(path), Err(VisguideError::Invalid { .. })),
                    "{:?}",
                    f.extent
                );
            }
        }
        assert_eq!(listing(), before, "a refused save touched a file");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
