//! Recognition and servo-step costs on a synthetic 640×480 scene and on `arm-sim`'s rendered
//! 640×480 images (no peer exists for them).

use criterion::{Criterion, criterion_group, criterion_main};
use image::{GrayImage, Luma};
use servo_loop::recognition::TrainingView;
use servo_loop::recognition::features::{FeatureMap, FeatureParams};
use servo_loop::recognition::image::half_resolution;
use servo_loop::{
    GripperModel, InverseModel, InverseModelConfig, RandomCommands, RecognitionConfig,
    SilhouetteConfig, TipModel, TipRule,
};

fn scene(x0: u32, y0: u32, s: u32) -> GrayImage {
    GrayImage::from_fn(640, 480, |x, y| {
        let bar = (x >= x0 && x < x0 + s / 3) || (x >= x0 + 2 * s / 3 && x < x0 + s);
        if bar && y >= y0 && y < y0 + s {
            Luma([220])
        } else {
            Luma([90 + (((x * 7) ^ (y * 13)) % 9) as u8])
        }
    })
}

fn bench(c: &mut Criterion) {
    let img = scene(300, 200, 30);
    let half = half_resolution(&img);
    let p = FeatureParams {
        block: 3,
        orientations: 8,
        magnitude_half: 40.0,
        intensities: 8,
    };
    c.bench_function("feature_map_640x480", |b| {
        b.iter(|| FeatureMap::compute(&half, &p).unwrap())
    });
    let views: Vec<TrainingView> = [(100u32, 100u32), (400, 150), (200, 300)]
        .iter()
        .map(|&(x, y)| TrainingView {
            before: vec![scene(x, y, 30)],
            after: vec![scene(x - 2, y, 34)],
        })
        .collect();
    let (model, _) = GripperModel::learn(&RecognitionConfig::default(), &views).unwrap();
    c.bench_function("locate_whole_image", |b| {
        b.iter(|| model.locate_unchecked(0, &half, None).unwrap())
    });
    c.bench_function("locate_with_hint", |b| {
        b.iter(|| {
            model
                .locate_unchecked(0, &half, Some([315.0, 215.0]))
                .unwrap()
        })
    });
    let mut inv = InverseModel::new(4, 3, &InverseModelConfig::default()).unwrap();
    for i in 0..2000 {
        let t = f64::from(i) * 0.01;
        let x = [
            320.0 + 100.0 * t.sin(),
            240.0 + 80.0 * (1.3 * t).cos(),
            300.0 + 90.0 * (0.7 * t).sin(),
            250.0 + 70.0 * t.cos(),
        ];
        let y = [
            1500.0 + 300.0 * t.sin(),
            1600.0 + 200.0 * (1.3 * t).cos(),
            1400.0 + 250.0 * (0.7 * t).sin(),
        ];
        inv.update(&x, &y).unwrap();
    }
    c.bench_function("inverse_jacobian_4x3", |b| {
        b.iter(|| inv.predict_with_jacobian(&[330.0, 235.0, 310.0, 255.0]))
    });
}

/// The silhouette recogniser on rendered images: learned from 20 gripper moves of the
/// default arm, then one localisation of one camera's image.
fn bench_tip(c: &mut Criterion) {
    let mut sim = arm_sim::ArmSim::new(arm_sim::SimConfig::default()).unwrap();
    let explore = [[1167.0, 1833.0], [1389.0, 1833.0], [1111.0, 1611.0]];
    let mut commands = RandomCommands::new(&explore, 1).unwrap();
    let mut views = Vec::new();
    let command = |y: &[f64], gripper: f64| [y[0], y[1], y[2], 1944.0, 1500.0, gripper];
    for _ in 0..20 {
        let y = commands.next_command();
        sim.command(&command(&y, 2100.0)).unwrap();
        let before = sim.capture();
        sim.command(&command(&y, 1000.0)).unwrap();
        let after = sim.capture();
        views.push(TrainingView { before, after });
    }
    // One image, one camera: the far-end rule (the learned rule adds the end-face outline and
    // a kernel regression over all cameras).
    let far_end = SilhouetteConfig {
        tip: TipRule::FarEnd,
        ..SilhouetteConfig::default()
    };
    let (model, _) = TipModel::learn(&far_end, &views).unwrap();
    sim.command(&command(&commands.next_command(), 1500.0))
        .unwrap();
    let img = sim.capture().swap_remove(0);
    c.bench_function("tip_locate_640x480", |b| {
        b.iter(|| model.locate(0, &img).unwrap())
    });
    // The learned rule (the servo percept): both cameras' far ends and end faces, and the
    // correction learned from 300 further poses.
    let mut learned = model.with_tip_rule(TipRule::Learned);
    let samples: Vec<_> = (0..300)
        .filter_map(|_| {
            sim.command(&command(&commands.next_command(), 1500.0))
                .unwrap();
            learned.correction_sample(&sim.capture()).ok()
        })
        .collect();
    learned.learn_correction(&samples).unwrap();
    sim.command(&command(&commands.next_command(), 1500.0))
        .unwrap();
    let both = sim.capture();
    c.bench_function("tip_locate_all_learned_2x640x480", |b| {
        b.iter(|| learned.locate_all(&both).unwrap())
    });
}

criterion_group!(benches, bench, bench_tip);
criterion_main!(benches);
