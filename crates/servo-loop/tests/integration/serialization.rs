//! Learned recognition models read back with serde: a saved model reads back unchanged (same
//! text, same answers), and a file that learning could not have written (a scene of the wrong
//! size, settings `learn` refuses, truncated prototypes, an inconsistent correction) is an
//! error when it is read, never a model that panics or silently misreads later.

use image::{GrayImage, Luma};
use serde_json::{Value, json};
use servo_loop::{
    CorrectionSample, GripperModel, Recogniser, RecognitionConfig, TipCorrection, TipModel,
};

use crate::common::two_bar_scene;
use two_bar_scene::{opening_views, scene};

/// Loads `v` as `T`, expecting the crate's parameter error (not a JSON syntax error).
fn refused<T: serde::de::DeserializeOwned>(v: Value, what: &str) -> String {
    match serde_json::from_value::<T>(v) {
        Ok(_) => panic!("{what}: a bad file loaded"),
        Err(e) => {
            let e = e.to_string();
            assert!(e.contains("invalid parameter"), "{what}: {e}");
            e
        }
    }
}

/// A value with the number at `pointer` replaced.
fn with(v: &Value, pointer: &str, x: Value) -> Value {
    let mut v = v.clone();
    *v.pointer_mut(pointer)
        .unwrap_or_else(|| panic!("no {pointer}")) = x;
    v
}

/// One camera's learned correction: the end face 2 px left of the far end at 100 poses.
fn correction() -> TipCorrection {
    let samples: Vec<CorrectionSample> = (0..100)
        .map(|k| {
            let f = [4.0 + 0.1 * (k % 10) as f64, 5.0 + 0.1 * (k / 10) as f64];
            CorrectionSample {
                far_ends: vec![f],
                end_faces: vec![Some([f[0] - 2.0, f[1]])],
            }
        })
        .collect();
    TipCorrection::learn(&samples, &[10.0]).unwrap().0
}

/// A one-camera tip model of a 16 × 12 image, as `TipModel` saves it (every field).
fn tip_model_json() -> Value {
    json!({
        "config": {
            "noise_multiple": 5.0, "min_threshold": 8.0, "min_pixels": 4, "min_certainty": 0.3,
            "tip": "learned", "correction_poses": 100, "cross_camera_choice": false,
            "face_gate": 0.0, "spread_scale": 0.0, "cap_training": true
        },
        "cameras": [{
            "width": 16, "height": 12,
            "background": vec![40.0f32; 16 * 12], "half_background": vec![40.0f32; 8 * 6],
            "noise_sigma": 1.5, "root": [0.5, 6.0], "end_length": 8.0, "end_area": 12.0
        }],
        "correction": serde_json::to_value(correction()).unwrap(),
        "consistency": []
    })
}

#[test]
fn a_saved_tip_model_round_trips() {
    let v = tip_model_json();
    let m: TipModel = serde_json::from_value(v.clone()).unwrap();
    assert_eq!(serde_json::to_value(&m).unwrap(), v);
    let text = serde_json::to_string(&m).unwrap();
    let back: TipModel = serde_json::from_str(&text).unwrap();
    assert_eq!(back, m);
    assert_eq!(serde_json::to_string(&back).unwrap(), text);
    // Usable: a blank image of the learned size shows no arm (an error, no panic).
    let img = GrayImage::from_pixel(16, 12, Luma([40]));
    assert!(back.locate_all(std::slice::from_ref(&img)).is_err());
    assert_eq!(Recogniser::image_size(&back, 0), [16, 12]);
}

/// A scene shorter than its image used to load and panic (index out of bounds) on the first
/// image; settings `TipModel::learn` refuses used to load as they were.
#[test]
fn a_tip_model_learning_could_not_have_written_is_an_error() {
    let v = tip_model_json();
    let cam = "/cameras/0";
    for (what, bad) in [
        (
            "short background",
            with(&v, &format!("{cam}/background"), json!(vec![40.0; 10])),
        ),
        (
            "short half",
            with(&v, &format!("{cam}/half_background"), json!(vec![40.0; 3])),
        ),
        (
            "wider than its scene",
            with(&v, &format!("{cam}/width"), json!(17)),
        ),
        ("too small", {
            let v = with(&v, &format!("{cam}/width"), json!(4));
            let v = with(&v, &format!("{cam}/background"), json!(vec![40.0; 48]));
            with(&v, &format!("{cam}/half_background"), json!(vec![40.0; 12]))
        }),
        (
            "noise",
            with(&v, &format!("{cam}/noise_sigma"), json!(-1.0)),
        ),
        (
            "end length",
            with(&v, &format!("{cam}/end_length"), json!(0.0)),
        ),
        (
            "end area",
            with(&v, &format!("{cam}/end_area"), json!(-3.0)),
        ),
        (
            "noise multiple",
            with(&v, "/config/noise_multiple", json!(-1.0)),
        ),
        (
            "min certainty",
            with(&v, "/config/min_certainty", json!(5.0)),
        ),
        ("face gate", with(&v, "/config/face_gate", json!(-1.0))),
        ("no camera", with(&v, "/cameras", json!([]))),
        (
            "correction bandwidth",
            with(&v, "/correction/bandwidth", json!(-4.0)),
        ),
    ] {
        refused::<TipModel>(bad, what);
    }
    // The scene's and the correction's checks apply to them alone too.
    let scene = v.pointer(cam).unwrap();
    refused::<servo_loop::recognition::CameraScene>(
        with(scene, "/background", json!(vec![40.0; 10])),
        "scene",
    );
}

