//! Recognition building blocks on synthetic images: the feature map is shift-equivariant by
//! whole spatial channels, the change region of a moved bright square is its new-and-old
//! area, and localisation finds a learned pattern at a shifted place.

use image::{GrayImage, Luma};
use proptest::prelude::*;
use servo_loop::recognition::TrainingView;
use servo_loop::recognition::change::{changed_mask, changed_region};
use servo_loop::recognition::features::{FeatureMap, FeatureParams};
use servo_loop::recognition::image::{full_to_half, half_resolution, half_to_full};
use servo_loop::{GripperModel, RecognitionConfig, ServoError};

use crate::common::two_bar_scene;
use two_bar_scene::{opening_views, scene};

#[test]
fn coordinates_round_trip() {
    for f in [0.0, 0.5, 17.25, 639.0] {
        assert!((half_to_full(full_to_half(f)) - f).abs() < 1e-12);
    }
}

proptest! {
    #![proptest_config(crate::seeded(12))]
    /// Shifting the image by a whole spatial channel (2·block full pixels) shifts the map by
    /// one channel, away from the borders.
    #[test]
    fn feature_map_is_shift_equivariant(sx in 40u32..80, sy in 40u32..60, k in 1u32..3) {
        let p = FeatureParams { block: 3, orientations: 8, magnitude_half: 40.0, intensities: 0 };
        let shift = 6 * k;
        let a = scene(240, 200, Some((sx, sy, 30)), 0);
        // The same scene content moved right by `shift` (texture included).
        let b = GrayImage::from_fn(240, 200, |x, y| if x >= shift { *a.get_pixel(x - shift, y) } else { Luma([90]) });
        let ma = FeatureMap::compute(&half_resolution(&a), &p).unwrap();
        let mb = FeatureMap::compute(&half_resolution(&b), &p).unwrap();
        let (mut da, mut db) = (Vec::new(), Vec::new());
        let (tx, ty) = (ma.to_channel(f64::from(sx + 15)), ma.to_channel(f64::from(sy + 15)));
        ma.descriptor(tx.round(), ty.round(), 6, &mut da);
        mb.descriptor(tx.round() + f64::from(k), ty.round(), 6, &mut db);
        // Background normalisation divides by image-wide means, which the shift changes
        // slightly (the filled strip): compare after normalising.
        let na: f32 = da.iter().map(|v| v * v).sum::<f32>().sqrt();
        let nb: f32 = db.iter().map(|v| v * v).sum::<f32>().sqrt();
        let cos: f32 = da.iter().zip(&db).map(|(x, y)| x * y).sum::<f32>() / (na * nb);
        prop_assert!(cos > 0.995, "cosine {}", cos);
    }
}

#[test]
fn change_region_is_where_the_object_moved() {
    let a = scene(320, 240, Some((100, 80, 30)), 1);
    let b = scene(320, 240, Some((110, 80, 30)), 1);
    let r = changed_region(&half_resolution(&a), &half_resolution(&b), 5).expect("a change");
    // The union of old and new position spans x ∈ [100, 140), y ∈ [80, 110).
    assert!(
        r.centroid[0] > 100.0 && r.centroid[0] < 140.0,
        "{:?}",
        r.centroid
    );
    assert!((r.centroid[1] - 95.0).abs() < 6.0, "{:?}", r.centroid);
    // Identical images, or a global brightness change only: nothing.
    assert!(changed_region(&half_resolution(&a), &half_resolution(&a), 5).is_none());
    let brighter = GrayImage::from_fn(320, 240, |x, y| {
        Luma([(f32::from(a.get_pixel(x, y)[0]) * 1.05) as u8])
    });
    assert!(changed_region(&half_resolution(&a), &half_resolution(&brighter), 5).is_none());
}

#[test]
fn localisation_finds_a_learned_object_elsewhere() {
    let views = opening_views();
    let cfg = RecognitionConfig {
        prototypes: 2,
        ..RecognitionConfig::default()
    };
    let (model, report) = GripperModel::learn(&cfg, &views).unwrap();
    assert_eq!(report.used, vec![4]);
    let img = scene(320, 240, Some((140, 100, 30)), 9);
    let loc = model.locate(0, &img, None).unwrap();
    // The object's centre is at (155, 115). Measured: (141.6, 120.9), i.e. within about two
    // spatial channels (12 px): the localisation is coarse, as the eval's recognition table
    // shows for the arm too.
    assert!(
        (loc.position[0] - 155.0).abs() < 15.0 && (loc.position[1] - 115.0).abs() < 15.0,
        "{loc:?}"
    );
    assert!(loc.certainty > 0.6);

    // An unknown camera or a non-finite hint is a typed error on every entry point: an
    // unknown camera used to panic in `prototypes` and `locate_unchecked`, and a NaN hint to
    // be taken as none (a search of the whole image).
    assert_eq!(model.prototypes(0).map(<[_]>::len), Some(2));
    assert!(model.prototypes(1).is_none());
    let half = half_resolution(&img);
    let unknown = |r: servo_loop::Result<servo_loop::Localisation>| {
        matches!(
            r,
            Err(ServoError::DimensionMismatch {
                what: "camera index",
                expected: 1,
                got: 1
            })
        )
    };
    assert!(unknown(model.locate(1, &img, None)));
    assert!(unknown(model.locate_unchecked(1, &half, None)));
    assert!(unknown(model.locate_after_move(1, &img, &img)));
    for hint in [[f64::NAN, 115.0], [155.0, f64::INFINITY]] {
        let bad_hint = |r: servo_loop::Result<servo_loop::Localisation>| {
            matches!(r, Err(ServoError::InvalidParameter { name: "hint", .. }))
        };
        assert!(bad_hint(model.locate(0, &img, Some(hint))), "{hint:?}");
        assert!(bad_hint(model.locate_unchecked(0, &half, Some(hint))));
    }
}

