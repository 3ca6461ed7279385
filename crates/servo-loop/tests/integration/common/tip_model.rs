//! A saved silhouette tip model of small cameras, for tests that need a learned recogniser
//! without learning one.

use serde_json::{Value, json};
use servo_loop::TipModel;

/// A learned consistency of a rectified camera pair: `F` relates points of one image row
/// (`bᵀ F a = a_v − b_v`, Sampson distance `|a_v − b_v| / √2`), residual scale 0.5 px.
pub fn rectified() -> Value {
    json!({ "f": [0.0, 0.0, 0.0, 0.0, 0.0, -1.0, 0.0, 1.0, 0.0], "sigma": 0.5 })
}

/// A tip model of `cams` 16 × 12 cameras (far-end rule) with the given learned consistency,
/// as saved.
pub fn tip_model(cams: usize, consistency: Vec<Value>) -> TipModel {
    let camera = json!({
        "width": 16, "height": 12,
        "background": vec![40.0f32; 16 * 12], "half_background": vec![40.0f32; 8 * 6],
        "noise_sigma": 1.5, "root": [0.5, 6.0], "end_length": 8.0, "end_area": 12.0
    });
    serde_json::from_value(json!({
        "config": {
            "noise_multiple": 5.0, "min_threshold": 8.0, "min_pixels": 4, "min_certainty": 0.3,
            "tip": "far_end", "correction_poses": 100, "cross_camera_choice": false,
            "face_gate": 0.0, "spread_scale": 0.0, "cap_training": true
        },
        "cameras": vec![camera; cams],
        "consistency": consistency
    }))
    .unwrap()
}
