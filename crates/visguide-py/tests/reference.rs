//! Reference values for the Python tests (`python/tests`), computed with the crates directly:
//! `tests/reference.json` must equal what this test computes, so the pytest suite compares the
//! bindings with the current Rust crates. Regenerate with `VISGUIDE_PY_BLESS=1 cargo test -p
//! visguide-py --test reference` after a deliberate change of a crate's results.
//!
//! Inputs are defined by integer formulas (the image) or stored in the JSON (training samples),
//! so Python rebuilds them exactly.

use serde_json::{Value, json};

const W: usize = 96;
const H: usize = 72;

/// The discs of the test image, `(cx, cy, r², level)`: the first disc containing a pixel sets
/// it; the rest is a ramp. Stored in the JSON (`image.discs`), from which `conftest.py` reads
/// them.
const DISCS: [(i64, i64, i64, i64); 6] = [
    (60, 25, 16, 250),
    (20, 20, 64, 30),
    (60, 25, 100, 200),
    (40, 50, 36, 60),
    (75, 55, 49, 230),
    (20, 55, 25, 160),
];

/// The test image; `python/tests/conftest.py` has the same formula, checked against the
/// image's digest stored in the JSON.
fn image() -> Vec<u8> {
    let mut px = vec![0u8; W * H];
    for y in 0..H as i64 {
        for x in 0..W as i64 {
            let v = DISCS
                .iter()
                .find(|&&(cx, cy, r2, _)| (x - cx).pow(2) + (y - cy).pow(2) < r2)
                .map(|&(_, _, _, l)| l + (x + y) % 3)
                .unwrap_or(100 + (x * 5 + y * 3) % 23);
            px[y as usize * W + x as usize] = v as u8;
        }
    }
    px
}

/// FNV-1a (64 bit) of `bytes`: large arrays are stored as their length and this digest
/// (`conftest.py` has the same function).
fn fnv1a(bytes: impl IntoIterator<Item = u8>) -> String {
    let mut h: u64 = 0xcbf29ce484222325;
    for b in bytes {
        h ^= b as u64;
        h = h.wrapping_mul(0x100000001b3);
    }
    format!("{h:016x}")
}

/// Digest of a point list: little-endian `u32` x, y, point after point.
fn points_digest(p: &[(u32, u32)]) -> Value {
    let bytes = p
        .iter()
        .flat_map(|&(x, y)| x.to_le_bytes().into_iter().chain(y.to_le_bytes()));
    json!({"len": p.len(), "fnv1a": fnv1a(bytes)})
}

fn region_json(r: &mser::Region, img: &mser::GrayView) -> Value {
    let e = r.ellipse().unwrap();
    let m = r.moments;
    let b = r.bbox;
    json!({
        "polarity": match r.polarity { mser::Polarity::Dark => "dark", mser::Polarity::Bright => "bright" },
        "level": r.level,
        "seed": [r.seed.0, r.seed.1],
        "area": r.area,
        "variation": r.variation,
        "bbox": [b.x_min, b.y_min, b.x_max, b.y_max],
        "moments": [m.n, m.sx, m.sy, m.sxx, m.sxy, m.syy],
        "ellipse": [e.u, e.v, e.a, e.b, e.c],
        "pixels": points_digest(&r.pixels(img).unwrap()),
        "contour": r.contour(img).unwrap(),
    })
}

fn mser_cases(px: &[u8]) -> Value {
    let img = mser::GrayView::packed(px, W, H).unwrap();
    let larsson = mser::MserParams {
        min_area: 10,
        ..mser::MserParams::larsson2009()
    };
    let small = mser::MserParams {
        min_area: 10,
        delta: 3,
        min_diversity: 0.0,
        ..mser::MserParams::opencv()
    };
    let mut cases = serde_json::Map::new();
    for (name, p) in [
        ("opencv_min_area_10", &small),
        ("larsson2009_min_area_10", &larsson),
    ] {
        let rs = mser::detect(&img, p).unwrap();
        cases.insert(
            name.into(),
            rs.iter().map(|r| region_json(r, &img)).collect(),
        );
    }
    // The image without its outer ring (what OpenCV 4.x floods), pixels in full-image coordinates.
    let inner = img.window(1, 1, W - 2, H - 2).unwrap();
    let rs = mser::detect(&inner, &small).unwrap();
    let sets: Vec<Value> = rs
        .iter()
        .map(|r| {
            let p: Vec<(u32, u32)> = r
                .pixels(&inner)
                .unwrap()
                .into_iter()
                .map(|(x, y)| (x + 1, y + 1))
                .collect();
            points_digest(&p)
        })
        .collect();
    cases.insert("inner_ring_pixels_min_area_10".into(), sets.into());
    Value::Object(cases)
}

