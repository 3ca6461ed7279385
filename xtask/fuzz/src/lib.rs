//! The bodies of visguide's fuzz targets: one function per parser or loader, called by the
//! libFuzzer binary of the same name (`fuzz_targets/NAME.rs`) and by the stable replay test
//! (`tests/replay.rs`) on every file of `corpus/NAME/`.
//!
//! Each body feeds arbitrary bytes to a loader. Whatever the bytes, the loader must return
//! (never panic, never abort on an allocation); and what it accepts must be usable: a loaded
//! model predicts or tracks without panicking, a parsed file survives its own writer. A panic
//! here is a finding.

use std::path::Path;

/// A target's body: takes any bytes, panics only on a finding.
pub type Body = fn(&[u8]);

/// Every target: its name (the binary and the corpus folder) and its body.
pub const TARGETS: &[(&str, Body)] = &[
    ("oxford_regions", oxford_regions),
    ("tracking_csv", tracking_csv),
    ("tracking_mot", tracking_mot),
    ("arm_config", arm_config),
    ("lwpr_json", lwpr_json),
    ("lwpr_binary", lwpr_binary),
    ("lwpr_xml", lwpr_xml),
    ("cbt_model", cbt_model),
    ("cbt_tracker", cbt_tracker),
    ("servo_inverse_model", servo_inverse_model),
    ("servo_recognition", servo_recognition),
    ("visguide_table", visguide_table),
    ("visguide_models", visguide_models),
    ("visguide_image", visguide_image),
];

/// Oxford region files (`mser::read_regions`): every accepted ellipse is finite and positive
/// definite, as documented, and writing the ellipses back reads back the same values.
pub fn oxford_regions(data: &[u8]) {
    let Ok(regions) = mser::read_regions(data) else {
        return;
    };
    let ellipses: Vec<mser::Ellipse> = regions.iter().map(|r| r.ellipse).collect();
    for e in &ellipses {
        let finite = [e.u, e.v, e.a, e.b, e.c].iter().all(|x| x.is_finite());
        assert!(finite && e.a > 0.0 && e.a * e.c - e.b * e.b > 0.0, "{e:?}");
    }
    let mut text = Vec::new();
    mser::write_regions(&mut text, &ellipses).expect("writing to memory");
    let back = mser::read_regions(text.as_slice()).expect("our own output reads back");
    let again: Vec<mser::Ellipse> = back.iter().map(|r| r.ellipse).collect();
    assert_eq!(again, ellipses);
}

/// Tracking CSV files (`cbt_tracker::csv::parse`): what parses writes back and reads back to
/// the same sequence.
pub fn tracking_csv(data: &[u8]) {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let path = Path::new("fuzz.csv");
    let Ok(seq) = cbt_tracker::csv::parse(text, "fuzz", path) else {
        return;
    };
    let written = cbt_tracker::csv::to_string(&seq);
    let back = cbt_tracker::csv::parse(&written, "fuzz", path).expect("our own output parses");
    // Trailing empty frames are not written (they have no rows).
    let used = |s: &cbt_tracker::Sequence| {
        s.frames
            .iter()
            .rposition(|f| f.truth.is_some() || !f.detections.is_empty())
            .map_or(0, |k| k + 1)
    };
    assert_eq!(used(&back), used(&seq));
    assert_eq!(back.frames[..used(&back)], seq.frames[..used(&seq)]);
}

/// MOTChallenge ground truth (`cbt_tracker::mot::parse`): as documented, every accepted
/// sequence spans at most `MAX_SPAN` frames, holds no detections, has a finite truth in its
/// first and last frame and in at least two frames (only finite truths), and sequences come in
/// increasing id order with distinct names. An accepted sequence is usable: the tracking CSV
/// writer reproduces it and the baselines' calibration runs on it (errors allowed, panics
/// not).
pub fn tracking_mot(data: &[u8]) {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let Ok(seqs) = cbt_tracker::mot::parse(text, "gt", Path::new("gt.txt")) else {
        return;
    };
    let mut ids = Vec::new();
    for s in &seqs {
        let n = s.frames.len();
        assert!(
            (2..=cbt_tracker::csv::MAX_SPAN as usize).contains(&n),
            "{n} frames"
        );
        assert!(s.frames.iter().all(|f| f.detections.is_empty()));
        let truths: Vec<[f64; 2]> = s.frames.iter().filter_map(|f| f.truth).collect();
        assert!(truths.len() >= 2, "{}: {} truths", s.name, truths.len());
        assert!(truths.iter().flatten().all(|v| v.is_finite()), "{truths:?}");
        assert!(s.frames[0].truth.is_some() && s.frames[n - 1].truth.is_some());
        let id: i64 = s.name["gt-id".len()..].parse().expect("name gt-id<ID>");
        ids.push(id);
        let written = cbt_tracker::csv::to_string(s);
        let back = cbt_tracker::csv::parse(&written, "gt", Path::new("gt.csv"))
            .expect("a MOT sequence writes as tracking CSV");
        assert_eq!(back.frames, s.frames);
    }
    assert!(ids.windows(2).all(|w| w[0] < w[1]), "{ids:?}");
    let _ = cbt_tracker::Calibration::estimate(&seqs, 10.0);
}