#[test]
fn a_saved_correction_round_trips_and_an_inconsistent_one_is_an_error() {
    let c = correction();
    let text = serde_json::to_string(&c).unwrap();
    let back: TipCorrection = serde_json::from_str(&text).unwrap();
    assert_eq!(back, c);
    assert_eq!(serde_json::to_string(&back).unwrap(), text);
    assert_eq!(
        back.tips(&[[4.5, 5.5]], &[None]).unwrap(),
        c.tips(&[[4.5, 5.5]], &[None]).unwrap()
    );
    let v: Value = serde_json::from_str(&text).unwrap();
    let n = v["offsets"].as_array().unwrap().len();
    for (what, bad) in [
        ("bandwidth", with(&v, "/bandwidth", json!(0.0))),
        ("cameras", with(&v, "/cameras", json!(0))),
        ("cameras", with(&v, "/cameras", json!(3))),
        ("offsets", with(&v, "/offsets", json!(vec![0.0; n - 1]))),
        (
            "empty",
            with(&with(&v, "/offsets", json!([])), "/descriptors", json!([])),
        ),
    ] {
        refused::<TipCorrection>(bad, what);
    }
}

fn gripper_model() -> GripperModel {
    let views = opening_views();
    let cfg = RecognitionConfig {
        prototypes: 2,
        ..RecognitionConfig::default()
    };
    GripperModel::learn(&cfg, &views).unwrap().0
}

/// A saved gripper model reads back unchanged and locates as before; one with settings
/// `GripperModel::learn` refuses or prototypes of another length is an error. (Truncated
/// prototypes used to load and score against the first values of every descriptor only.)
#[test]
fn a_saved_gripper_model_round_trips_and_a_bad_one_is_an_error() {
    let m = gripper_model();
    let text = serde_json::to_string(&m).unwrap();
    let back: GripperModel = serde_json::from_str(&text).unwrap();
    assert_eq!(back, m);
    assert_eq!(serde_json::to_string(&back).unwrap(), text);
    let img = scene(320, 240, Some((140, 100, 30)), 9);
    assert_eq!(
        back.locate(0, &img, None).unwrap(),
        m.locate(0, &img, None).unwrap()
    );
    let v: Value = serde_json::from_str(&text).unwrap();
    let proto = v["prototypes"][0][0].as_array().unwrap();
    let half: Vec<Value> = proto[..proto.len() / 2].to_vec();
    for (what, bad) in [
        ("block", with(&v, "/config/block", json!(0))),
        ("orientations", with(&v, "/config/orientations", json!(2))),
        (
            "search radius",
            with(&v, "/config/search_radius", json!(-1.0)),
        ),
        (
            "truncated prototype",
            with(&v, "/prototypes/0/0", Value::Array(half)),
        ),
        ("no prototype", with(&v, "/prototypes/0", json!([]))),
        ("no camera", with(&v, "/prototypes", json!([]))),
        ("cells", with(&v, "/config/cells", json!(u64::MAX))),
    ] {
        refused::<GripperModel>(bad, what);
    }
}

/// A tip model whose learned parts do not fit its cameras (a correction learned for another
/// number of cameras; a consistency that is not one geometry per camera `k ≥ 1`) is a file
/// learning could not have written: an error when it is read. (Both used to load: the first
/// failed only when the recogniser was used, the second left cameras unchecked or ignored
/// geometries.)
#[test]
fn a_tip_model_whose_learned_parts_do_not_fit_its_cameras_is_an_error() {
    let v = tip_model_json();
    let camera = v.pointer("/cameras/0").unwrap().clone();
    let geometry = json!({ "f": [0.0, 0.0, 0.0, 0.0, 0.0, -1.0, 0.0, 1.0, 0.0], "sigma": 0.5 });
    let cameras = |n: usize| json!(vec![camera.clone(); n]);
    // The learned one-camera correction in a two-camera model.
    refused::<TipModel>(
        with(&v, "/cameras", cameras(2)),
        "a correction of another camera count",
    );
    // A geometry in a one-camera model; one geometry in a three-camera model.
    refused::<TipModel>(
        with(&v, "/consistency", json!([geometry.clone()])),
        "a geometry without a second camera",
    );
    let three = with(
        &with(&v, "/cameras", cameras(3)),
        "/correction",
        Value::Null,
    );
    refused::<TipModel>(
        with(&three, "/consistency", json!([geometry.clone()])),
        "one geometry for three cameras",
    );
    // What learning writes loads: no geometry, or one per camera k ≥ 1.
    for consistency in [json!([]), json!([geometry.clone(), geometry])] {
        let m: TipModel = serde_json::from_value(with(&three, "/consistency", consistency))
            .expect("a file learning could have written");
        assert_eq!(m.num_cameras(), 3);
    }
}