/// A 64-bit LCG (Knuth's MMIX constants) for the training samples, stored in the JSON.
struct Lcg(u64);

impl Lcg {
    fn uniform(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    }
}

fn lwpr_case(model: lwpr::Lwpr, n_samples: usize, seed: u64) -> Value {
    let mut model = model;
    let (n, m) = (model.n_in(), model.n_out());
    let mut rng = Lcg(seed);
    let (mut xs, mut ys, mut yps) = (Vec::new(), Vec::new(), Vec::new());
    for _ in 0..n_samples {
        let x: Vec<f64> = (0..n).map(|_| rng.uniform()).collect();
        let r2: f64 = x.iter().map(|v| v * v).sum();
        let y: Vec<f64> = (0..m)
            .map(|k| (-(5.0 + k as f64) * r2).exp() + 0.3 * x[k % n] + 0.05 * rng.uniform())
            .collect();
        yps.push(model.update(&x, &y).unwrap());
        xs.push(x);
        ys.push(y);
    }
    let queries: Vec<Vec<f64>> = (0..20)
        .map(|_| (0..n).map(|_| rng.uniform()).collect())
        .collect();
    let preds: Vec<Value> = queries
        .iter()
        .map(|q| {
            let c = model.predict_with_confidence(q, 0.001).unwrap();
            let j = model.predict_with_jacobian(q, 0.001).unwrap();
            let jac: Vec<Vec<f64>> = (0..m)
                .map(|i| (0..n).map(|k| j.jacobian[(i, k)]).collect())
                .collect();
            json!({
                "y": model.predict(q, 0.001).unwrap(),
                "y0": model.predict(q, 0.0).unwrap(),
                "conf_y": c.y,
                "conf": c.confidence,
                "jacobian_y": j.y,
                "jacobian": jac,
            })
        })
        .collect();
    let bin = model.to_binary();
    let binary = json!({"len": bin.len(), "fnv1a": fnv1a(bin)});
    let xml = model.to_xml();
    let xml = json!({"len": xml.len(), "fnv1a": fnv1a(xml.into_bytes())});
    json!({
        "x": xs, "y": ys, "y_learning": yps, "queries": queries, "predictions": preds,
        "num_rfs": model.num_rfs(), "binary": binary, "xml": xml,
    })
}

fn lwpr_cases() -> Value {
    // The reference module's test.py setting: 2 → 1, init_D = 50 I, init_alpha = 250.
    let cross = lwpr::LwprBuilder::new(2, 1)
        .init_d_spherical(50.0)
        .init_alpha(250.0)
        .build()
        .unwrap();
    // Full metric with meta learning, normalisation and two outputs.
    let full = lwpr::LwprBuilder::new(3, 2)
        .init_d_spherical(20.0)
        .init_alpha(100.0)
        .diag_only(false)
        .meta(true)
        .norm_in(&[1.0, 2.0, 0.5])
        .norm_out(&[1.0, 3.0])
        .build()
        .unwrap();
    // A model file written by the reference C library (see crates/lwpr/tests/integration/xml.rs).
    let file = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../lwpr/tests/data/reference_setting_a.xml"
    );
    let from_reference = lwpr::Lwpr::load_xml(file).unwrap();
    let queries: Vec<[f64; 2]> = (0..25)
        .map(|k| [-0.9 + 0.075 * k as f64, 0.8 - 0.07 * k as f64])
        .collect();
    let predictions: Vec<Vec<f64>> = queries
        .iter()
        .map(|q| from_reference.predict(q, 0.001).unwrap())
        .collect();
    json!({
        "cross_2d": lwpr_case(cross, 400, 1),
        "full_meta_3d": lwpr_case(full, 300, 2),
        "reference_xml": {
            "num_rfs": from_reference.num_rfs(),
            "n_data": from_reference.n_data(),
            "queries": queries,
            "predictions": predictions,
        },
    })
}

