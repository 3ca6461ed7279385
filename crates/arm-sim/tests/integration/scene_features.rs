//! The opt-in scene features (a moving distractor, lighting drift; occlusion comes from clutter
//! placed in front of the workspace): off by default, so the default configuration, its JSON
//! and every image it renders are unchanged; on, they do what their docs say; bad values are
//! typed errors naming the key; the shipped `hard-scene.json` uses all three.

use arm_sim::{
    ArmSim, ArmSimError, Distractor, LABEL_DISTRACTOR, LABEL_FINGER_A, LABEL_FINGER_B,
    LightingDrift, SimConfig,
};

fn hard() -> SimConfig {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("arms/hard-scene.json");
    SimConfig::read_file(path).expect("the hard scene loads")
}

fn distractor() -> Distractor {
    Distractor {
        size_mm: [50.0, 16.0, 24.0],
        albedo: 0.75,
        path_centre_mm: [250.0, 0.0],
        path_radius_mm: 70.0,
        period_frames: 37.0,
    }
}

/// Pixels of camera `cam`'s last capture labelled `label`, and their centroid.
fn labelled(sim: &ArmSim, cam: usize, label: u8) -> (usize, [f64; 2]) {
    let l = sim.inspect().labels(cam).unwrap();
    let (mut n, mut sx, mut sy) = (0usize, 0.0, 0.0);
    for (x, y, p) in l.enumerate_pixels() {
        if p[0] == label {
            n += 1;
            sx += f64::from(x);
            sy += f64::from(y);
        }
    }
    (n, [sx / n.max(1) as f64, sy / n.max(1) as f64])
}

#[test]
fn off_by_default_and_absent_from_the_json() {
    let d = SimConfig::default();
    assert!(d.scene.distractor.is_none() && d.scene.lighting_drift.is_none());
    let json = d.to_json();
    assert!(!json.contains("distractor") && !json.contains("lighting_drift"));
    assert_eq!(SimConfig::from_json(&json).unwrap(), d);
    // The committed default file (written before the features existed) reads as "off".
    let committed = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../fixtures/arm-sim/default-config.json");
    assert_eq!(SimConfig::read_file(committed).unwrap(), d);
}

#[test]
fn the_distractor_moves_by_itself_and_is_as_bright_as_the_gripper() {
    let mut config = SimConfig::ideal();
    config.scene.distractor = Some(distractor());
    let mut sim = ArmSim::new(config).unwrap();
    let mut still = ArmSim::new(SimConfig::ideal()).unwrap();
    let a = sim.capture();
    let (n0, c0) = labelled(&sim, 0, LABEL_DISTRACTOR);
    let b = sim.capture();
    let (n1, c1) = labelled(&sim, 0, LABEL_DISTRACTOR);
    // Visible in both frames, moved between them with the arm standing still.
    assert!(n0 > 100 && n1 > 100, "{n0} {n1} pixels");
    let moved = (c1[0] - c0[0]).hypot(c1[1] - c0[1]);
    assert!(moved > 2.0, "moved {moved:.2} px");
    assert_ne!(a[0], b[0]);
    // Without it, an ideal scene's two frames are identical.
    assert_eq!(still.capture(), still.capture());
    // Its placement follows the frame count: back where it started after one period.
    let d = distractor();
    let (p0, y0) = d.placement(0);
    let (p1, y1) = d.placement(37);
    assert!((p0[0] - p1[0]).abs() < 1e-9 && (p0[1] - p1[1]).abs() < 1e-9);
    assert!((y1 - y0 - std::f64::consts::TAU).abs() < 1e-9);
    assert!((p0[0] - 320.0).abs() < 1e-9 && p0[1].abs() < 1e-9);
}

#[test]
fn lighting_drifts_with_the_frame_count() {
    let drift = LightingDrift {
        amplitude: 0.2,
        period_frames: 8.0,
    };
    assert_eq!(drift.factor(0), 1.0);
    assert!((drift.factor(2) - 1.2).abs() < 1e-12);
    assert!((drift.factor(6) - 0.8).abs() < 1e-12);
    let mut config = SimConfig::ideal();
    config.scene.lighting_drift = Some(drift);
    let mut sim = ArmSim::new(config).unwrap();
    let mut plain = ArmSim::new(SimConfig::ideal()).unwrap();
    let mean = |img: &image::GrayImage| {
        img.pixels().map(|p| f64::from(p[0])).sum::<f64>() / f64::from(img.width() * img.height())
    };
    let base = mean(&plain.capture()[0]);
    let means: Vec<f64> = (0..7).map(|_| mean(&sim.capture()[0])).collect();
    // Frame 0 unchanged; frame 2 brighter by about 20 %, frame 6 darker (8-bit saturation
    // keeps the ratio a little below the factor).
    assert!((means[0] - base).abs() < 1e-9);
    assert!(means[2] / base > 1.15, "{:.3}", means[2] / base);
    assert!(means[6] / base < 0.85, "{:.3}", means[6] / base);
}