/// The command line's numeric CSV tables (`visguide::tables::parse`): every accepted row is as
/// wide as the column names and finite, and the table written back (names, then the rows with
/// `tables::cell`) parses to the same names and rows.
pub fn visguide_table(data: &[u8]) {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let path = Path::new("fuzz.csv");
    let Ok(t) = visguide::tables::parse(text, path) else {
        return;
    };
    assert!(!t.rows.is_empty() && t.rows.len() == t.lines.len());
    assert!(t.lines.windows(2).all(|w| w[0] < w[1]), "{:?}", t.lines);
    for r in &t.rows {
        assert_eq!(r.len(), t.columns.len());
        assert!(r.iter().all(|v| v.is_finite()), "{r:?}");
    }
    let mut out = t.columns.join(",");
    for r in &t.rows {
        out.push('\n');
        let cells: Vec<String> = r.iter().map(|&v| visguide::tables::cell(v)).collect();
        out.push_str(&cells.join(","));
    }
    let back = visguide::tables::parse(&out, path).expect("a written table parses");
    assert_eq!((back.columns, back.rows), (t.columns, t.rows));
}

/// A scratch file of this process for loaders that only read files.
fn scratch(name: &str) -> std::path::PathBuf {
    std::env::temp_dir().join(format!("visguide-fuzz-{}-{name}", std::process::id()))
}

/// The command line's model files (`visguide::models`): the same bytes are offered to both
/// envelopes through their loaders (which read a file). A loaded LWPR file predicts and its
/// model survives saving (the file saved and loaded again holds the same model); a loaded
/// tracking model drives a CBT tracker and loads again after saving.
pub fn visguide_models(data: &[u8]) {
    use visguide::models::{LwprFile, TrackModelFile};
    let (input, output) = (scratch("model.json"), scratch("saved.json"));
    std::fs::write(&input, data).expect("writing a scratch file");
    if let Ok((file, model)) = LwprFile::load(&input) {
        assert_eq!(
            (file.inputs.len(), file.outputs.len()),
            (model.n_in(), model.n_out())
        );
        use_lwpr(&model);
        file.save(&output).expect("saving a loaded model");
        let (_, again) = LwprFile::load(&output).expect("a saved model loads");
        assert_eq!(again, model);
    }
    if let Ok(file) = TrackModelFile::load(&input) {
        use_tracker(cbt_tracker::CbtTracker::new(file.cbt.clone()));
        file.save(&output).expect("saving a loaded model");
        let again = TrackModelFile::load(&output).expect("a saved model loads");
        assert_eq!(again.cbt, file.cbt);
    }
    let _ = std::fs::remove_file(&input);
    let _ = std::fs::remove_file(&output);
}

/// Most pixels an image may declare to be decoded here (the fuzzer's time and memory bound;
/// `decode_gray` itself relies on the `image` crate's default allocation limit).
pub const MAX_PIXELS: u64 = 1 << 16;

/// Image decoding as the command line does it (`visguide::decode_gray`, PNG and Netpbm chosen
/// by content), for images declaring at most [`MAX_PIXELS`]: an accepted image has the declared
/// size and pixels; small ones (at most 64 × 64) go through MSER detection (errors allowed,
/// panics not).
pub fn visguide_image(data: &[u8]) {
    let Ok(reader) = image::ImageReader::new(std::io::Cursor::new(data)).with_guessed_format()
    else {
        return;
    };
    let Ok((w, h)) = reader.into_dimensions() else {
        return;
    };
    if u64::from(w) * u64::from(h) > MAX_PIXELS {
        return;
    }
    let Ok(img) = visguide::decode_gray(Path::new("fuzz.png"), data) else {
        return;
    };
    assert_eq!(img.dimensions(), (w, h));
    assert!(w > 0 && h > 0);
    if w <= 64 && h <= 64 {
        let _ = visguide::detect(&img, &mser::MserParams::default());
    }
}

/// Arm configurations (`arm_sim::SimConfig::from_json`): an accepted configuration writes
/// back and reads back equal.
pub fn arm_config(data: &[u8]) {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let Ok(config) = arm_sim::SimConfig::from_json(text) else {
        return;
    };
    let back = arm_sim::SimConfig::from_json(&config.to_json()).expect("our own output loads");
    assert_eq!(back, config);
}