/// `np.rot90(image)`: `out[i, j] = image[j, W − 1 − i]`, `W` rows of `H` pixels.
fn rot90(px: &[u8]) -> Vec<u8> {
    let mut out = vec![0u8; W * H];
    for i in 0..W {
        for j in 0..H {
            out[i * H + j] = px[j * W + (W - 1 - i)];
        }
    }
    out
}

fn f64_digest(v: impl IntoIterator<Item = f64>) -> Value {
    let v: Vec<f64> = v.into_iter().collect();
    json!({"len": v.len(), "fnv1a": fnv1a(v.iter().flat_map(|x| x.to_le_bytes()))})
}

fn complex_digest(v: impl IntoIterator<Item = fd_match::Complex64>) -> Value {
    f64_digest(v.into_iter().flat_map(|c| [c.re, c.im]))
}

/// Contours of the image's regions and of its 90° rotation, described with every sampling and
/// matched with every method.
fn fd_cases(px: &[u8]) -> Value {
    let p = mser::MserParams {
        min_area: 10,
        delta: 3,
        min_diversity: 0.0,
        ..mser::MserParams::opencv()
    };
    let contours = |img: &mser::GrayView| -> Vec<Vec<(u32, u32)>> {
        mser::detect(img, &p)
            .unwrap()
            .iter()
            .map(|r| r.contour(img).unwrap())
            .collect()
    };
    let rotated = rot90(px);
    let a = contours(&mser::GrayView::packed(px, W, H).unwrap());
    let b = contours(&mser::GrayView::packed(&rotated, H, W).unwrap());
    let mut out = serde_json::Map::new();
    for (sname, sampling) in [
        ("arc_length", fd_match::Sampling::ArcLength),
        ("affine", fd_match::Sampling::AffineArcLength),
        ("canonical", fd_match::Sampling::Canonical),
    ] {
        let cfg = fd_match::DescriptorConfig::with_sampling(sampling);
        let da = fd_match::describe_all(cfg, &a).unwrap();
        let db = fd_match::describe_all(cfg, &b).unwrap();
        let set = &da.set;
        let k = set.len();
        let mut methods = serde_json::Map::new();
        for (mname, method) in [
            ("fd_corr", fd_match::Method::FdCorr),
            ("abs_fd_ssd", fd_match::Method::AbsFdSsd),
            ("afd0_ssd", fd_match::Method::Afd0Ssd),
            ("afd1_ssd", fd_match::Method::Afd1Ssd),
            ("fd_ssd", fd_match::Method::FdSsd),
        ] {
            let ms = fd_match::match_sets(&da.set, &db.set, method).unwrap();
            let ms: Vec<Value> = ms
                .iter()
                .map(|m| {
                    let al = m.alignment.map(|a| [a.rotation, a.shift]);
                    json!([m.query, m.target, m.error, m.ratio, al])
                })
                .collect();
            let min_err = fd_match::min_errors_within(&da.set, method).unwrap();
            methods.insert(mname.into(), json!({"matches": ms, "min_errors": min_err}));
        }
        out.insert(
            sname.into(),
            json!({
                "sources_a": set.sources(),
                "sources_b": db.set.sources(),
                "rejected_a": da.rejected.iter().map(|(i, _)| *i).collect::<Vec<_>>(),
                "fd": complex_digest((0..k).flat_map(|i| set.fd(i).to_vec())),
                "magnitudes": f64_digest((0..k).flat_map(|i| set.magnitudes(i).to_vec())),
                "afd0": f64_digest((0..k).flat_map(|i| set.afd0(i).to_vec())),
                "afd1": complex_digest((0..k).flat_map(|i| set.afd1(i).to_vec())),
                "methods": methods,
            }),
        );
    }
    Value::Object(out)
}

