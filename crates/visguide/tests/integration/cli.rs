//! End-to-end tests through the built `visguide` binary, on generated images, tables and
//! tracks: every subcommand and output format read back and compared with the library, and
//! bad input (one line on stderr, exit code ≠ 0, no output file left behind).

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use image::GrayImage;
use visguide::{Combination, Homography, MatchSettings, match_images};

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_visguide"))
}

fn run(args: &[&str]) -> Output {
    bin().args(args).output().expect("the binary runs")
}

fn ok(args: &[&str]) -> Output {
    let o = run(args);
    assert!(
        o.status.success(),
        "visguide {args:?} failed: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    o
}

/// Runs a command that must fail: exit code 1, exactly one line on stderr mentioning `needle`.
fn fails(args: &[&str], needle: &str) -> String {
    let o = run(args);
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    assert_eq!(o.status.code(), Some(1), "visguide {args:?}: {err}");
    assert_eq!(err.trim_end().lines().count(), 1, "not one line: {err}");
    assert!(err.starts_with("visguide: error: "), "{err}");
    assert!(err.contains(needle), "`{needle}` not in: {err}");
    err
}

fn temp(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("visguide-cli-{tag}-{}", std::process::id()));
    if d.exists() {
        std::fs::remove_dir_all(&d).unwrap();
    }
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// A scene of distinct blobs on a grid (one per 40-pixel cell): each a star-shaped region
/// `r(θ) < R (1 + Σₖ aₖ cos(kθ + φₖ))`, k = 2, 3, 4, with radius, harmonics and grey level
/// varied by `seed`; seen through `h` (maps scene → image).
fn scene(h: &Homography, w: u32, ht: u32, seed: u32) -> GrayImage {
    let inv = h.inverse();
    // splitmix64 of (seed, cell, slot): deterministic, well mixed.
    let q = |k: u32, m: u32| {
        let mut z = (seed as u64) << 40 ^ (k as u64) << 16 ^ m as u64;
        z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    };
    let mut shapes = Vec::new();
    for cy in 0..(ht / 40) {
        for cx in 0..(w / 40) {
            let k = cy * 100 + cx;
            let harm: Vec<(f64, f64)> = (0..3)
                .map(|n| (0.05 + 0.2 * q(k, 10 + n), 6.3 * q(k, 20 + n)))
                .collect();
            shapes.push((
                cx as f64 * 40.0 + 20.0,
                cy as f64 * 40.0 + 20.0,
                9.0 + q(k, 3) * 5.0,
                harm,
                [20u8, 70, 190, 240][(q(k, 4) * 4.0) as usize],
            ));
        }
    }
    GrayImage::from_fn(w, ht, |x, y| {
        let Some((sx, sy)) = inv.map(x as f64, y as f64) else {
            return image::Luma([128]);
        };
        let mut g = 128u8;
        for (cx, cy, r, harm, v) in &shapes {
            let (dx, dy) = (sx - cx, sy - cy);
            let t = dy.atan2(dx);
            let f: f64 = harm
                .iter()
                .enumerate()
                .map(|(n, (a, p))| a * ((n as f64 + 2.0) * t + p).cos())
                .sum();
            if dx.hypot(dy) < r * (1.0 + f) {
                g = *v;
            }
        }
        image::Luma([g])
    })
}

fn identity() -> Homography {
    Homography::from_row_major(&[1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]).unwrap()
}

fn warp() -> Homography {
    Homography::from_row_major(&[0.95, 0.12, 14.0, -0.1, 0.97, 9.0, 1.5e-4, -1e-4, 1.0]).unwrap()
}

/// `visguide regions` in all three formats, read back and compared with the library; the
/// region files are byte-identical to `mser::write_regions` of the library's regions, and
/// identical with one thread and with three (the pool size honouring --threads).
#[test]
fn regions_every_format_matches_the_library() {
    let dir = temp("regions");
    let imgs = dir.join("imgs");
    std::fs::create_dir_all(&imgs).unwrap();
    let mut images = Vec::new();
    for k in 0..4 {
        let img = scene(&identity(), 200, 150, k);
        img.save(imgs.join(format!("s{k}.png"))).unwrap();
        images.push(img);
    }
    let params = mser::MserParams::larsson2009();
    // Oxford, default preset, a directory argument, two thread counts.
    // The pool has exactly --threads threads (reported on stderr with how many of them took
    // images; how many do depends on scheduling, the files do not).
    for threads in ["1", "3"] {
        let out = dir.join(format!("ox{threads}"));
        let o = ok(&["regions", "--threads", threads, "--out", s(&out), s(&imgs)]);
        let err = String::from_utf8(o.stderr).unwrap();
        let pool = match threads {
            "1" => String::from("(1 thread in the pool, "),
            n => format!("({n} threads in the pool, "),
        };
        let at = err
            .find(&pool)
            .unwrap_or_else(|| panic!("{pool} not in {err}"));
        let used: usize = err[at + pool.len()..]
            .split_whitespace()
            .next()
            .unwrap()
            .parse()
            .unwrap();
        assert!(
            (1..=threads.parse::<usize>().unwrap() + 1).contains(&used),
            "{err}"
        );
        for (k, img) in images.iter().enumerate() {
            let view = mser::GrayView::from_image(img).unwrap();
            let regions = mser::detect(&view, &params).unwrap();
            let ellipses: Vec<mser::Ellipse> =
                regions.iter().map(|r| r.ellipse().unwrap()).collect();
            let mut want = Vec::new();
            mser::write_regions(&mut want, &ellipses).unwrap();
            let got = std::fs::read(out.join(format!("s{k}.mser"))).unwrap();
            assert_eq!(got, want, "image {k}, {threads} threads");
            assert!(regions.len() >= 8, "only {} regions", regions.len());
            let back = mser::load_regions(out.join(format!("s{k}.mser"))).unwrap();
            assert_eq!(back.len(), regions.len());
        }
    }
    // JSON with contours and another preset and overrides.
    let out = dir.join("json");
    let first = imgs.join("s0.png");
    ok(&[
        "regions",
        "-q",
        "--format",
        "json",
        "--contours",
        "--preset",
        "opencv",
        "--delta",
        "7",
        "--max-variation",
        "0.4",
        "--draw",
        "--out",
        s(&out),
        s(&first),
    ]);
    let p = mser::MserParams {
        delta: 7,
        max_variation: 0.4,
        ..mser::MserParams::opencv()
    };
    let lib = visguide::detect(&images[0], &p).unwrap();
    let file: visguide::output::regions::RegionFile =
        serde_json::from_str(&std::fs::read_to_string(out.join("s0.json")).unwrap()).unwrap();
    assert_eq!(file.size, (200, 150));
    assert_eq!((file.params.delta, file.params.max_variation), (7, 0.4));
    assert_eq!(file.regions.len(), lib.len());
    for (r, (lr, lc)) in file
        .regions
        .iter()
        .zip(lib.regions.iter().zip(&lib.contours))
    {
        let e = lr.ellipse().unwrap();
        assert_eq!(r.ellipse, (e.u, e.v, e.a, e.b, e.c));
        assert_eq!((r.seed, r.area, r.level), (lr.seed, lr.area, lr.level));
        assert_eq!(r.contour.as_ref().unwrap(), lc);
    }
    assert!(image::open(out.join("s0-regions.png")).is_ok());
    // CSV: one row per region, the ellipse columns as the library's.
    let out = dir.join("csv");
    ok(&[
        "regions",
        "-q",
        "--format",
        "csv",
        "--out",
        s(&out),
        s(&first),
    ]);
    let text = std::fs::read_to_string(out.join("s0.csv")).unwrap();
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some(visguide::output::regions::CSV_HEADER));
    let view = mser::GrayView::from_image(&images[0]).unwrap();
    let regions = mser::detect(&view, &params).unwrap();
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    assert_eq!(rows.len(), regions.len());
    for (row, r) in rows.iter().zip(&regions) {
        let e = r.ellipse().unwrap();
        let nums: Vec<f64> = row[13..18].iter().map(|v| v.parse().unwrap()).collect();
        assert_eq!(nums, vec![e.u, e.v, e.a, e.b, e.c]);
        assert_eq!(row[5].parse::<u32>().unwrap(), r.area);
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// `visguide match` in every combination gives exactly the library's matches; in Paper A's
/// setting the matches are those of the study's calls (describe → match_regions), the
/// homography is close to the true one and the score is read back from JSON and CSV.
#[test]
fn match_equals_library_and_study_and_recovers_the_homography() {
    let dir = temp("match");
    let h = warp();
    let (a, b) = (scene(&identity(), 320, 240, 1), scene(&h, 320, 240, 1));
    let (pa, pb, ph) = (dir.join("a.png"), dir.join("b.png"), dir.join("H1to2p"));
    a.save(&pa).unwrap();
    b.save(&pb).unwrap();
    std::fs::write(&ph, h.to_text()).unwrap();
    let json = dir.join("m.json");
    let pic = dir.join("pair.png");
    ok(&[
        "match",
        "-q",
        s(&pa),
        s(&pb),
        "--homography",
        s(&ph),
        "--out",
        s(&json),
        "--picture",
        s(&pic),
    ]);
    let doc = json_file(&json);
    let lib = match_images(&a, &b, &MatchSettings::paper()).unwrap();
    let got: Vec<(u64, u64, f64)> = doc["matches"]
        .as_array()
        .unwrap()
        .iter()
        .map(|m| {
            (
                m["i"].as_u64().unwrap(),
                m["j"].as_u64().unwrap(),
                m["ratio"].as_f64().unwrap(),
            )
        })
        .collect();
    let want: Vec<(u64, u64, f64)> = lib
        .accepted
        .iter()
        .map(|g| (g.m.i as u64, g.m.j as u64, g.m.ratio))
        .collect();
    assert_eq!(got, want);
    assert!(got.len() >= 6, "only {} matches", got.len());
    // The study's calls on the same regions give the same symmetric matches.
    let c = Combination::SHOWN;
    let (sa, sb) = (
        visguide::matching::describe(&lib.features1, c.sampling).unwrap(),
        visguide::matching::describe(&lib.features2, c.sampling).unwrap(),
    );
    let study: Vec<(usize, usize)> = visguide::match_regions(&sa, &sb, c.method)
        .unwrap()
        .iter()
        .filter(|m| m.ratio < visguide::scoring::PAPER_T_R)
        .map(|m| (m.i, m.j))
        .collect();
    assert_eq!(
        study,
        want.iter()
            .map(|w| (w.0 as usize, w.1 as usize))
            .collect::<Vec<_>>()
    );
    // Geometry: a rotation and a local affine per match, the homography near the truth.
    let m0 = &doc["matches"][0];
    assert!(m0["rotation"].is_f64() && m0["shift"].is_f64() && m0["affine"].is_array());
    let corner = doc["homography"]["corner_error"].as_f64().unwrap();
    assert!(corner < 2.0, "corner error {corner}");
    let precision = doc["score"]["precision"].as_f64().unwrap();
    assert!(precision > 0.8, "precision {precision}");
    assert!(image::open(&pic).is_ok());
    // Local rotations agree with the true map's rotation at the region (about −6°).
    for m in doc["matches"].as_array().unwrap() {
        if m["inlier"] == true {
            let r = m["rotation"].as_f64().unwrap();
            assert!((r - (-0.1f64).atan2(0.95)).abs() < 0.15, "rotation {r}");
        }
    }
    // Every combination through the binary equals the library (CSV read back).
    for method in ["fd-corr", "abs-fd-ssd", "afd0-ssd", "afd1-ssd"] {
        for sampling in ["affine", "canonical"] {
            let o = ok(&[
                "match",
                "-q",
                s(&pa),
                s(&pb),
                "--method",
                method,
                "--sampling",
                sampling,
                "--format",
                "csv",
                "--ratio",
                "0.8",
            ]);
            let text = String::from_utf8(o.stdout).unwrap();
            let rows: Vec<(usize, usize, f64)> = text
                .lines()
                .skip(1)
                .map(|l| {
                    let f: Vec<&str> = l.split(',').collect();
                    (
                        f[0].parse().unwrap(),
                        f[1].parse().unwrap(),
                        f[7].parse().unwrap(),
                    )
                })
                .collect();
            let combination = Combination::ALL
                .into_iter()
                .find(|c| {
                    c.label()
                        == format!(
                            "{}/{}",
                            match method {
                                "fd-corr" => "FD Corr",
                                "abs-fd-ssd" => "abs(FD) SSD",
                                "afd0-ssd" => "AFD0 SSD",
                                _ => "AFD1 SSD",
                            },
                            if sampling == "affine" {
                                "Affine"
                            } else {
                                "Canonical"
                            }
                        )
                })
                .unwrap();
            let settings = MatchSettings {
                combination,
                ratio_threshold: 0.8,
                ..MatchSettings::paper()
            };
            let lib = match_images(&a, &b, &settings).unwrap();
            let want: Vec<(usize, usize, f64)> = lib
                .accepted
                .iter()
                .map(|g| (g.m.i, g.m.j, g.m.ratio))
                .collect();
            assert_eq!(rows, want, "{method}/{sampling}");
        }
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The homography from `visguide match` on leuven img1 → img2 is within 5 px (corner error over
/// the image's corners) of the benchmark's H1to2p (measured: 2.7 px with the larsson2009
/// preset). Skipped with a note without `VISGUIDE_DATA`; fails under `CI=true`.
#[test]
fn leuven_homography_is_close_to_the_benchmark() {
    let why = match std::env::var_os("VISGUIDE_DATA") {
        Some(d) if Path::new(&d).join("oxford-affine/leuven/H1to2p").is_file() => None,
        Some(d) => Some(format!(
            "{}/oxford-affine/leuven is missing",
            Path::new(&d).display()
        )),
        None => Some("VISGUIDE_DATA is not set".into()),
    };
    if let Some(why) = why {
        assert!(
            std::env::var("CI").map_or(true, |v| v != "true"),
            "leuven data needed under CI=true: {why}"
        );
        eprintln!("skipped: {why}");
        return;
    }
    let d = PathBuf::from(std::env::var_os("VISGUIDE_DATA").unwrap()).join("oxford-affine/leuven");
    let o = ok(&[
        "match",
        "-q",
        s(&d.join("img1.png")),
        s(&d.join("img2.png")),
        "--homography",
        s(&d.join("H1to2p")),
    ]);
    let doc: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let corner = doc["homography"]["corner_error"].as_f64().unwrap();
    assert!(corner < 5.0, "corner error {corner} px");
    assert!(doc["homography"]["inliers"].as_u64().unwrap() >= 10);
}

fn write_table(path: &Path, rows: usize) {
    let mut t = String::from("x1,x2,y\n");
    for k in 0..rows {
        let x1 = (k as f64 * 0.618_033_988_75).fract() * 2.0 - 1.0;
        let x2 = (k as f64 * 0.414_213_562_37).fract() * 2.0 - 1.0;
        t.push_str(&format!("{x1},{x2},{}\n", (2.0 * x1).sin() + 0.5 * x2));
    }
    std::fs::write(path, t).unwrap();
}

/// The arguments of `lwpr fit` on a table of two inputs.
fn fit_args<'a>(data: &'a Path, model: &'a Path, passes: &'a str) -> [&'a str; 10] {
    [
        "lwpr",
        "fit",
        "-q",
        s(data),
        "--inputs",
        "2",
        "--model",
        s(model),
        "--passes",
        passes,
    ]
}

/// `dir/d.csv`, a table of 50 rows, and the name `dir/m.json` for its model.
fn table(dir: &Path) -> (PathBuf, PathBuf) {
    let (data, model) = (dir.join("d.csv"), dir.join("m.json"));
    write_table(&data, 50);
    (data, model)
}

/// [`table`], with the model `lwpr fit` learns from it in one pass.
fn fitted_table(dir: &Path) -> (PathBuf, PathBuf) {
    let (data, model) = table(dir);
    ok(&fit_args(&data, &model, "1"));
    (data, model)
}

/// The JSON document in the file `path`.
fn json_file(path: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

/// `dir/a.png` and `dir/b.png`: a 120 × 90 scene and its warp (`warp()` maps a to b).
fn image_pair(dir: &Path) -> (PathBuf, PathBuf) {
    let (a, b) = (dir.join("a.png"), dir.join("b.png"));
    scene(&identity(), 120, 90, 3).save(&a).unwrap();
    scene(&warp(), 120, 90, 3).save(&b).unwrap();
    (a, b)
}

/// `lwpr fit` then `lwpr predict`: the model file loads in the library, the predictions,
/// confidence bounds and Jacobians are in the CSV and equal the library's.
#[test]
fn lwpr_fit_and_predict() {
    let dir = temp("lwpr");
    let (data, model, pred) = (dir.join("d.csv"), dir.join("m.json"), dir.join("p.csv"));
    write_table(&data, 400);
    ok(&fit_args(&data, &model, "10"));
    ok(&[
        "lwpr",
        "predict",
        "-q",
        s(&model),
        s(&data),
        "--out",
        s(&pred),
    ]);
    let (file, lib) = visguide::models::LwprFile::load(&model).unwrap();
    assert_eq!(file.outputs, vec!["y"]);
    let text = std::fs::read_to_string(&pred).unwrap();
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some("x1,x2,y,y_conf,dy/dx1,dy/dx2"));
    let mut worst: f64 = 0.0;
    for l in lines {
        let v: Vec<f64> = l.split(',').map(|c| c.parse().unwrap()).collect();
        let c = lib.predict_with_confidence(&v[..2], 0.001).unwrap();
        let j = lib.predict_with_jacobian(&v[..2], 0.001).unwrap();
        assert_eq!(
            (v[2], v[3], v[4], v[5]),
            (
                c.y[0],
                c.confidence[0],
                j.jacobian[(0, 0)],
                j.jacobian[(0, 1)]
            )
        );
        worst = worst.max((v[2] - ((2.0 * v[0]).sin() + 0.5 * v[1])).abs());
    }
    assert!(worst < 0.3, "worst training error {worst}");
    // A pass count whose updates overflow is an error naming it, and writes no model (it
    // used to panic on the multiplication).
    let huge = dir.join("huge.json");
    fails(
        &fit_args(&data, &huge, "18446744073709551615"),
        "--passes 18446744073709551615",
    );
    assert!(!huge.exists());
    std::fs::remove_dir_all(&dir).unwrap();
}

/// `track` in one step and as `learn` + `run` give the same CSV; with `--baselines` three
/// trackers, each one row per frame; CBT follows the generated car.
#[test]
fn track_one_step_equals_learn_then_run() {
    use cbt_tracker::sim::{Level, Scenario, generate};
    let dir = temp("track");
    let train = dir.join("train");
    std::fs::create_dir_all(&train).unwrap();
    let sc = Scenario::default();
    for s in generate(&sc, &Level::preset(1), 4, 150, 11).unwrap() {
        cbt_tracker::csv::write(&train, &s).unwrap();
    }
    let test = &generate(&sc, &Level::preset(1), 1, 120, 99).unwrap()[0];
    let seq = cbt_tracker::csv::write(&dir, test).unwrap();
    let (one, two, model) = (
        dir.join("one.csv"),
        dir.join("two.csv"),
        dir.join("m.cbt.json"),
    );
    ok(&[
        "track",
        "-q",
        "--train",
        s(&train),
        s(&seq),
        "--out",
        s(&one),
        "--baselines",
    ]);
    ok(&[
        "track",
        "learn",
        "-q",
        "--train",
        s(&train),
        "--model",
        s(&model),
    ]);
    ok(&[
        "track",
        "run",
        "-q",
        s(&model),
        s(&seq),
        "--out",
        s(&two),
        "--baselines",
    ]);
    let (a, b) = (
        std::fs::read_to_string(&one).unwrap(),
        std::fs::read_to_string(&two).unwrap(),
    );
    assert_eq!(a, b);
    let rows: Vec<Vec<&str>> = a.lines().skip(1).map(|l| l.split(',').collect()).collect();
    assert_eq!(rows.len(), 3 * 120);
    let mut err = 0.0;
    for (k, r) in rows.iter().take(120).enumerate() {
        assert_eq!(r[0].parse::<usize>().unwrap(), k);
        let t = test.frames[k].truth.unwrap();
        err += (r[2].parse::<f64>().unwrap() - t[0]).hypot(r[3].parse::<f64>().unwrap() - t[1]);
    }
    assert!(err / 120.0 < 6.0, "CBT mean error {}", err / 120.0);
    // Detections outside the model's extent are left out of their frames, and said so; the
    // frames' other detections still count (they used to be dropped with the whole frame):
    // the same sequence with one far detection added to every other frame tracks as before.
    let mut far = test.clone();
    for f in far.frames.iter_mut().skip(1).step_by(2) {
        f.detections
            .push(cbt_tracker::Detection::new(-5000.0, 40.0));
    }
    let far_dir = dir.join("far");
    std::fs::create_dir_all(&far_dir).unwrap();
    let far_seq = cbt_tracker::csv::write(&far_dir, &far).unwrap();
    let far_out = dir.join("far.csv");
    let o = ok(&["track", "run", s(&model), s(&far_seq), "--out", s(&far_out)]);
    let note = String::from_utf8_lossy(&o.stderr);
    assert!(
        note.contains("60 detections outside the model's extent"),
        "{note}"
    );
    let cbt_rows = |text: &str| text.lines().take(121).map(String::from).collect::<Vec<_>>();
    assert_eq!(
        cbt_rows(&std::fs::read_to_string(&far_out).unwrap()),
        cbt_rows(&b)
    );
    // A model file edited to be inconsistent is refused on loading, naming the file and the
    // field (an extent off or across the model's grid, a negative clutter rate: these used
    // to load, and ran or failed later with an error naming neither).
    let text = std::fs::read_to_string(&model).unwrap();
    let v: serde_json::Value = serde_json::from_str(&text).unwrap();
    let edited = dir.join("edited.json");
    type Edit = fn(&mut serde_json::Value);
    let edits: [(&str, Edit); 3] = [
        ("extent", |v| {
            v["extent"][0] = 1e6.into();
            v["extent"][1] = 2e6.into();
        }),
        ("extent", |v| {
            let (a, b) = (v["extent"][0].clone(), v["extent"][1].clone());
            v["extent"][0] = b;
            v["extent"][1] = a;
        }),
        ("clutter_rate", |v| {
            v["calibration"]["clutter_rate"] = (-3.0).into()
        }),
    ];
    for (needle, edit) in edits {
        let mut e = v.clone();
        edit(&mut e);
        std::fs::write(&edited, e.to_string()).unwrap();
        let err = fails(&["track", "run", "-q", s(&edited), s(&seq)], needle);
        assert!(err.contains("edited.json"), "{err}");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// MOTChallenge ground truth of generated tracks: rows `frame,id,left,top,4,6,1`, frames from
/// `first`; the centre of a box is the track's position.
fn mot_rows(id: u32, first: u64, s: &cbt_tracker::Sequence) -> String {
    let mut out = String::new();
    for (k, f) in s.frames.iter().enumerate() {
        let t = f.truth.unwrap();
        out.push_str(&format!(
            "{},{id},{},{},4,6,1\n",
            first + k as u64,
            t[0] - 2.0,
            t[1] - 3.0
        ));
    }
    out
}

/// The rows of a track CSV without its header.
fn body(path: &Path) -> Vec<String> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .skip(1)
        .map(str::to_string)
        .collect()
}

/// `track --format mot` on MOTChallenge ground-truth files (training folder and sequence, one
/// step and learn + run) gives exactly what the same data gives as CSV files: the same model
/// file byte for byte, and per target the same track rows (detections simulated on these
/// truth-only sequences, from the target's name, so the format does not matter).
#[test]
fn track_mot_equals_the_same_data_as_csv() {
    use cbt_tracker::sim::{Level, Scenario, generate};
    let dir = temp("track-mot");
    let (mot_train, csv_train) = (dir.join("mot-train"), dir.join("csv-train"));
    std::fs::create_dir_all(&mot_train).unwrap();
    let sc = Scenario::default();
    let tracks = generate(&sc, &Level::preset(0), 6, 120, 21).unwrap();
    // Two training files of two targets each, plus a static object flagged 0 (left out).
    for (f, pair) in tracks[..4].chunks(2).enumerate() {
        let mut text = mot_rows(1, 1, &pair[0]) + &mot_rows(2, 5, &pair[1]);
        text.push_str("3,7,100,100,5,5,0\n4,7,100,100,5,5,0\n");
        std::fs::write(mot_train.join(format!("{}.txt", ["a", "b"][f])), text).unwrap();
    }
    // The sequence: targets 5 (frames 1..) and 9 (frames 11..).
    let gt = dir.join("gt.txt");
    std::fs::write(
        &gt,
        mot_rows(5, 1, &tracks[4]) + &mot_rows(9, 11, &tracks[5]),
    )
    .unwrap();
    // The same data as CSV, one file per target named as the MOT reader names the targets.
    let mut csv_seqs = Vec::new();
    for p in ["a.txt", "b.txt"] {
        for s in cbt_tracker::mot::read(&mot_train.join(p)).unwrap() {
            cbt_tracker::csv::write(&csv_train, &s).unwrap();
        }
    }
    let csv_test = dir.join("csv-test");
    let targets = cbt_tracker::mot::read(&gt).unwrap();
    assert_eq!(targets.len(), 2);
    for s in &targets {
        assert_eq!(s.frames.len(), 120);
        csv_seqs.push(cbt_tracker::csv::write(&csv_test, s).unwrap());
    }
    assert_eq!(targets[1].frames[0].truth, tracks[5].frames[0].truth);

    let out = |n: &str| dir.join(n);
    let (mot_one, mot_two) = (out("mot-one.csv"), out("mot-two.csv"));
    let mot = ["--format", "mot"];
    let mut one = vec!["track", "-q", "--train", s(&mot_train)];
    one.extend(mot);
    one.extend([s(&gt), "--out", s(&mot_one), "--baselines"]);
    ok(&one);
    let (mot_model, csv_model) = (out("mot.cbt.json"), out("csv.cbt.json"));
    let mut learn = vec!["track", "learn", "-q", "--train", s(&mot_train)];
    learn.extend(mot);
    learn.extend(["--model", s(&mot_model)]);
    ok(&learn);
    let mut run_ = vec!["track", "run", "-q", s(&mot_model), s(&gt)];
    run_.extend(mot);
    run_.extend(["--out", s(&mot_two), "--baselines"]);
    ok(&run_);
    ok(&[
        "track",
        "learn",
        "-q",
        "--train",
        s(&csv_train),
        "--model",
        s(&csv_model),
    ]);
    assert_eq!(
        std::fs::read(&mot_model).unwrap(),
        std::fs::read(&csv_model).unwrap(),
        "the model learned from MOT files differs from the one learned from the same CSV data"
    );
    let mot_rows_out = body(&out("mot-one.csv"));
    assert_eq!(mot_rows_out, body(&out("mot-two.csv")));
    assert!(
        std::fs::read_to_string(out("mot-one.csv"))
            .unwrap()
            .starts_with("target,frame,tracker,x,y,certainty\n")
    );
    // 2 targets × 3 trackers × 120 frames.
    assert_eq!(mot_rows_out.len(), 2 * 3 * 120);
    let mut err = 0.0;
    for (target, csv_seq) in targets.iter().zip(&csv_seqs) {
        let c = out(&format!("{}-track.csv", target.name));
        ok(&[
            "track",
            "-q",
            "--train",
            s(&csv_train),
            s(csv_seq),
            "--out",
            s(&c),
            "--baselines",
        ]);
        let prefix = format!("{},", target.name);
        let from_mot: Vec<String> = mot_rows_out
            .iter()
            .filter_map(|l| l.strip_prefix(&prefix).map(str::to_string))
            .collect();
        let from_csv = body(&c);
        assert_eq!(from_mot, from_csv, "{}", target.name);
        // Frame numbers as in the file; CBT follows the target.
        let first: u64 = from_csv[0].split(',').next().unwrap().parse().unwrap();
        assert_eq!(first, target.first_frame);
        for (k, r) in from_csv.iter().take(120).enumerate() {
            let v: Vec<f64> = r
                .split(',')
                .skip(2)
                .take(2)
                .map(|x| x.parse().unwrap())
                .collect();
            let t = target.frames[k].truth.unwrap();
            err += (v[0] - t[0]).hypot(v[1] - t[1]);
        }
    }
    assert_eq!(targets[1].first_frame, 11);
    assert!(err / 240.0 < 6.0, "CBT mean error {}", err / 240.0);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Bad MOTChallenge files: one line naming the file and the line, exit code 1, no output.
#[test]
fn track_mot_bad_input_names_file_and_line() {
    use cbt_tracker::sim::{Level, Scenario, generate};
    let dir = temp("track-mot-bad");
    let train = dir.join("train");
    std::fs::create_dir_all(&train).unwrap();
    let tracks = generate(&Scenario::default(), &Level::preset(0), 3, 40, 5).unwrap();
    std::fs::write(
        train.join("a.txt"),
        mot_rows(1, 1, &tracks[0]) + &mot_rows(2, 1, &tracks[1]),
    )
    .unwrap();
    let gt = dir.join("gt.txt");
    std::fs::write(&gt, mot_rows(3, 1, &tracks[2])).unwrap();
    let out = dir.join("out.csv");
    let model = dir.join("m.cbt.json");
    let track = |train: &Path, seq: &Path| {
        vec![
            "track".to_string(),
            "--format".into(),
            "mot".into(),
            "--train".into(),
            s(train).into(),
            s(seq).into(),
            "--out".into(),
            s(&out).into(),
        ]
    };
    let fails_with = |args: Vec<String>, needle: &str| {
        let a: Vec<&str> = args.iter().map(String::as_str).collect();
        fails(&a, needle);
        assert!(!out.exists() && !model.exists());
    };
    // A bad row in the tracked sequence (line 3), and in a training file (line 2).
    let bad = dir.join("bad.txt");
    let mut text = mot_rows(3, 1, &tracks[2]);
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    lines[2] = "3,3,12.5,oops,4,6,1".into();
    text = lines.join("\n");
    std::fs::write(&bad, &text).unwrap();
    fails_with(track(&train, &bad), "bad.txt:3:");
    let bad_train = dir.join("bad-train");
    std::fs::create_dir_all(&bad_train).unwrap();
    std::fs::write(bad_train.join("t.txt"), "1,1,0,0,4,6\n2,1,0,0,4\n").unwrap();
    fails_with(track(&bad_train, &gt), "t.txt:2:");
    // A target annotated in one frame only; a row repeated.
    std::fs::write(&bad, "1,4,0,0,4,6,1\n").unwrap();
    fails_with(track(&train, &bad), "bad.txt:1:");
    std::fs::write(&bad, "1,4,0,0,4,6\n2,4,1,0,4,6\n2,4,2,0,4,6\n").unwrap();
    fails_with(track(&train, &bad), "bad.txt:3:");
    // A CSV sequence given as MOT (a header is not a number), a folder without .txt files,
    // and the sequence given as a folder.
    let csv = dir.join("seq.csv");
    std::fs::write(&csv, cbt_tracker::csv::to_string(&tracks[2])).unwrap();
    fails_with(track(&train, &csv), "seq.csv:1:");
    let empty = dir.join("empty");
    std::fs::create_dir_all(&empty).unwrap();
    fails_with(track(&empty, &gt), "empty");
    fails_with(track(&train, &train), "is a directory");
    // learn: nothing written either.
    std::fs::write(bad_train.join("t.txt"), "1,1,0,0,4,6\n2,1,0,0,x,6\n").unwrap();
    fails_with(
        vec![
            "track".into(),
            "learn".into(),
            "--format".into(),
            "mot".into(),
            "--train".into(),
            s(&bad_train).into(),
            "--model".into(),
            s(&model).into(),
        ],
        "t.txt:2:",
    );
    // A target outside the grid learned from the training files: refused, naming it.
    fails_with(track(&train, &gt), "gt.txt: gt-id3: ");
    // A target inside it is tracked.
    std::fs::write(&gt, mot_rows(3, 1, &tracks[0])).unwrap();
    ok(&track(&train, &gt)
        .iter()
        .map(String::as_str)
        .collect::<Vec<_>>());
    assert!(out.exists());
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Bad input: one clear line on stderr, exit code 1, and no output file (nor a temporary one).
#[test]
fn bad_input_fails_cleanly_without_partial_output() {
    let dir = temp("bad");
    let out = dir.join("out");
    std::fs::create_dir_all(&out).unwrap();
    let good = dir.join("good.png");
    scene(&identity(), 120, 90, 3).save(&good).unwrap();
    let corrupt = dir.join("corrupt.png");
    std::fs::write(&corrupt, b"\x89PNG\r\n\x1a\nthis is not a png").unwrap();
    let empty = dir.join("empty.pgm");
    std::fs::write(&empty, b"P5\n0 0\n255\n").unwrap();
    let missing = dir.join("missing.png");
    let o = s(&out);
    fails(&["regions", "--out", o, s(&missing)], "missing.png");
    fails(
        &["regions", "--out", o, s(&good), s(&corrupt)],
        "corrupt.png",
    );
    fails(&["regions", "--out", o, s(&empty)], "empty.pgm");
    let m = out.join("m.json");
    fails(
        &["match", s(&good), s(&dir), "--out", s(&m)],
        "is a directory",
    );
    // A RANSAC threshold that cannot be used is an error (it used to give exit 0 and no
    // homography).
    for t in ["NaN", "0", "inf"] {
        fails(
            &[
                "match",
                s(&good),
                s(&good),
                "--ransac-threshold",
                t,
                "--out",
                s(&m),
            ],
            "invalid RANSAC setting",
        );
    }
    assert!(!m.exists());
    fails(
        &[
            "match",
            s(&good),
            s(&good),
            "--homography",
            s(&corrupt),
            "--out",
            s(&m),
        ],
        "corrupt.png",
    );
    let bad_csv = dir.join("bad.csv");
    std::fs::write(&bad_csv, "x,y\n1,2\n3,four\n").unwrap();
    fails(
        &[
            "lwpr",
            "fit",
            s(&bad_csv),
            "--inputs",
            "1",
            "--model",
            s(&m),
        ],
        "bad.csv:3:",
    );
    // Values beyond LWPR's bound: the error names the file, line and column (it used to be
    // the builder's "norm_in is not finite", the standard deviation having overflowed).
    let huge_csv = dir.join("huge.csv");
    std::fs::write(&huge_csv, "x,y\n1,2\n1e300,3\n-1e300,4\n").unwrap();
    fails(
        &[
            "lwpr",
            "fit",
            s(&huge_csv),
            "--inputs",
            "1",
            "--model",
            s(&m),
        ],
        "huge.csv:3: column `x` = 1e300",
    );
    let table = dir.join("t.csv");
    write_table(&table, 50);
    let model = dir.join("m.lwpr.json");
    ok(&[
        "lwpr",
        "fit",
        "-q",
        s(&table),
        "--inputs",
        "2",
        "--model",
        s(&model),
    ]);
    let text = std::fs::read_to_string(&model).unwrap();
    std::fs::write(&model, text.replacen("\"version\":1", "\"version\":99", 1)).unwrap();
    fails(
        &["lwpr", "predict", s(&model), s(&table), "--out", s(&m)],
        "version 99",
    );
    let track_train = dir.join("train");
    std::fs::create_dir_all(&track_train).unwrap();
    std::fs::write(
        track_train.join("s.csv"),
        "frame,kind,x,y\n0,truth,1,2\n1,det,x,3\n",
    )
    .unwrap();
    let seq = dir.join("seq.csv");
    std::fs::write(&seq, "frame,kind,x,y\n0,truth,1,2\n1,truth,2,3\n").unwrap();
    fails(
        &["track", "--train", s(&track_train), s(&seq), "--out", s(&m)],
        "s.csv:3:",
    );
    // A table that is not a sequence is refused (the sequence is read before any learning).
    fails(
        &[
            "track",
            "--train",
            s(&track_train),
            s(&table),
            "--out",
            s(&m),
        ],
        "t.csv:1:",
    );
    // Nothing was written, not even a temporary file.
    let left: Vec<_> = std::fs::read_dir(&out)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    assert!(left.is_empty(), "left behind: {left:?}");
    // A usage error is exit code 2.
    assert_eq!(
        run(&["regions", "--format", "tiff", s(&good)])
            .status
            .code(),
        Some(2)
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A run with several output files that fails on one of them leaves none: `regions` with a
/// directory where one image's region file goes (it used to rename the other images' files
/// into place and leave a staging file behind), `match` with a picture in a missing folder (it
/// used to write `--out` first) or with `--picture` the same file as `--out` (the picture
/// silently replaced the matches, exit code 0).
#[test]
fn a_failed_output_leaves_no_other_output() {
    let dir = temp("outputs");
    let (a, b) = (dir.join("a.png"), dir.join("b.png"));
    scene(&identity(), 120, 90, 3).save(&a).unwrap();
    scene(&identity(), 120, 90, 4).save(&b).unwrap();
    let out = dir.join("out");
    std::fs::create_dir_all(out.join("b.mser")).unwrap();
    fails(&["regions", "--out", s(&out), s(&a), s(&b)], "b.mser");
    let left: Vec<_> = std::fs::read_dir(&out)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(left, vec!["b.mser"], "left behind: {left:?}");
    let m = out.join("m.json");
    let pic = dir.join("missing").join("pair.png");
    fails(
        &["match", s(&a), s(&b), "--out", s(&m), "--picture", s(&pic)],
        "pair.png",
    );
    assert!(!m.exists(), "--out written although --picture failed");
    let same = out.join("sub").join("..").join("m.json");
    std::fs::create_dir_all(out.join("sub")).unwrap();
    fails(
        &["match", s(&a), s(&b), "--out", s(&m), "--picture", s(&same)],
        "same file",
    );
    assert!(!m.exists());
    assert_eq!(std::fs::read_dir(&out).unwrap().count(), 2);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A failed `regions` run leaves no output folder it made: `--out` names folders that do not
/// exist yet (they are made before the images are read, for the staged files), and a missing
/// or corrupt image, or a good image with a corrupt one, refuses the run. (The folders used to
/// stay behind, empty.) A folder that was there stays, and a run that succeeds makes them.
#[test]
fn a_failed_regions_run_leaves_no_folder_it_made() {
    let dir = temp("regions-out");
    let good = dir.join("good.png");
    scene(&identity(), 120, 90, 3).save(&good).unwrap();
    let corrupt = dir.join("corrupt.png");
    std::fs::write(&corrupt, b"\x89PNG\r\n\x1a\nthis is not a png").unwrap();
    let missing = dir.join("missing.png");
    let new = dir.join("new");
    let out = new.join("deeper");
    let listing = || {
        let mut l: Vec<_> = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        l.sort();
        l
    };
    let before = listing();
    for images in [
        vec![s(&missing)],
        vec![s(&corrupt)],
        vec![s(&good), s(&corrupt)],
    ] {
        let mut args = vec!["regions", "--out", s(&out)];
        args.extend(&images);
        fails(
            &args,
            if images.contains(&s(&missing)) {
                "missing.png"
            } else {
                "corrupt.png"
            },
        );
        assert!(!new.exists(), "{images:?} left {} behind", new.display());
        assert_eq!(listing(), before, "{images:?}");
    }
    // An output folder that was there is kept (empty, as it was).
    std::fs::create_dir_all(&out).unwrap();
    fails(
        &["regions", "--out", s(&out), s(&good), s(&corrupt)],
        "corrupt.png",
    );
    assert!(out.is_dir());
    assert_eq!(std::fs::read_dir(&out).unwrap().count(), 0);
    std::fs::remove_dir_all(&new).unwrap();
    // A run that succeeds makes the folders.
    ok(&["regions", "-q", "--out", s(&out), s(&good)]);
    assert!(out.join("good.mser").is_file());
    std::fs::remove_dir_all(&dir).unwrap();
}

/// With several bad images, the error names the first of them in the order given, at any
/// number of threads, as on one. Three slow images come before the first bad one and the second
/// bad one right after it, so with two threads the second fails while the first has not
/// started: the first bad image used to be skipped then, and the error named the second.
#[test]
fn the_error_names_the_first_bad_image_at_any_thread_count() {
    let dir = temp("first-bad");
    let mut images = Vec::new();
    for (i, name) in [
        "a.png",
        "b.png",
        "c.png",
        "d-bad.png",
        "e-bad.png",
        "f.png",
        "g.png",
        "h.png",
    ]
    .iter()
    .enumerate()
    {
        let p = dir.join(name);
        if name.contains("bad") {
            std::fs::write(&p, b"\x89PNG\r\n\x1a\nthis is not a png").unwrap();
        } else if i < 3 {
            scene(&identity(), 320, 240, i as u32).save(&p).unwrap();
        } else {
            scene(&identity(), 40, 40, i as u32).save(&p).unwrap();
        }
        images.push(p);
    }
    let out = dir.join("out");
    // Two threads twice: that is where the old scheduling went wrong.
    for threads in ["1", "2", "2", "4"] {
        let mut args = vec!["regions", "-q", "--threads", threads, "--out", s(&out)];
        args.extend(images.iter().map(|p| s(p)));
        let err = fails(&args, "d-bad.png");
        assert!(!err.contains("e-bad.png"), "{threads} threads: {err}");
        assert!(!out.exists());
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// `--threads` outside 1..=1024 is a usage error (exit 2, one line) before any work: a huge
/// count used to try to start that many threads (100,000 hung for over a minute).
#[test]
fn threads_out_of_range_is_a_usage_error() {
    for (n, needle) in [
        ("0", "at least 1"),
        ("1025", "limit of 1024"),
        ("100000", "limit of 1024"),
        ("18446744073709551615", "limit of 1024"),
    ] {
        let o = run(&["--threads", n, "regions", "--out", "/nonexistent", "x.png"]);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "--threads {n}: {err}");
        assert_eq!(err.trim_end().lines().count(), 1, "not one line: {err}");
        assert!(err.contains(needle), "`{needle}` not in: {err}");
    }
}

/// Every subcommand's --help has a description and examples.
#[test]
fn help_has_examples() {
    for sub in [
        &["regions"][..],
        &["match"],
        &["track"],
        &["lwpr"],
        &["eval"],
        &[],
    ] {
        let mut args = sub.to_vec();
        args.push("--help");
        let o = ok(&args);
        let text = String::from_utf8(o.stdout).unwrap();
        assert!(text.contains("Examples:"), "{sub:?}: {text}");
    }
}

/// `visguide eval` on a generated Oxford-layout folder prints one row per pair and combination
/// and writes the same numbers as JSON.
#[test]
fn eval_scores_a_sequence_folder() {
    let dir = temp("eval");
    let seq = dir.join("mine");
    std::fs::create_dir_all(&seq).unwrap();
    scene(&identity(), 240, 180, 5)
        .save(seq.join("img1.png"))
        .unwrap();
    let h = warp();
    scene(&h, 240, 180, 5).save(seq.join("img2.png")).unwrap();
    std::fs::write(seq.join("H1to2p"), h.to_text()).unwrap();
    let json = dir.join("scores.json");
    let o = ok(&["eval", "-q", s(&seq), "--out", s(&json)]);
    let text = String::from_utf8(o.stdout).unwrap();
    assert_eq!(text.lines().count(), 1 + 8);
    let rows = json_file(&json);
    assert_eq!(rows.as_array().unwrap().len(), 8);
    assert!(
        rows[1]["combination"] == "FD Corr/Affine" && rows[1]["existing"].as_u64().unwrap() > 5
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

/// `--quiet` (`-q`): a successful run prints nothing on stderr, where it otherwise prints its
/// summary; an error is still printed.
#[test]
fn quiet_prints_nothing_but_errors() {
    let dir = temp("quiet");
    let (data, model) = table(&dir);
    let args = fit_args(&data, &model, "1");
    let loud: Vec<&str> = args.iter().copied().filter(|a| *a != "-q").collect();
    let o = ok(&loud);
    assert!(!o.stderr.is_empty(), "no summary without --quiet");
    for quiet in [&args[..], &[&["--quiet"][..], &loud[..]].concat()] {
        let o = ok(quiet);
        assert!(
            o.stderr.is_empty(),
            "{quiet:?}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
    }
    let missing = dir.join("missing.csv");
    fails(&fit_args(&missing, &model, "1"), "missing.csv");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A usage error (an unknown option, a missing argument, a bad value) exits with code 2 and
/// does no work, as `visguide --help` says; a failed run exits with 1 (`fails`).
#[test]
fn usage_errors_exit_with_code_2() {
    let dir = temp("usage");
    let out = dir.join("out");
    for args in [
        &["regions", "--no-such-option", "--out", s(&out), "x.png"][..],
        &["regions", "--out", s(&out)],
        &["regions", "--preset", "sift", "--out", s(&out), "x.png"],
        &["lwpr", "fit"],
        &["no-such-command"],
    ] {
        let o = run(args);
        assert_eq!(
            o.status.code(),
            Some(2),
            "{args:?}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        assert!(!out.exists(), "{args:?} wrote output");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Checks a failed run's output: exit code 1, exactly one line on stderr mentioning
/// `needle`, no panic.
fn failed(o: &Output, what: &str, needle: &str) -> String {
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    assert_eq!(o.status.code(), Some(1), "{what}: {err}");
    assert_eq!(
        err.trim_end().lines().count(),
        1,
        "{what}: not one line: {err}"
    );
    assert!(err.starts_with("visguide: error: "), "{what}: {err}");
    assert!(err.contains(needle), "{what}: `{needle}` not in: {err}");
    err
}

/// Which standard stream [`run_closed`] closes.
#[derive(Clone, Copy)]
enum Closed {
    Stdout,
    Stderr,
}

/// Runs the binary with standard output (or standard error) a pipe whose reading end is
/// closed before the binary starts, as `visguide … | head -0` (or `2>&1 | head -0`) does at
/// the latest; closed before the start, so no write of the binary can get in first.
fn run_closed(args: &[&str], closed: Closed) -> Output {
    use std::process::Stdio;
    let (reader, writer) = std::io::pipe().expect("a pipe");
    drop(reader);
    let mut c = bin();
    c.args(args).stdin(Stdio::null());
    match closed {
        Closed::Stdout => c.stdout(writer).stderr(Stdio::piped()),
        Closed::Stderr => c.stdout(Stdio::piped()).stderr(writer),
    };
    let o = c.output().expect("the binary runs");
    // `c` holds the pipe's writing end until it is dropped.
    drop(c);
    o
}

/// Standard output closed early (`visguide … | head`): every subcommand that writes to it
/// ends with exit code 1 and one line naming `<stdout>`, never a panic ("failed printing to
/// stdout", exit code 101, as `println!` gives). `eval --out` writes its file before the table,
/// so the file is complete although the table could not be printed (it used to print first and
/// lose the file; its error did not name standard output).
#[test]
fn a_closed_standard_output_is_a_clear_error_not_a_panic() {
    let dir = temp("stdout");
    let (data, model) = fitted_table(&dir);
    let seq = dir.join("mine");
    std::fs::create_dir_all(&seq).unwrap();
    let (img1, img2) = (seq.join("img1.png"), seq.join("img2.png"));
    scene(&identity(), 160, 120, 5).save(&img1).unwrap();
    scene(&warp(), 160, 120, 5).save(&img2).unwrap();
    std::fs::write(seq.join("H1to2p"), warp().to_text()).unwrap();
    let track_train = dir.join("train");
    std::fs::create_dir_all(&track_train).unwrap();
    let walk = |dx: f64| -> String {
        let mut t = String::from("frame,kind,x,y\n");
        for f in 0..40 {
            let (x, y) = (10.0 + dx * f as f64, 20.0 + 0.5 * f as f64);
            t.push_str(&format!(
                "{f},truth,{x},{y}\n{f},det,{},{}\n",
                x + 0.3,
                y - 0.2
            ));
        }
        t
    };
    for (k, dx) in [1.0, 1.5, 2.0].iter().enumerate() {
        std::fs::write(track_train.join(format!("s{k}.csv")), walk(*dx)).unwrap();
    }
    let track_seq = dir.join("seq.csv");
    std::fs::write(&track_seq, walk(1.2)).unwrap();
    let json = dir.join("scores.json");
    for args in [
        &["lwpr", "predict", "-q", s(&model), s(&data)][..],
        &["match", "-q", s(&img1), s(&img2)],
        &["match", "-q", "--format", "csv", s(&img1), s(&img2)],
        &["track", "-q", "--train", s(&track_train), s(&track_seq)],
        &["eval", "-q", s(&seq), "--out", s(&json)],
    ] {
        let o = run_closed(args, Closed::Stdout);
        let err = failed(&o, &format!("{args:?}"), "<stdout>: Broken pipe");
        assert!(!err.contains("panicked"), "{args:?}: {err}");
    }
    let rows = json_file(&json);
    assert_eq!(rows.as_array().unwrap().len(), 8);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Standard error closed early: a successful run still exits with 0 (its summary line is
/// dropped) and a failed one with 1; `eprintln!` panicked on the closed pipe (exit code 101).
#[test]
fn a_closed_standard_error_is_no_panic() {
    let dir = temp("stderr");
    let (data, model) = table(&dir);
    let loud = [
        "lwpr",
        "fit",
        s(&data),
        "--inputs",
        "2",
        "--model",
        s(&model),
    ];
    let o = run_closed(&loud, Closed::Stderr);
    assert_eq!(o.status.code(), Some(0), "{loud:?}");
    assert!(model.is_file());
    let missing = dir.join("missing.csv");
    let o = run_closed(
        &[
            "lwpr",
            "fit",
            s(&missing),
            "--inputs",
            "2",
            "--model",
            s(&model),
        ],
        Closed::Stderr,
    );
    assert_eq!(o.status.code(), Some(1));
    let o = run_closed(&["--threads", "0", "lwpr", "fit", s(&data)], Closed::Stderr);
    assert_eq!(o.status.code(), Some(2));
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Runs the binary with every file it writes limited to 512 bytes (`ulimit -f 1`, `SIGXFSZ`
/// ignored): a write beyond that fails with "File too large" (EFBIG), also for root, so it
/// stands for a full disk or a quota in the middle of a write.
#[cfg(unix)]
fn run_limited(args: &[&str]) -> Output {
    Command::new("sh")
        .arg("-c")
        .arg("trap '' XFSZ; ulimit -f 1; exec \"$0\" \"$@\"")
        .arg(env!("CARGO_BIN_EXE_visguide"))
        .args(args)
        .output()
        .expect("sh runs")
}

/// The files of `dir`, sorted, with their contents.
fn contents(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut v: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| {
            let p = e.unwrap().path();
            let name = p.file_name().unwrap().to_string_lossy().into_owned();
            (name, std::fs::read(&p).unwrap_or_default())
        })
        .collect();
    v.sort();
    v
}

/// A write that fails in the middle (the disk full after 512 bytes) is an error naming the
/// output file; the file that was there keeps its contents byte for byte and no temporary
/// file is left, for every way the binary writes: one file through a buffer (`lwpr predict
/// --out`, whose ~6 KB sit in the buffer until the final flush, which is where it fails), a
/// model file, a file and a picture written together (`match`), and the staged files of
/// `regions`.
#[cfg(unix)]
#[test]
fn a_write_that_fails_midway_keeps_the_old_file() {
    let dir = temp("efbig");
    let out = dir.join("out");
    std::fs::create_dir_all(&out).unwrap();
    let (data, model) = fitted_table(&dir);
    let (a, b) = image_pair(&dir);
    // The predictions fit in the write buffer (8 KiB) but not in the limit: the failure
    // comes at the flush.
    let whole = dir.join("whole.csv");
    ok(&[
        "lwpr",
        "predict",
        "-q",
        s(&model),
        s(&data),
        "--out",
        s(&whole),
    ]);
    let size = std::fs::metadata(&whole).unwrap().len();
    assert!((1024..8192).contains(&size), "{size} bytes");
    let (pred, refit, m, pic) = (
        out.join("p.csv"),
        out.join("refit.json"),
        out.join("m.json"),
        out.join("p.png"),
    );
    for p in [&pred, &refit, &m, &pic, &out.join("a.json")] {
        std::fs::write(p, b"old").unwrap();
    }
    let before = contents(&out);
    let refit_args = fit_args(&data, &refit, "1");
    let cases: [(&[&str], &Path); 4] = [
        (
            &[
                "lwpr",
                "predict",
                "-q",
                s(&model),
                s(&data),
                "--out",
                s(&pred),
            ],
            &pred,
        ),
        (&refit_args, &refit),
        (
            &[
                "match",
                "-q",
                s(&a),
                s(&b),
                "--out",
                s(&m),
                "--picture",
                s(&pic),
            ],
            &m,
        ),
        (
            &["regions", "-q", "--format", "json", "--out", s(&out), s(&a)],
            &out.join("a.json"),
        ),
    ];
    for (args, target) in cases {
        let o = run_limited(args);
        let err = failed(&o, &format!("{args:?}"), "File too large");
        let named = [target, &pic].iter().any(|t| err.contains(s(t)));
        assert!(named, "{args:?}: the file is not named: {err}");
        assert_eq!(contents(&out), before, "{args:?}");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// An output file that names one of the run's inputs is refused before any work, and the input
/// is left as it was (it used to be read and then replaced: `lwpr fit d.csv --model d.csv`
/// turned the table into the model, exit code 0). Also when spelt differently (a bare name in
/// the current folder, `./`), and for the files of a folder the run reads (training
/// sequences, an evaluated sequence). An output that is a directory, or in a folder that does
/// not exist, is refused before any work too.
#[test]
fn an_output_that_names_an_input_is_refused() {
    let dir = temp("in-out");
    let (data, model) = fitted_table(&dir);
    let (a, b) = image_pair(&dir);
    let h = dir.join("H1to2p");
    std::fs::write(&h, warp().to_text()).unwrap();
    let a_regions = dir.join("a-regions.png");
    std::fs::copy(&b, &a_regions).unwrap();
    let train = dir.join("train");
    std::fs::create_dir_all(&train).unwrap();
    let walk = "frame,kind,x,y\n0,truth,1,2\n1,truth,2,3\n2,truth,3,4\n";
    std::fs::write(train.join("s.csv"), walk).unwrap();
    let seq = dir.join("seq.csv");
    std::fs::write(&seq, walk).unwrap();
    let mine = dir.join("mine");
    std::fs::create_dir_all(&mine).unwrap();
    std::fs::copy(&a, mine.join("img1.png")).unwrap();
    let dotted = format!("{}/./d.csv", s(&dir));
    let before = contents(&dir);
    let elsewhere = dir.join("no-such-folder").join("p.csv");
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (fit_args(&data, &data, "1").to_vec(), "d.csv"),
        (
            vec![
                "lwpr", "fit", "d.csv", "--inputs", "2", "--model", "./d.csv",
            ],
            "d.csv",
        ),
        (
            vec!["lwpr", "fit", s(&data), "--inputs", "2", "--model", &dotted],
            "d.csv",
        ),
        (
            vec!["lwpr", "predict", "m.json", "d.csv", "--out", "m.json"],
            "m.json",
        ),
        (
            vec!["lwpr", "predict", s(&model), s(&data), "--out", s(&data)],
            "d.csv",
        ),
        (
            vec!["lwpr", "predict", s(&model), s(&data), "--out", s(&dir)],
            "is a directory",
        ),
        (
            vec![
                "lwpr",
                "predict",
                s(&model),
                s(&data),
                "--out",
                s(&elsewhere),
            ],
            "does not exist",
        ),
        (vec!["match", s(&a), s(&b), "--out", s(&a)], "a.png"),
        (vec!["match", s(&a), s(&b), "--picture", "b.png"], "b.png"),
        (
            vec![
                "match",
                s(&a),
                s(&b),
                "--homography",
                "H1to2p",
                "--out",
                "H1to2p",
            ],
            "H1to2p",
        ),
        (
            vec!["regions", "--draw", "--out", s(&dir), s(&a), s(&a_regions)],
            "a-regions.png",
        ),
        (
            vec![
                "track",
                "learn",
                "--train",
                s(&train),
                "--model",
                "train/s.csv",
            ],
            "s.csv",
        ),
        (
            vec!["track", "run", s(&model), s(&seq), "--out", s(&model)],
            "m.json",
        ),
        (
            vec!["track", "--train", s(&train), s(&seq), "--out", "seq.csv"],
            "seq.csv",
        ),
        (vec!["eval", s(&mine), "--out", "mine/img1.png"], "img1.png"),
    ];
    for (args, needle) in &cases {
        let o = bin().args(args).current_dir(&dir).output().unwrap();
        let err = failed(&o, &format!("{args:?}"), needle);
        let reason = ["is also an input", "is a directory", "does not exist"];
        assert!(reason.iter().any(|r| err.contains(r)), "{args:?}: {err}");
        assert_eq!(contents(&dir), before, "{args:?} changed a file");
    }
    // A bare output name in the current folder that is not an input is fine.
    let o = bin()
        .args(["lwpr", "predict", "-q", "m.json", "d.csv", "--out", "p.csv"])
        .current_dir(&dir)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(dir.join("p.csv").is_file());
    std::fs::remove_dir_all(&dir).unwrap();
}

/// `visguide match --homography` with a valid but strongly anisotropic homography (area kept,
/// x scaled by 10⁸ and y by 10⁻⁸) that maps a region of the second image back onto the same
/// region of the first: mapped back, it is a needle whose overlap window with that region the
/// 32-bit grid of the overlap error cannot step through. The run used to hang there; it ends,
/// the pair scored as not overlapping (ε = 1).
#[test]
fn match_with_a_needle_making_homography_ends() {
    let dir = temp("needle");
    let img = scene(&identity(), 160, 120, 3);
    let pa = dir.join("a.png");
    img.save(&pa).unwrap();
    let f = visguide::detect(&img, &MatchSettings::paper().mser.0).unwrap();
    let (u, v) = (f.frames[0].u, f.frames[0].v);
    let k = 1e8;
    // H⁻¹ (image 2 → image 1) fixes (u, v), scales x by 1/k and y by k.
    let h_inv =
        Homography::from_row_major(&[1.0 / k, 0.0, u - u / k, 0.0, k, v - k * v, 0.0, 0.0, 1.0])
            .unwrap();
    let ph = dir.join("H1to2p");
    std::fs::write(&ph, h_inv.inverse().to_text()).unwrap();
    let json = dir.join("m.json");
    let mut child = bin()
        .args(["match", "-q", s(&pa), s(&pa), "--homography", s(&ph)])
        .args(["--out", s(&json)])
        .spawn()
        .unwrap();
    let start = std::time::Instant::now();
    let status = loop {
        if let Some(status) = child.try_wait().unwrap() {
            break status;
        }
        if start.elapsed() > std::time::Duration::from_secs(60) {
            child.kill().unwrap();
            let _ = child.wait();
            panic!("visguide match still runs after 60 s");
        }
        std::thread::sleep(std::time::Duration::from_millis(50));
    };
    assert!(status.success(), "{status}");
    let doc = json_file(&json);
    assert!(doc["score"]["existing"].is_u64(), "{}", doc["score"]);
}
