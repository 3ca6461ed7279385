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

/// The test image; `python/tests/conftest.py` has the same formula.
fn image() -> Vec<u8> {
    // (cx, cy, r², level): the first disc containing a pixel sets it; the rest is a ramp.
    const DISCS: [(i64, i64, i64, i64); 6] = [
        (60, 25, 16, 250),
        (20, 20, 64, 30),
        (60, 25, 100, 200),
        (40, 50, 36, 60),
        (75, 55, 49, 230),
        (20, 55, 25, 160),
    ];
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
    let e = r.ellipse();
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
    let inner = mser::GrayView::new(&px[W + 1..], W - 2, H - 2, W).unwrap();
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
    json!({
        "x": xs, "y": ys, "y_learning": yps, "queries": queries, "predictions": preds,
        "num_rfs": model.num_rfs(), "binary": binary,
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
    json!({
        "cross_2d": lwpr_case(cross, 400, 1),
        "full_meta_3d": lwpr_case(full, 300, 2),
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

fn reference() -> Value {
    let px = image();
    json!({
        "image": {"width": W, "height": H},
        "mser": mser_cases(&px),
        "lwpr": lwpr_cases(),
        "fd": fd_cases(&px),
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
