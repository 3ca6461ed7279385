//! Writes the generated part of the seed corpus (small valid files of every format) into
//! `corpus/<target>/seed-*`: `cargo run --manifest-path xtask/fuzz/Cargo.toml --example
//! write_seeds`. Deterministic (fixed seeds), so rerunning rewrites the same files.

use std::path::PathBuf;

fn put(target: &str, name: &str, bytes: impl AsRef<[u8]>) {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("corpus")
        .join(target);
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join(format!("seed-{name}")), bytes).unwrap();
}

fn lwpr_model(n_in: usize, samples: usize) -> lwpr::Lwpr {
    let mut m = lwpr::LwprBuilder::new(n_in, 1)
        .init_d_spherical(20.0)
        .build()
        .unwrap();
    for i in 0..samples {
        let x: Vec<f64> = (0..n_in)
            .map(|d| ((i * (d + 3)) % 17) as f64 / 17.0)
            .collect();
        let y = x.iter().map(|v| v.sin()).sum::<f64>();
        m.update(&x, &[y]).unwrap();
    }
    m
}

fn main() {
    // Oxford region files: without and with descriptors.
    let e = |u, v, a, b, c| mser::Ellipse { u, v, a, b, c };
    let mut text = Vec::new();
    mser::write_regions(
        &mut text,
        &[
            e(10.0, 20.0, 0.01, 0.001, 0.02),
            e(5.5, 7.25, 1.0, 0.0, 1.0),
        ],
    )
    .unwrap();
    put("oxford_regions", "plain", &text);
    put(
        "oxford_regions",
        "descriptor",
        "2\n1\n10 20 0.01 0.001 0.02 0.5 0.25\n",
    );
    put("oxford_regions", "empty", "1.0\n0\n");

    // Tracking CSV.
    let seqs = cbt_tracker::sim::generate(
        &cbt_tracker::sim::Scenario::default(),
        &cbt_tracker::sim::Level::preset(1),
        1,
        6,
        7,
    )
    .expect("the default scenario and preset levels are valid");
    put(
        "tracking_csv",
        "rc-car",
        cbt_tracker::csv::to_string(&seqs[0]),
    );
    put(
        "tracking_csv",
        "gaps",
        "frame,kind,x,y\n0,truth,1,2\n0,det,1.5,2\n3,det,-4,1e3\n\n5,truth,0,0\n",
    );

    // Arm configuration.
    put(
        "arm_config",
        "default",
        arm_sim::SimConfig::default().to_json(),
    );

    // LWPR: a 1-D and a 3-D model, untrained and trained.
    for (name, m) in [
        ("1d", lwpr_model(1, 30)),
        ("3d", lwpr_model(3, 40)),
        ("untrained", lwpr_model(2, 0)),
    ] {
        put("lwpr_json", name, m.to_json());
        put("lwpr_xml", name, m.to_xml());
        let bin = m.to_binary();
        put(
            "lwpr_binary",
            &format!("{name}-payload"),
            &bin[20..bin.len() - 8],
        );
        put("lwpr_binary", name, bin);
    }

    // CBT: untrained and learned models of the image and the separable layouts, and a tracker.
    use cbt_tracker::{CbtConfig, CbtModel, CbtTracker, Layout, Space};
    let train = cbt_tracker::sim::generate(
        &cbt_tracker::sim::Scenario::default(),
        &cbt_tracker::sim::Level::preset(0),
        1,
        20,
        11,
    )
    .expect("the default scenario and preset levels are valid");
    let scene = cbt_tracker::sim::Scenario::default();
    let space = || Space::image(scene.width, scene.height, 64.0).unwrap();
    for (name, layout) in [
        ("separable", Layout::Separable),
        ("stationary", Layout::Stationary),
    ] {
        let config = CbtConfig {
            layout,
            ..CbtConfig::default()
        };
        if let Ok(m) = CbtModel::untrained(space(), config) {
            put(
                "cbt_model",
                &format!("{name}-untrained"),
                serde_json::to_vec(&m).unwrap(),
            );
        }
        if let Ok(m) = CbtModel::learn_sequences(space(), config, &train) {
            put("cbt_model", name, serde_json::to_vec(&m).unwrap());
            let mut t = CbtTracker::new(m);
            use cbt_tracker::Tracker;
            for f in &train[0].frames[..3] {
                let _ = t.step(&f.detections);
            }
            put("cbt_tracker", name, serde_json::to_vec(&t).unwrap());
        }
    }

    // servo-loop: a trained inverse model; recognition models written by hand (learning one
    // needs a simulated arm and takes minutes).
    let mut inv = servo_loop::InverseModel::new(2, 2, &Default::default()).unwrap();
    for i in 0..30 {
        let x = [(i % 7) as f64 * 10.0, (i % 5) as f64 * 12.0];
        let _ = inv.update(&x, &[x[0] / 100.0, x[1] / 90.0]);
    }
    put(
        "servo_inverse_model",
        "trained",
        serde_json::to_vec(&inv).unwrap(),
    );
    let config = serde_json::to_string(&servo_loop::SilhouetteConfig::default()).unwrap();
    let scene = r#"{"width":4,"height":2,"background":[0,1,2,3,4,5,6,7],"half_background":[1,2],"noise_sigma":1.5,"root":[1.0,1.0],"end_length":2.0,"end_area":3.0}"#;
    let offsets: Vec<String> = (0..40)
        .map(|i| format!("{}", (i % 5) as f64 * 0.5))
        .collect();
    let descriptors: Vec<String> = (0..40).map(|i| format!("{}", i as f64 * 3.0)).collect();
    let correction = format!(
        r#"{{"cameras":1,"descriptors":[{}],"offsets":[{}],"bandwidth":4.0}}"#,
        descriptors.join(","),
        offsets.join(",")
    );
    put(
        "servo_recognition",
        "tip-model",
        format!(r#"{{"config":{config},"cameras":[{scene}]}}"#),
    );
    put(
        "servo_recognition",
        "tip-model-corrected",
        format!(r#"{{"config":{config},"cameras":[{scene}],"correction":{correction}}}"#),
    );
    put("servo_recognition", "correction", &correction);

    // MOTChallenge ground truth: two ids (one with a gap and an ignored row), decimal ids, a BOM.
    put(
        "tracking_mot",
        "two-ids",
        "1,1,10,20,4,8,1,1,1\n2,1,12,21,4,8,1\n4,1,15,22,4,8,1\n1,2,0,0,2,2,0\n\
         1,2,50.5,60,10,20,1\n2,2,51,60,10,20,1\n3,2,52,61,10,20,1\n",
    );
    put(
        "tracking_mot",
        "bom-decimal-id",
        "\u{feff}1,3.0,-5,-5,0,0\n\n2,3.0,-4,-5,0,0\n",
    );

    // visguide's command line: tables, model files, images.
    put(
        "visguide_table",
        "header",
        "# samples\nx1,x2,y\n\n1,2,3\n4, 5.5 ,-6e-1\n",
    );
    put("visguide_table", "plain", "0.5\n-1e300\n2\n");
    let scratch = std::env::temp_dir().join(format!("write-seeds-{}.json", std::process::id()));
    let lwpr_file = visguide::models::LwprFile::new(
        vec!["a".into(), "b".into()],
        vec!["y".into()],
        &lwpr_model(2, 30),
    )
    .unwrap();
    lwpr_file.save(&scratch).unwrap();
    put("visguide_models", "lwpr", std::fs::read(&scratch).unwrap());
    let scene = cbt_tracker::sim::Scenario::default();
    if let Ok(cbt) = CbtModel::learn_sequences(space(), CbtConfig::default(), &train) {
        let file = visguide::models::TrackModelFile {
            format: visguide::models::CBT_FORMAT.into(),
            version: visguide::models::MODEL_VERSION,
            extent: [0.0, scene.width, 0.0, scene.height],
            sequences: train.len(),
            cbt,
            calibration: cbt_tracker::Calibration::estimate(&train, 10.0).unwrap(),
        };
        file.save(&scratch).unwrap();
        put("visguide_models", "cbt", std::fs::read(&scratch).unwrap());
    }
    std::fs::remove_file(&scratch).unwrap();
    let grey = image::GrayImage::from_fn(24, 16, |x, y| {
        image::Luma([if (x / 6 + y / 4) % 2 == 0 { 40 } else { 200 }])
    });
    let mut pgm = b"P5\n# blocks\n24 16\n255\n".to_vec();
    pgm.extend_from_slice(grey.as_raw());
    put("visguide_image", "blocks.pgm", pgm);
    let rgb = image::RgbImage::from_fn(4, 3, |x, y| image::Rgb([x as u8 * 60, y as u8 * 90, 17]));
    let mut ppm = b"P6\n4 3\n255\n".to_vec();
    ppm.extend_from_slice(rgb.as_raw());
    put("visguide_image", "colour.ppm", ppm);
    let mut png = Vec::new();
    image::DynamicImage::ImageRgb8(rgb)
        .write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
        .unwrap();
    put("visguide_image", "colour.png", png);
}
