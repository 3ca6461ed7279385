//! Projection against hand-computed pixels, undistortion round trip, cameras that do not see
//! the scene.

use arm_sim::{ArmSim, ArmSimError, Camera, CameraConfig, SimConfig};
use nalgebra::Vector3;
use proptest::prelude::*;

fn overhead() -> Camera {
    // 1 m above the base, looking straight down: image right = world −y, image down = world −x.
    Camera::new(
        &CameraConfig::looking_at([0.0, 0.0, 1000.0], [0.0, 0.0, 0.0]),
        0,
    )
    .unwrap()
}

#[test]
fn projection_by_hand() {
    let cam = overhead();
    // (100, 50, 0): camera frame (−50, −100, 1000); x = −0.05, y = −0.1, r² = 0.0125,
    // d = 1 − 0.1·0.0125 + 0.01·0.0125² = 0.9987515625.
    let [u, v] = cam.project(&Vector3::new(100.0, 50.0, 0.0)).unwrap();
    let d = 0.998_751_562_5;
    assert!((u - (319.5 - 560.0 * d * 0.05)).abs() < 1e-9, "u = {u}");
    assert!((v - (239.5 - 560.0 * d * 0.1)).abs() < 1e-9, "v = {v}");
    assert!((u - 291.534_956_25).abs() < 1e-9 && (v - 183.569_912_5).abs() < 1e-9);
    // A point on the optical axis lands on the principal point whatever its depth.
    let [u, v] = cam.project(&Vector3::new(0.0, 0.0, 400.0)).unwrap();
    assert!((u - 319.5).abs() < 1e-12 && (v - 239.5).abs() < 1e-12);
}

#[test]
fn projection_without_distortion_is_pinhole() {
    let mut cfg = CameraConfig::looking_at([500.0, 0.0, 0.0], [0.0, 0.0, 0.0]);
    cfg.position_mm[2] = 1e-9 + 1.0; // just above the table
    cfg.look_at_mm[2] = 1.0;
    cfg.k1 = 0.0;
    cfg.k2 = 0.0;
    let cam = Camera::new(&cfg, 0).unwrap();
    // Looking along −x: image right = +y, down = −z. Point (0, −100, −49): 500 mm ahead,
    // x = −100/500, y = 50/500.
    let [u, v] = cam.project(&Vector3::new(0.0, -100.0, -49.0)).unwrap();
    assert!(
        (u - (319.5 - 112.0)).abs() < 1e-9 && (v - (239.5 + 56.0)).abs() < 1e-9,
        "{u} {v}"
    );
}

proptest! {
    #![proptest_config(crate::seeded(256))]
    #[test]
    fn undistort_round_trip(u in -0.5f64..639.5, v in -0.5f64..479.5) {
        let cam = overhead();
        let [x, y] = cam.undistort(u, v).unwrap();
        let [u2, v2] = cam.normalised_to_pixel(x, y);
        prop_assert!((u - u2).abs() < 1e-9 && (v - v2).abs() < 1e-9);
        // And through the world: the ray's point projects back to the pixel.
        let p = cam.centre + cam.ray(u, v).unwrap() * 700.0;
        let [u3, v3] = cam.project(&p).unwrap();
        prop_assert!((u - u3).abs() < 1e-7 && (v - v3).abs() < 1e-7);
    }
}

#[test]
fn point_behind_camera_is_an_error() {
    let cam = overhead();
    let e = cam.project(&Vector3::new(0.0, 0.0, 1500.0)).unwrap_err();
    assert!(matches!(
        e,
        ArmSimError::PointBehindCamera { camera: 0, .. }
    ));
    let e = cam.project(&Vector3::new(f64::NAN, 0.0, 0.0)).unwrap_err();
    assert!(matches!(e, ArmSimError::NonFinite { .. }));
    assert!(matches!(
        cam.undistort(f64::INFINITY, 0.0),
        Err(ArmSimError::NonFinite { .. })
    ));
}

#[test]
fn camera_behind_scene_is_a_typed_error() {
    // Looking away from the arm.
    let mut cfg = SimConfig::default();
    cfg.cameras[1] = CameraConfig::looking_at([400.0, 0.0, 300.0], [900.0, 0.0, 300.0]);
    let e = ArmSim::new(cfg).err().unwrap();
    assert!(
        matches!(e, ArmSimError::CameraBehindScene { camera: 1, .. }),
        "{e}"
    );
    // Under the table.
    let mut cfg = SimConfig::default();
    cfg.cameras[0].position_mm[2] = -50.0;
    let e = ArmSim::new(cfg).err().unwrap();
    assert!(
        matches!(e, ArmSimError::CameraBehindScene { camera: 0, .. }),
        "{e}"
    );
    // Inspection asks for a camera that does not exist.
    let sim = ArmSim::new(SimConfig::ideal()).unwrap();
    assert!(matches!(
        sim.inspect().project(2, &Vector3::zeros()),
        Err(ArmSimError::NoSuchCamera {
            camera: 2,
            count: 2
        })
    ));
}

#[test]
fn default_cameras_see_the_home_tip() {
    let sim = ArmSim::new(SimConfig::default()).unwrap();
    for (i, uv) in sim.inspect().tip_pixels().unwrap().into_iter().enumerate() {
        assert!(
            sim.inspect().camera(i).unwrap().in_image(uv),
            "camera {i}: {uv:?}"
        );
    }
}