#[test]
fn bad_values_are_typed_errors_naming_the_key() {
    let cases: Vec<(SimConfig, &str)> = vec![
        {
            let mut c = SimConfig::default();
            c.scene.distractor = Some(Distractor {
                period_frames: 0.0,
                ..distractor()
            });
            (c, "scene.distractor.period_frames")
        },
        {
            let mut c = SimConfig::default();
            c.scene.distractor = Some(Distractor {
                albedo: 0.0,
                ..distractor()
            });
            (c, "scene.distractor.albedo")
        },
        {
            let mut c = SimConfig::default();
            c.scene.distractor = Some(Distractor {
                size_mm: [10.0, f64::NAN, 3.0],
                ..distractor()
            });
            (c, "scene.distractor.size_mm[1]")
        },
        {
            let mut c = SimConfig::default();
            c.scene.lighting_drift = Some(LightingDrift {
                amplitude: 0.7,
                period_frames: 10.0,
            });
            (c, "scene.lighting_drift.amplitude")
        },
        {
            let mut c = SimConfig::default();
            c.scene.lighting_drift = Some(LightingDrift {
                amplitude: 0.1,
                period_frames: -1.0,
            });
            (c, "scene.lighting_drift.period_frames")
        },
        // Periods below one frame were accepted down to 5e-324, where frame / period is +inf
        // and the drift factor sin(inf) = NaN made every captured image black.
        {
            let mut c = SimConfig::default();
            c.scene.lighting_drift = Some(LightingDrift {
                amplitude: 0.1,
                period_frames: 5e-324,
            });
            (c, "scene.lighting_drift.period_frames")
        },
        {
            let mut c = SimConfig::default();
            c.scene.distractor = Some(Distractor {
                period_frames: 0.5,
                ..distractor()
            });
            (c, "scene.distractor.period_frames")
        },
    ];
    for (c, key) in cases {
        match ArmSim::new(c.clone()) {
            Err(ArmSimError::InvalidConfig { key: k, .. }) => assert_eq!(k, key),
            other => panic!("{key}: {:?}", other.err()),
        }
        // The same from JSON.
        assert!(SimConfig::from_json(&c.to_json()).is_err(), "{key}");
    }
    // Unknown keys inside the new sections are refused like everywhere else.
    let json = hard().to_json().replace(
        "\"period_frames\": 37.0",
        "\"period_frames\": 37.0, \"speed\": 1.0",
    );
    assert!(SimConfig::from_json(&json).is_err());
}

/// The hard scene: the default arm and cameras with the distractor, lighting drift and two
/// poles standing between the cameras and the workspace, which hide part of the gripper at
/// some poses (measured from the label images: the fingers' visible pixels against the same
/// pose without the poles).
#[test]
fn the_hard_scene_occludes_the_gripper_at_some_poses() {
    let h = hard();
    let d = SimConfig::default();
    assert_eq!((h.arm.clone(), h.cameras.clone()), (d.arm, d.cameras));
    assert!(h.scene.distractor.is_some() && h.scene.lighting_drift.is_some());
    assert_eq!(h.scene.clutter.len(), d.scene.clutter.len() + 2);
    let mut open = h.clone();
    open.scene.clutter.truncate(d.scene.clutter.len());
    let (mut with, mut without) = (ArmSim::new(h).unwrap(), ArmSim::new(open).unwrap());
    let mut occluded = 0;
    let mut poses = 0;
    for i in 0..24 {
        let t = f64::from(i) / 24.0;
        let c = [
            1167.0 + 666.0 * t,
            1389.0 + 444.0 * ((7.0 * t) % 1.0),
            1111.0 + 500.0 * ((3.0 * t) % 1.0),
            1944.0,
            1500.0,
            1500.0,
        ];
        if with.command(&c).is_err() || without.command(&c).is_err() {
            continue;
        }
        with.capture();
        without.capture();
        for cam in 0..2 {
            let fingers = |s: &ArmSim| {
                labelled(s, cam, LABEL_FINGER_A).0 + labelled(s, cam, LABEL_FINGER_B).0
            };
            let (seen, all) = (fingers(&with), fingers(&without));
            poses += 1;
            if all > 0 && seen * 10 < all * 9 {
                occluded += 1;
            }
        }
    }
    assert!(poses >= 30, "{poses}");
    assert!(
        occluded >= 2 && occluded * 2 <= poses,
        "the fingers partly hidden in {occluded} of {poses} views"
    );
}

/// `into_ideal` switches off the arm's and the camera's faults but keeps the scene: lens
/// distortion, clutter, and the opt-in distractor and lighting drift of the hard scene.
#[test]
fn into_ideal_keeps_the_scene_features() {
    let h = hard();
    let i = h.clone().into_ideal();
    assert_eq!(i.scene.clutter, h.scene.clutter);
    assert_eq!(i.scene.distractor, h.scene.distractor);
    assert_eq!(i.scene.lighting_drift, h.scene.lighting_drift);
    assert_eq!(i.cameras, h.cameras);
    assert!(i.cameras.iter().all(|c| c.k1 != 0.0));
    assert_eq!(
        (
            i.scene.lighting_gain_sigma,
            i.scene.lighting_gradient_sigma,
            i.scene.sensor_noise_sigma
        ),
        (0.0, 0.0, 0.0)
    );
    assert!(
        i.servos
            .iter()
            .all(|s| s.end_noise_deg == 0.0 && s.backlash_deg == 0.0)
    );
    // `ideal()` starts from the default scene, which has neither feature: its light is steady.
    let ideal = SimConfig::ideal();
    assert!(ideal.scene.distractor.is_none() && ideal.scene.lighting_drift.is_none());
    assert_eq!(ideal.scene.clutter, SimConfig::default().scene.clutter);
}
