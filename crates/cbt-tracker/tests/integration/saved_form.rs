//! Files saved by earlier versions keep loading, and are saved again byte for byte.
//!
//! `tests/data/saved/*.json` were written by the code before the per-layout state of
//! [`CbtTracker`] became one enum (commit "cbt-tracker: files by family", whose `CbtTracker`
//! held every layout's fields side by side). Each is a tracker of one layout and order after
//! a fixed script of steps; the test replays the script with today's code and requires the
//! file to load, to compare equal to the replayed tracker, and to serialise to the same text
//! as the file (and as the replayed tracker). `CBT_WRITE_SAVED=1` rewrites the files (only
//! meaningful on a commit whose saved form is the reference).

use cbt_tracker::sim::Ungm;
use cbt_tracker::{
    CbtConfig, CbtModel, CbtTracker, DEFAULT_KERNEL, Displacements, Layout, ObservationFallback,
    Order, PeriodicInput, Space, StartMotion, Tracker, axis,
};

use crate::common;
use common::{H, W, data, stationary_spacing};

/// The scripted trackers: `(file name, tracker)`.
fn scripted() -> Vec<(String, CbtTracker)> {
    let (train, test) = data();
    let mut out = Vec::new();
    for layout in [Layout::Separable, Layout::SparseJoint, Layout::Stationary] {
        for order in [Order::First, Order::Second] {
            let (cfg, spacing) = if layout == Layout::Stationary {
                let s = stationary_spacing(&train);
                // The files predate the learned start and the interpolated displacements.
                let cfg = CbtConfig {
                    start: StartMotion::Marginal,
                    displacements: Displacements::Channels,
                    ..CbtConfig::stationary()
                };
                (cfg, s)
            } else {
                (CbtConfig::default(), 16.0)
            };
            let cfg = CbtConfig {
                layout,
                order,
                ..cfg
            };
            let space = Space::image(W, H, spacing).unwrap();
            let m = CbtModel::learn_sequences(space, cfg, &train).unwrap();
            // Online learning's saved history once per layout: second order, first for the
            // sparse joint layout (whose second-order files are large).
            let online: &[bool] = if (order == Order::Second) != (layout == Layout::SparseJoint) {
                &[false, true]
            } else {
                &[false]
            };
            for &online in online {
                let mut t = CbtTracker::new(m.clone());
                if online {
                    t = t.with_self_learning();
                }
                t.reset(test.frames[0].truth.unwrap()).unwrap();
                for f in &test.frames[1..6] {
                    t.step(&f.detections).unwrap();
                }
                let name = format!("{layout:?}-{order:?}-online-{online}").to_lowercase();
                out.push((name, t));
            }
        }
    }
    // A model with a known input: the saved time index.
    let state = axis(-30.0, 30.0, 3.0, DEFAULT_KERNEL).unwrap();
    let meas = axis(-5.0, 50.0, 3.0, DEFAULT_KERNEL).unwrap();
    let space = Space::new(vec![state], vec![meas]).unwrap();
    let cfg = CbtConfig {
        order: Order::First,
        observation_fallback: ObservationFallback::Uniform,
        input: Some(PeriodicInput {
            omega: 1.2,
            channels: 6,
        }),
        ..CbtConfig::default()
    };
    let mut runs = Ungm::default().generate(4, 40, 5).unwrap();
    for q in &mut runs {
        for f in &mut q.frames {
            if let Some(t) = f.truth.as_mut() {
                t[0] = t[0].clamp(-29.0, 29.0);
            }
            for d in &mut f.detections {
                d.pos[0] = d.pos[0].clamp(-4.0, 49.0);
            }
        }
    }
    let m = CbtModel::learn_sequences(space, cfg, &runs[..3]).unwrap();
    let mut t = CbtTracker::new(m);
    let s = &runs[3];
    t.reset(s.frames[0].truth.unwrap()).unwrap();
    for f in &s.frames[1..6] {
        t.step(&f.detections).unwrap();
    }
    out.push(("separable-first-input".into(), t));
    out
}

fn path(name: &str) -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/saved")
        .join(format!("{name}.json"))
}

#[test]
fn files_saved_before_the_layout_enum_load_and_save_byte_identically() {
    let write = std::env::var_os("CBT_WRITE_SAVED").is_some();
    for (name, t) in scripted() {
        let now = serde_json::to_string(&t).unwrap();
        if write {
            std::fs::write(path(&name), &now).unwrap();
            continue;
        }
        let file = std::fs::read_to_string(path(&name)).unwrap();
        let loaded: CbtTracker = serde_json::from_str(&file)
            .unwrap_or_else(|e| panic!("{name}: the saved file no longer loads: {e}"));
        assert!(
            loaded == t,
            "{name}: the loaded tracker differs from the replayed one"
        );
        assert!(
            serde_json::to_string(&loaded).unwrap() == file,
            "{name}: saved again, the text differs from the file"
        );
        assert!(
            now == file,
            "{name}: the replayed tracker saves different text"
        );
    }
}