fn frames_json(frames: &[cbt_tracker::Frame]) -> Value {
    frames
        .iter()
        .map(|f| {
            let truths: Vec<[f64; 2]> = f.truth.into_iter().collect();
            let dets: Vec<[f64; 3]> = f
                .detections
                .iter()
                .map(|d| [d.pos[0], d.pos[1], d.weight])
                .collect();
            json!([truths, dets])
        })
        .collect()
}

fn run_json<T: cbt_tracker::Tracker>(t: &mut T, frames: &[cbt_tracker::Frame]) -> Value {
    t.reset(frames[0].truth.unwrap()).unwrap();
    frames[1..]
        .iter()
        .map(|f| {
            let e = t.step(&f.detections).unwrap();
            json!([e.position[0], e.position[1], e.certainty])
        })
        .collect()
}

/// Simulated sequences (stored), a CBT learned from them, and the three trackers' estimates.
fn tracking_cases() -> Value {
    use cbt_tracker::{
        CbtConfig, CbtModel, CbtTracker, KalmanParams, KalmanTracker, ParticleFilter, PfModel,
        Space, sim,
    };
    let level = sim::Level::preset(1);
    let train = sim::generate(&sim::Scenario::default(), &level, 2, 120, 7).unwrap();
    let test = &sim::generate(&sim::Scenario::default(), &level, 1, 40, 8).unwrap()[0];
    let space = Space::image(320.0, 240.0, 10.0).unwrap();
    let model = CbtModel::learn_sequences(space.clone(), CbtConfig::default(), &train).unwrap();
    let mut cbt = CbtTracker::new(model);
    let mut kalman = KalmanTracker::new(KalmanParams {
        accel_sigma: 2.0,
        meas_sigma: 3.0,
        init_vel_sigma: 10.0,
        gate: cbt_tracker::GATE_99,
    })
    .unwrap();
    let mut pf = ParticleFilter::new(
        PfModel::ConstantVelocity {
            accel_sigma: 2.0,
            meas_sigma: 3.0,
            p_detect: 0.9,
            clutter_density: 1e-4,
            init_vel_sigma: 10.0,
        },
        200,
        3,
    )
    .unwrap();
    // CBT beyond the default configuration; python/tests/test_tracking.py passes the same
    // keywords.
    use cbt_tracker::{
        Clutter, Displacements, Layout, ObservationFallback, Order, StartMotion, SystemFallback,
        Velocity,
    };
    let configs = [
        (
            "first_order_subtract",
            CbtConfig {
                order: Order::First,
                clutter: Clutter::Subtract,
                observation_fallback: ObservationFallback::Uniform,
                prior_weight: 2.0,
                mixing: 0.01,
                prune: 0.0,
                runner_ups: 1,
                ..CbtConfig::default()
            },
            false,
        ),
        (
            "stationary",
            CbtConfig {
                layout: Layout::Stationary,
                system_fallback: SystemFallback::ConstantVelocity,
                fallback_sigma: 1.5,
                obs_radius: 6,
                support: 0.02,
                decode_radius: 3,
                ..CbtConfig::default()
            },
            false,
        ),
        (
            "sparse_joint_online",
            CbtConfig {
                layout: Layout::SparseJoint,
                clutter: Clutter::Uniform,
                observation_floor: 0.01,
                online_weight: 0.5,
                ..CbtConfig::default()
            },
            true,
        ),
        // The image-tracking settings (`CBT.stationary_config()` in Python).
        ("real_motion", CbtConfig::stationary(), false),
        (
            "stationary_options",
            CbtConfig {
                start: StartMotion::Pooled,
                displacements: Displacements::Aligned,
                velocity: Velocity::PerPosition,
                ..CbtConfig::stationary()
            },
            false,
        ),
    ];
    let mut cbt_configs = serde_json::Map::new();
    for (name, config, online) in configs {
        let model = CbtModel::learn_sequences(space.clone(), config, &train).unwrap();
        let mut t = CbtTracker::new(model);
        if online {
            t = t.with_self_learning();
        }
        cbt_configs.insert(name.into(), run_json(&mut t, &test.frames));
    }
    json!({
        "cbt_configs": cbt_configs,
        "train": train.iter().map(|s| frames_json(&s.frames)).collect::<Vec<_>>(),
        "test": frames_json(&test.frames),
        "cbt": run_json(&mut cbt, &test.frames),
        "kalman": run_json(&mut kalman, &test.frames),
        "particle_filter": run_json(&mut pf, &test.frames),
    })
}