#[test]
fn learning_without_views_or_changes_fails() {
    let cfg = RecognitionConfig::default();
    assert!(GripperModel::learn(&cfg, &[]).is_err());
    let still = TrainingView {
        before: vec![scene(320, 240, Some((50, 50, 30)), 0)],
        after: vec![scene(320, 240, Some((50, 50, 30)), 0)],
    };
    assert!(GripperModel::learn(&cfg, &[still]).is_err());
}

/// `half_resolution`: pixel `(i, j)` is the mean of the full-resolution 2 × 2 block at
/// `(2i, 2j)`, odd trailing rows and columns dropped; its centre is the full-resolution
/// coordinate `2i + 0.5`.
#[test]
fn half_resolution_averages_blocks_centred_at_two_i_plus_a_half() {
    let img = GrayImage::from_fn(5, 3, |x, y| Luma([(10 * y + x) as u8]));
    let half = half_resolution(&img);
    assert_eq!((half.width, half.height), (2, 1));
    // (0 + 1 + 10 + 11) / 4 and (2 + 3 + 12 + 13) / 4.
    assert_eq!(half.data, vec![5.5, 7.5]);
    assert_eq!(half.at(1, 0), 7.5);
    assert_eq!(half_to_full(0.0), 0.5);
    assert_eq!(half_to_full(3.0), 6.5);
    assert_eq!(full_to_half(6.5), 3.0);
}

/// `changed_region` and `changed_mask` give `None` for images of different sizes, and
/// `changed_mask` for images smaller than 3 × 3.
#[test]
fn changes_between_images_of_different_sizes_are_none() {
    let a = half_resolution(&scene(64, 48, Some((10, 10, 12)), 1));
    let b = half_resolution(&scene(64, 50, Some((14, 10, 12)), 1));
    let c = half_resolution(&scene(64, 48, Some((14, 10, 12)), 1));
    assert!(changed_mask(&a, &c).is_some());
    assert!(changed_region(&a, &c, 1).is_some());
    assert!(changed_mask(&a, &b).is_none());
    assert!(changed_region(&a, &b, 1).is_none());
    let tiny = half_resolution(&GrayImage::new(4, 6));
    assert!(changed_mask(&tiny, &tiny).is_none());
}

/// `EpipolarGeometry`: the Sampson distance of `F`, the consistency scale
/// `s = max(2σ, 0.5 px)`, the consistency `exp(−½ (d/s)²)`, and 0 for non-finite points.
#[test]
fn epipolar_consistency_is_a_gaussian_of_the_sampson_distance() {
    use servo_loop::EpipolarGeometry;
    // A rectified pair: `bᵀ F a = a_v − b_v`, Sampson distance `|a_v − b_v| / √2`.
    let geometry = |sigma: f64| -> EpipolarGeometry {
        serde_json::from_value(serde_json::json!({
            "f": [0.0, 0.0, 0.0, 0.0, 0.0, -1.0, 0.0, 1.0, 0.0], "sigma": sigma
        }))
        .unwrap()
    };
    let (g, narrow) = (geometry(0.75), geometry(0.1));
    assert_eq!((g.scale(), narrow.scale()), (1.5, 0.5));
    let (a, b) = ([10.0, 5.0], [40.0, 8.0]);
    let d = 3.0 / 2f64.sqrt();
    assert!((g.distance(a, b) - d).abs() < 1e-12);
    assert!((g.consistency(a, b) - (-0.5 * (d / 1.5).powi(2)).exp()).abs() < 1e-12);
    assert!((narrow.consistency(a, b) - (-0.5 * (d / 0.5).powi(2)).exp()).abs() < 1e-12);
    assert_eq!(g.consistency(a, [99.0, 5.0]), 1.0);
    for bad in [f64::NAN, f64::INFINITY] {
        assert_eq!(g.consistency([bad, 5.0], b), 0.0, "{bad}");
        assert_eq!(g.consistency(a, [40.0, bad]), 0.0, "{bad}");
    }
}