#[test]
fn finger_middle_pixels_project_the_finger_ends_middle_into_every_camera() {
    let config = SimConfig::default().with_image_scale(0.25);
    let mut one_camera = config.clone();
    one_camera.cameras.truncate(1);
    for (config, cameras) in [(config, 2), (one_camera, 1)] {
        let mut sim = ArmSim::new(config).unwrap();
        for set_points in [
            [1500.0; 6],
            [1600.0, 1350.0, 1700.0, 1500.0, 1500.0, 1200.0],
            [1300.0, 1450.0, 1850.0, 1200.0, 1900.0, 2000.0],
        ] {
            sim.command(&set_points).unwrap();
            let inspect = sim.inspect();
            let [a, b] = inspect.pose().finger_ends;
            let mean = Vector3::new((a.x + b.x) / 2.0, (a.y + b.y) / 2.0, (a.z + b.z) / 2.0);
            let pixels = inspect.finger_middle_pixels().unwrap();
            let tips = inspect.tip_pixels().unwrap();
            assert_eq!(pixels.len(), cameras);
            for (c, (uv, tip)) in pixels.into_iter().zip(tips).enumerate() {
                assert_eq!(uv, inspect.project(c, &mean).unwrap(), "camera {c}");
                // Not the tool point, 8 mm further back.
                assert!((uv[0] - tip[0]).hypot(uv[1] - tip[1]) > 0.1, "camera {c}");
            }
        }
    }
}

/// `Camera::new` is public: a configuration that never went through `SimConfig::validate` (built
/// by hand or deserialised) with degenerate intrinsics or a pose too large to subtract used to
/// give a camera whose projections were NaN, infinite or always the principal point.
#[test]
fn degenerate_camera_parameters_are_refused_by_camera_new() {
    let base = || CameraConfig::looking_at([500.0, 0.0, 300.0], [0.0, 0.0, 0.0]);
    type Spoil = fn(&mut CameraConfig);
    let cases: [(&str, Spoil); 11] = [
        ("cameras[0].fx", |c| c.fx = 0.0),
        ("cameras[0].fx", |c| c.fx = f64::NAN),
        ("cameras[0].fy", |c| c.fy = -1.0),
        ("cameras[0].cx", |c| c.cx = f64::INFINITY),
        ("cameras[0].k1", |c| c.k1 = f64::NAN),
        ("cameras[0].k1", |c| c.k1 = -5.0),
        ("cameras[0].roll_deg", |c| c.roll_deg = f64::NAN),
        ("cameras[0].width", |c| c.width = 0),
        ("cameras[0].position_mm", |c| c.position_mm[0] = f64::NAN),
        // Finite, but the optical axis overflows: look_at − position is infinite.
        ("cameras[0].position_mm", |c| {
            c.position_mm = [1e308, 1e308, 1e308];
            c.look_at_mm = [-1e308, -1e308, -1e308];
        }),
        ("cameras[0].position_mm", |c| {
            c.position_mm = [1.5e308, 0.0, 1.0];
            c.look_at_mm = [-1.5e308, 0.0, 0.0];
        }),
    ];
    for (key, spoil) in cases {
        let mut cfg = base();
        spoil(&mut cfg);
        match Camera::new(&cfg, 0) {
            Err(ArmSimError::InvalidConfig { key: k, .. }) => assert_eq!(k, key, "{cfg:?}"),
            other => panic!("{cfg:?}: expected InvalidConfig for {key}, got {other:?}"),
        }
        assert!(cfg.validate(0).is_err());
    }
}

/// `CameraConfig::scaled`: the size is rounded and the view unchanged, pixel centres at
/// integers, so every world point lands at `(u + ½)·f − ½` of its full-size pixel, where `f` is
/// the actual ratio of the (rounded) sizes.
#[test]
fn scaled_cameras_see_the_same_view() {
    let full_cfg = CameraConfig::looking_at([450.0, -250.0, 380.0], [120.0, 20.0, 60.0]);
    let full = Camera::new(&full_cfg, 0).unwrap();
    for factor in [0.25, 0.5, 0.33, 1.7] {
        let cfg = full_cfg.scaled(factor);
        let (w, h) = (
            (640.0 * factor).round() as u32,
            (480.0 * factor).round() as u32,
        );
        assert_eq!((cfg.width, cfg.height), (w, h), "{factor}");
        let (fu, fv) = (w as f64 / 640.0, h as f64 / 480.0);
        let small = Camera::new(&cfg, 0).unwrap();
        for p in [
            [120.0, 20.0, 60.0],
            [0.0, 0.0, 0.0],
            [200.0, 100.0, 10.0],
            [60.0, -90.0, 150.0],
        ] {
            let p = Vector3::from(p);
            let [u, v] = full.project(&p).unwrap();
            let [us, vs] = small.project(&p).unwrap();
            assert!(
                (us - ((u + 0.5) * fu - 0.5)).abs() < 1e-9
                    && (vs - ((v + 0.5) * fv - 0.5)).abs() < 1e-9,
                "{factor}: {p:?} at ({u}, {v}) full size, ({us}, {vs}) scaled"
            );
        }
    }
    // `SimConfig::with_image_scale` scales every camera that way.
    let cfg = SimConfig::default();
    let scaled = cfg.clone().with_image_scale(0.25);
    for (a, b) in cfg.cameras.iter().zip(&scaled.cameras) {
        assert_eq!(*b, a.scaled(0.25));
    }
}