/// Predicts with a loaded LWPR model at the origin and at a far point (errors allowed, panics
/// not), and checks that it saves and loads again.
fn use_lwpr(model: &lwpr::Lwpr) {
    for x in [0.0, 1e3] {
        let x = vec![x; model.n_in()];
        let _ = model.predict(&x, 0.001);
        let _ = model.predict_with_confidence(&x, 0.001);
        let _ = model.predict_with_jacobian(&x, 0.001);
    }
    // A loaded model trains on: its counts and statistics must take a few more updates.
    let mut trained = model.clone();
    for k in 0..3 {
        let x = vec![0.1 * k as f64; trained.n_in()];
        let y = vec![0.5; trained.n_out()];
        let _ = trained.update(&x, &y);
    }
    lwpr::Lwpr::from_json(&model.to_json()).expect("a loaded model's JSON loads again");
    lwpr::Lwpr::from_binary(&model.to_binary()).expect("a loaded model's binary loads again");
    let back = lwpr::Lwpr::from_xml(&model.to_xml()).expect("a loaded model's XML loads again");
    assert!(
        back == *model,
        "a model's XML reads back as a different model"
    );
}

/// LWPR models in the reference library's XML layout (`Lwpr::from_xml`).
pub fn lwpr_xml(data: &[u8]) {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    if let Ok(model) = lwpr::Lwpr::from_xml(text) {
        use_lwpr(&model);
    }
}

/// LWPR models saved as JSON (`Lwpr::from_json`).
pub fn lwpr_json(data: &[u8]) {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    if let Ok(model) = lwpr::Lwpr::from_json(text) {
        use_lwpr(&model);
    }
}

/// LWPR models saved in the binary format (`Lwpr::from_binary`). Input that does not start
/// with the format's magic is also taken as a payload and framed (magic, version, length,
/// FNV-1a checksum) first, so that mutations reach the decoder behind the checksum.
pub fn lwpr_binary(data: &[u8]) {
    if let Ok(model) = lwpr::Lwpr::from_binary(data) {
        use_lwpr(&model);
    }
    let header = binary_header();
    if !data.starts_with(&header[..8]) {
        let mut framed = header[..12].to_vec();
        framed.extend_from_slice(&(data.len() as u64).to_le_bytes());
        framed.extend_from_slice(data);
        framed.extend_from_slice(&fnv1a(data).to_le_bytes());
        if let Ok(model) = lwpr::Lwpr::from_binary(&framed) {
            use_lwpr(&model);
        }
    }
}

/// The first 12 bytes of a binary LWPR model (magic and version), taken from a saved model.
fn binary_header() -> &'static [u8] {
    static HEADER: std::sync::OnceLock<Vec<u8>> = std::sync::OnceLock::new();
    HEADER.get_or_init(|| {
        let model = lwpr::LwprBuilder::new(1, 1).build().expect("a 1-D model");
        model.to_binary()[..12].to_vec()
    })
}

/// The binary format's checksum (64-bit FNV-1a over the payload), for framing payloads.
fn fnv1a(data: &[u8]) -> u64 {
    data.iter().fold(0xcbf2_9ce4_8422_2325, |h, &b| {
        (h ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3)
    })
}

/// A detection at the centre of a tracker's first two axes.
fn probe_detections() -> Vec<cbt_tracker::Detection> {
    vec![cbt_tracker::Detection::new(0.5, 0.5)]
}

/// Runs a tracker for two frames (with and without a detection); errors allowed, panics not.
fn use_tracker(mut t: cbt_tracker::CbtTracker) {
    use cbt_tracker::Tracker;
    let _ = t.step(&probe_detections());
    let _ = t.step(&[]);
    let _ = t.estimate();
}

/// CBT models saved with serde (JSON): a loaded model drives a tracker.
pub fn cbt_model(data: &[u8]) {
    if let Ok(model) = serde_json::from_slice::<cbt_tracker::CbtModel>(data) {
        use_tracker(cbt_tracker::CbtTracker::new(model));
    }
}

/// CBT trackers saved with serde (JSON), posterior included: a loaded tracker keeps tracking.
pub fn cbt_tracker(data: &[u8]) {
    if let Ok(tracker) = serde_json::from_slice::<cbt_tracker::CbtTracker>(data) {
        use_tracker(tracker);
    }
}

/// servo-loop's learned inverse model (`InverseModel`, JSON): a loaded model predicts.
pub fn servo_inverse_model(data: &[u8]) {
    if let Ok(model) = serde_json::from_slice::<servo_loop::InverseModel>(data) {
        for x in [0.0, 1e3] {
            let _ = model.predict(&vec![x; model.percept_dim()]);
            let _ = model.predict_with_jacobian(&vec![x; model.percept_dim()]);
        }
    }
}

/// servo-loop's recognition models (`TipModel`, `GripperModel`, `TipCorrection`; JSON): the
/// same bytes are offered to each; a loaded tip model locates on a small blank image (an error
/// for a size it was not learned on, never a panic).
pub fn servo_recognition(data: &[u8]) {
    if let Ok(model) = serde_json::from_slice::<servo_loop::TipModel>(data) {
        let img = image::GrayImage::new(16, 12);
        for cam in 0..2 {
            let _ = model.locate(cam, &img);
        }
    }
    let _ = serde_json::from_slice::<servo_loop::GripperModel>(data);
    if let Ok(c) = serde_json::from_slice::<servo_loop::TipCorrection>(data) {
        let _ = c.tips(&[[1.0, 2.0]], &[None]);
    }
}