/// `visguide::match_images` on the image and its 90° rotation: everything the Python
/// `visguide.fd.match_images` returns, exactly.
fn pair_case(px: &[u8], s: &visguide::MatchSettings) -> Value {
    let img1 = image::GrayImage::from_raw(W as u32, H as u32, px.to_vec()).unwrap();
    let img2 = image::GrayImage::from_raw(H as u32, W as u32, rot90(px)).unwrap();
    let pair = visguide::match_images(&img1, &img2, s).unwrap();
    let frames = |f: &visguide::Features| -> Vec<[f64; 5]> {
        f.frames.iter().map(|e| [e.u, e.v, e.a, e.b, e.c]).collect()
    };
    let row = |m: &visguide::RegionMatch| json!([m.i, m.j, m.error, m.ratio]);
    json!({
        "frames1": frames(&pair.features1),
        "frames2": frames(&pair.features2),
        "described": [pair.described.0, pair.described.1],
        "all": pair.all.iter().map(row).collect::<Vec<_>>(),
        "accepted": pair.accepted.iter().map(|g| json!({
            "match": row(&g.m),
            "rotation": g.rotation,
            "affine": g.local.map(|l| [l.a[(0, 0)], l.a[(0, 1)], l.a[(1, 0)], l.a[(1, 1)]]),
        })).collect::<Vec<_>>(),
        "homography": pair.homography.as_ref().map(|h| json!({
            "H": h.homography.to_row_major(),
            "inliers": h.inliers,
            "inlier_count": h.inlier_count,
            "rms": h.rms,
            "iterations": h.iterations,
        })),
    })
}

/// Two settings of the image-pair pipeline; `python/tests/test_pair.py` passes the same ones.
fn pair_cases(px: &[u8]) -> Value {
    let p = mser::MserParams {
        min_area: 10,
        delta: 3,
        min_diversity: 0.0,
        ..mser::MserParams::opencv()
    };
    let paper = visguide::MatchSettings {
        mser: (p.clone(), p.clone()),
        ratio_threshold: 0.8,
        ..visguide::MatchSettings::paper()
    };
    let other = visguide::MatchSettings {
        mser: (p.clone(), p),
        combination: visguide::Combination::new(
            fd_match::Method::AbsFdSsd,
            fd_match::Sampling::Canonical,
        ),
        ratio_threshold: 0.9,
        preselection: Some(0.0009),
        ransac: Some(visguide::RansacConfig {
            threshold: 2.0,
            max_iterations: 300,
            confidence: 0.99,
            seed: 5,
        }),
    };
    json!({
        "fd_corr_affine": pair_case(px, &paper),
        "abs_fd_ssd_canonical": pair_case(px, &other),
    })
}

fn reference() -> Value {
    let px = image();
    json!({
        "image": {
            "width": W,
            "height": H,
            "discs": DISCS,
            "pixels": {"len": px.len(), "fnv1a": fnv1a(px.iter().copied())},
        },
        "mser": mser_cases(&px),
        "lwpr": lwpr_cases(),
        "fd": fd_cases(&px),
        "pair": pair_cases(&px),
        "tracking": tracking_cases(),
    })
}

#[test]
fn reference_json_is_current() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/reference.json");
    let fresh = serde_json::to_string(&reference()).unwrap() + "\n";
    if std::env::var_os("VISGUIDE_PY_BLESS").is_some() {
        std::fs::write(&path, &fresh).unwrap();
        return;
    }
    let stored = std::fs::read_to_string(&path).unwrap_or_default();
    assert!(
        stored == fresh,
        "{} is out of date: rerun with VISGUIDE_PY_BLESS=1 and review the change",
        path.display()
    );
}
