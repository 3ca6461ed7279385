//! Independent oracles for computations whose other tests use loose tolerances or ordinary
//! inputs only:
//! - the motion check's local linear prediction recovers an affine percept map exactly (one
//!   to three controlled joints, one to three cameras), its leave-one-out threshold is then
//!   zero, a percept off by a known amount in one camera has exactly that residual, and a
//!   command with exactly `neighbours` remembered commands within `reach` (the boundary
//!   included) is judged while one fewer is not;
//! - the change region and mask between two small float images (3 × 3 up to odd sizes, with a
//!   lighting gain) against a naive re-implementation of the documented rule: gain
//!   compensation, 3 × 3 box, robust threshold `max(6 · 1.4826 · median, 8)`, largest
//!   8-connected component, difference-weighted centroid;
//! - the learned tip correction against the Nadaraya–Watson estimate written out (kept
//!   samples, leave-one-out error at the chosen bandwidth, offsets, spreads, the clipped or
//!   gated move towards the end face), one to three cameras, from exactly the fewest samples
//!   learning accepts;
//! - the random training commands are uniform in their box: every draw inside its range (a
//!   one-point range, negative and huge ranges included), with the uniform's mean and variance,
//!   and the same seed gives the same commands.
//!
//! Random cases come from a fixed seed.

use rand::rngs::Xoshiro256PlusPlus;
use rand::{RngExt, SeedableRng};
use servo_loop::recognition::change::{
    MIN_THRESHOLD, NOISE_MULTIPLE, changed_mask, changed_region,
};
use servo_loop::recognition::image::FloatImage;
use servo_loop::{
    CorrectionSample, MotionCheck, MotionConfig, RandomCommands, ServoError, TipCorrection, Verdict,
};

/// The random cases' generator: rand's Xoshiro256++ from a fixed seed.
struct Rng(Xoshiro256PlusPlus);

impl Rng {
    fn seeded(seed: u64) -> Self {
        Rng(Xoshiro256PlusPlus::seed_from_u64(seed))
    }

    /// Uniform in `[lo, hi)` (`lo` when they are equal).
    fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.0.random::<f64>()
    }

    /// Uniform in `0..n`.
    fn below(&mut self, n: u64) -> u64 {
        self.0.random_range(0..n)
    }
}

/// An affine percept map `x = A y + b` with `cameras` cameras and `joints` joints.
struct Affine {
    a: Vec<Vec<f64>>,
    b: Vec<f64>,
}

impl Affine {
    fn random(rng: &mut Rng, cameras: usize, joints: usize) -> Affine {
        let n = 2 * cameras;
        Affine {
            a: (0..n)
                .map(|_| (0..joints).map(|_| rng.uniform(-0.8, 0.8)).collect())
                .collect(),
            b: (0..n).map(|_| rng.uniform(50.0, 600.0)).collect(),
        }
    }

    fn at(&self, y: &[f64]) -> Vec<f64> {
        self.a
            .iter()
            .zip(&self.b)
            .map(|(row, b)| b + row.iter().zip(y).map(|(a, y)| a * y).sum::<f64>())
            .collect()
    }
}

/// Commands on a jittered grid: `per_axis` values per joint around 1500 µs.
fn commands(rng: &mut Rng, joints: usize, per_axis: usize) -> Vec<Vec<f64>> {
    let total = per_axis.pow(joints as u32);
    (0..total)
        .map(|mut k| {
            (0..joints)
                .map(|_| {
                    let i = k % per_axis;
                    k /= per_axis;
                    1300.0 + 40.0 * i as f64 + rng.uniform(-8.0, 8.0)
                })
                .collect()
        })
        .collect()
}

#[test]
fn the_motion_check_recovers_an_affine_percept_map_exactly() {
    let mut rng = Rng::seeded(0x0AC1_E501);
    for (joints, cameras, per_axis) in [(1, 1, 24), (1, 3, 20), (2, 2, 7), (3, 1, 4), (3, 3, 4)] {
        let map = Affine::random(&mut rng, cameras, joints);
        let samples: Vec<(Vec<f64>, Vec<f64>)> = commands(&mut rng, joints, per_axis)
            .into_iter()
            .map(|y| (map.at(&y), y))
            .collect();
        let config = MotionConfig {
            neighbours: joints + 4,
            reach: 400.0,
            ..MotionConfig::default()
        };
        let check = MotionCheck::learn(&samples, &config).unwrap();
        assert_eq!(
            (check.percept_dim(), check.command_dim()),
            (2 * cameras, joints)
        );
        // Every training percept is predicted exactly from the others: the threshold is 0.
        assert!(
            check.threshold() < 1e-7,
            "{joints} joints, {cameras} cameras: threshold {}",
            check.threshold()
        );
        for _ in 0..10 {
            let y: Vec<f64> = (0..joints)
                .map(|_| rng.uniform(1320.0, 1300.0 + 40.0 * (per_axis - 1) as f64))
                .collect();
            let want = map.at(&y);
            let got = check.predict(&y).unwrap().expect("inside the memory");
            for (g, w) in got.iter().zip(&want) {
                assert!(
                    (g - w).abs() < 1e-7,
                    "{joints} joints, {cameras} cameras at {y:?}: {got:?} vs {want:?}"
                );
            }
            // One camera off by a known (3, 4): the residual is the largest camera distance, 5.
            let cam = rng.below(cameras as u64) as usize;
            let mut x = want.clone();
            x[2 * cam] += 3.0;
            x[2 * cam + 1] -= 4.0;
            match check.judge(&x, &y).unwrap() {
                Verdict::Inconsistent { residual, .. } => {
                    assert!((residual - 5.0).abs() < 1e-7, "residual {residual}")
                }
                v => panic!("{joints} joints, {cameras} cameras: {v:?}"),
            }
        }
    }
}

/// `None` when fewer than `neighbours` remembered commands lie within `reach` (the distance
/// `reach` itself counts as within).
#[test]
fn the_motion_check_judges_with_exactly_neighbours_within_reach() {
    let map = Affine {
        a: vec![vec![0.5], vec![-0.25]],
        b: vec![100.0, 200.0],
    };
    // Commands 0, 10, …, 200 (exact in binary).
    let samples: Vec<(Vec<f64>, Vec<f64>)> = (0..21)
        .map(|k| {
            let y = vec![10.0 * k as f64];
            (map.at(&y), y)
        })
        .collect();
    let config = MotionConfig {
        neighbours: 4,
        reach: 20.0,
        ..MotionConfig::default()
    };
    let check = MotionCheck::learn(&samples, &config).unwrap();
    // At 5: 0, 10, 20 within 20 (three): not judged. At 10: 0, 10, 20, 30 (four, 30 at
    // exactly the reach): judged. At 0: 0, 10, 20 (three): not judged. At 210: 190, 200 (two).
    for (y, judged) in [(5.0, false), (10.0, true), (0.0, false), (210.0, false)] {
        let p = check.predict(&[y]).unwrap();
        assert_eq!(p.is_some(), judged, "at {y}: {p:?}");
        if let Some(p) = p {
            let want = map.at(&[y]);
            assert!((p[0] - want[0]).abs() < 1e-9 && (p[1] - want[1]).abs() < 1e-9);
        }
        let v = check.judge(&map.at(&[y]), &[y]).unwrap();
        assert_eq!(v == Verdict::NotJudged, !judged, "at {y}: {v:?}");
    }
}

/// The documented change rule, written out naively in f64.
struct NaiveChange {
    smooth: Vec<f64>,
    threshold: f64,
}

fn naive_change(a: &FloatImage, b: &FloatImage) -> NaiveChange {
    let (w, h) = (a.width, a.height);
    let sa: f64 = a.data.iter().map(|&v| f64::from(v)).sum();
    let sb: f64 = b.data.iter().map(|&v| f64::from(v)).sum();
    let gain = if sa > 0.0 { sb / sa } else { 1.0 };
    let diff = |x: usize, y: usize| {
        (f64::from(b.data[y * w + x]) - gain * f64::from(a.data[y * w + x])).abs()
    };
    let mut smooth = vec![0.0; w * h];
    for y in 1..h - 1 {
        for x in 1..w - 1 {
            let mut s = 0.0;
            for yy in y - 1..=y + 1 {
                for xx in x - 1..=x + 1 {
                    s += diff(xx, yy);
                }
            }
            smooth[y * w + x] = s / 9.0;
        }
    }
    // The median of all smoothed values (the border's zeros included), upper middle.
    let mut sorted = smooth.clone();
    sorted.sort_by(f64::total_cmp);
    let median = sorted[sorted.len() / 2];
    let threshold = (f64::from(NOISE_MULTIPLE) * 1.4826 * median).max(f64::from(MIN_THRESHOLD));
    NaiveChange { smooth, threshold }
}

/// The 8-connected components of `mask` as lists of pixel indices, in the raster order of
/// their first pixel (by repeated label propagation, not a flood fill).
fn components(mask: &[bool], w: usize, h: usize) -> Vec<Vec<usize>> {
    let mut label: Vec<usize> = (0..w * h).collect();
    loop {
        let mut changed = false;
        for p in 0..w * h {
            if !mask[p] {
                continue;
            }
            let (x, y) = ((p % w) as i64, (p / w) as i64);
            for dy in -1..=1 {
                for dx in -1..=1 {
                    let (nx, ny) = (x + dx, y + dy);
                    if nx < 0 || ny < 0 || nx >= w as i64 || ny >= h as i64 {
                        continue;
                    }
                    let q = ny as usize * w + nx as usize;
                    if mask[q] && label[q] < label[p] {
                        label[p] = label[q];
                        changed = true;
                    }
                }
            }
        }
        if !changed {
            break;
        }
    }
    let mut roots: Vec<usize> = (0..w * h).filter(|&p| mask[p] && label[p] == p).collect();
    roots.sort_unstable();
    roots
        .iter()
        .map(|&r| (0..w * h).filter(|&p| mask[p] && label[p] == r).collect())
        .collect()
}

fn float_image(w: usize, h: usize, data: Vec<f32>) -> FloatImage {
    FloatImage {
        width: w,
        height: h,
        data,
    }
}

#[test]
fn the_change_region_follows_the_documented_rule_on_small_images() {
    let mut rng = Rng::seeded(0x0AC1_E502);
    let (mut compared, mut with_region) = (0, 0);
    for case in 0..300 {
        let (w, h) = (3 + rng.below(10) as usize, 3 + rng.below(9) as usize);
        // Integer grey levels (the half-resolution images hold quarters), a global gain on the
        // second image, a little noise and a few changed blobs.
        let a: Vec<f32> = (0..w * h)
            .map(|_| (20 + rng.below(200)) as f32 * 0.25 * 4.0)
            .collect();
        let gain = [1.0, 1.0, 0.9, 1.15][rng.below(4) as usize];
        let mut b: Vec<f32> = a
            .iter()
            .map(|&v| (gain * f64::from(v) + rng.uniform(-2.0, 2.0)).max(0.0) as f32)
            .collect();
        for _ in 0..rng.below(4) {
            let (bx, by) = (rng.below(w as u64) as usize, rng.below(h as u64) as usize);
            let (bw, bh) = (1 + rng.below(4) as usize, 1 + rng.below(3) as usize);
            let delta = [-120.0f32, 90.0, 150.0][rng.below(3) as usize];
            for y in by..(by + bh).min(h) {
                for x in bx..(bx + bw).min(w) {
                    b[y * w + x] = (b[y * w + x] + delta).max(0.0);
                }
            }
        }
        let (fa, fb) = (float_image(w, h, a), float_image(w, h, b));
        let naive = naive_change(&fa, &fb);
        // Skip the rare case of a smoothed value within rounding of the threshold (the method
        // works in f32).
        if naive
            .smooth
            .iter()
            .any(|&s| (s - naive.threshold).abs() < 1e-3 * naive.threshold.max(1.0))
        {
            continue;
        }
        let want_mask: Vec<bool> = naive.smooth.iter().map(|&s| s > naive.threshold).collect();
        let got_mask = changed_mask(&fa, &fb).expect("at least 3 × 3");
        assert_eq!(got_mask, want_mask, "case {case} ({w} × {h})");
        // Largest component; among equally large ones the first in raster order.
        let comps = components(&want_mask, w, h);
        let best = comps
            .iter()
            .fold(None::<&Vec<usize>>, |best, c| match best {
                Some(b) if b.len() >= c.len() => Some(b),
                _ => Some(c),
            });
        for min_pixels in [1, 3] {
            let got = changed_region(&fa, &fb, min_pixels);
            match best.filter(|c| c.len() >= min_pixels) {
                None => assert!(got.is_none(), "case {case}: {got:?}"),
                Some(c) => {
                    let got = got.unwrap_or_else(|| panic!("case {case}: no region, want {c:?}"));
                    assert_eq!(got.pixels, c.len(), "case {case}");
                    assert!(
                        (f64::from(got.threshold) - naive.threshold).abs() < 1e-4 * naive.threshold,
                        "case {case}: threshold {} vs {}",
                        got.threshold,
                        naive.threshold
                    );
                    let (mut sw, mut sx, mut sy) = (0.0, 0.0, 0.0);
                    for &p in c {
                        let wt = naive.smooth[p] - naive.threshold;
                        sw += wt;
                        sx += wt * (p % w) as f64;
                        sy += wt * (p / w) as f64;
                    }
                    // Half-resolution pixel i is centred at full-resolution 2i + 0.5.
                    let want = [2.0 * sx / sw + 0.5, 2.0 * sy / sw + 0.5];
                    for k in 0..2 {
                        assert!(
                            (got.centroid[k] - want[k]).abs() < 1e-3,
                            "case {case}: centroid {:?} vs {want:?}",
                            got.centroid
                        );
                    }
                    with_region += 1;
                }
            }
        }
        compared += 1;
    }
    assert!(
        compared > 250 && with_region > 150,
        "{compared} compared, {with_region} with a region"
    );
}

/// Two changed blocks that touch only at a corner are one 8-connected region, larger than a
/// third block alone: the region is both blocks, centred between them (random images rarely
/// make such a corner contact, the 3 × 3 box rounds the changed areas).
#[test]
fn changed_blocks_touching_at_a_corner_are_one_region() {
    let (w, h) = (20, 20);
    let a = float_image(w, h, vec![250.0; w * h]);
    let mut b = a.clone();
    // Single-pixel changes: each smooths into a 3 × 3 block of about 10 grey levels, above the
    // threshold of 8; the blocks of (4, 4) and (7, 7) share only the corner (5, 5)–(6, 6).
    for (x, y) in [(4, 4), (7, 7), (15, 4)] {
        b.data[y * w + x] += 90.0;
    }
    let naive = naive_change(&a, &b);
    assert_eq!(naive.threshold, f64::from(MIN_THRESHOLD));
    let mask = changed_mask(&a, &b).unwrap();
    assert_eq!(mask.iter().filter(|&&m| m).count(), 27);
    let comps = components(&mask, w, h);
    assert_eq!(comps.iter().map(Vec::len).collect::<Vec<_>>(), [18, 9]);
    let r = changed_region(&a, &b, 10).expect("the joined blocks");
    assert_eq!(r.pixels, 18);
    // Half-resolution (5.5, 5.5), full resolution 2 · 5.5 + 0.5.
    for c in r.centroid {
        assert!((c - 11.5).abs() < 1e-4, "{:?}", r.centroid);
    }
}

/// Nadaraya–Watson at `z` over `(descriptor, offset)` samples with bandwidth `h`, leaving out
/// sample `skip`: the offsets and, per camera, the weighted RMS distance from them.
fn naive_nw(
    kept: &[(Vec<f64>, Vec<f64>)],
    z: &[f64],
    h: f64,
    skip: Option<usize>,
) -> (Vec<f64>, Vec<f64>) {
    let dim = z.len();
    let w: Vec<f64> = kept
        .iter()
        .enumerate()
        .map(|(i, (zi, _))| {
            if Some(i) == skip {
                0.0
            } else {
                let d2: f64 = zi.iter().zip(z).map(|(a, b)| (a - b) * (a - b)).sum();
                (-d2 / (2.0 * h * h)).exp()
            }
        })
        .collect();
    let total: f64 = w.iter().sum();
    let mean: Vec<f64> = (0..dim)
        .map(|k| kept.iter().zip(&w).map(|((_, o), w)| w * o[k]).sum::<f64>() / total)
        .collect();
    let spread: Vec<f64> = (0..dim / 2)
        .map(|c| {
            let ss: f64 = kept
                .iter()
                .zip(&w)
                .map(|((_, o), w)| {
                    w * ((o[2 * c] - mean[2 * c]).powi(2)
                        + (o[2 * c + 1] - mean[2 * c + 1]).powi(2))
                })
                .sum();
            (ss / total).sqrt()
        })
        .collect();
    (mean, spread)
}

#[test]
fn the_tip_correction_is_the_nadaraya_watson_estimate_written_out() {
    let mut rng = Rng::seeded(0x0AC1_E504);
    let mut learned = 0;
    for case in 0..24 {
        let cameras = 1 + case % 3;
        // The first cases keep exactly the fewest samples learning accepts (20).
        let poses = if case < 3 {
            20
        } else {
            20 + rng.below(30) as usize
        };
        // Windows above every offset drawn (at most 2√2 px).
        let windows: Vec<f64> = (0..cameras).map(|_| rng.uniform(3.0, 6.0)).collect();
        let mut samples = Vec::new();
        let mut kept: Vec<(Vec<f64>, Vec<f64>)> = Vec::new();
        for _ in 0..poses {
            let far_ends: Vec<[f64; 2]> = (0..cameras)
                .map(|_| [rng.uniform(100.0, 140.0), rng.uniform(60.0, 90.0)])
                .collect();
            let offsets: Vec<[f64; 2]> = (0..cameras)
                .map(|_| [rng.uniform(-2.0, 2.0), rng.uniform(-2.0, 2.0)])
                .collect();
            let mut end_faces: Vec<Option<[f64; 2]>> = far_ends
                .iter()
                .zip(&offsets)
                .map(|(f, o)| Some([f[0] + o[0], f[1] + o[1]]))
                .collect();
            let mut keep = true;
            if case >= 3 {
                match rng.below(6) {
                    // No end face in one camera, or one beyond its end window.
                    0 => {
                        end_faces[rng.below(cameras as u64) as usize] = None;
                        keep = false;
                    }
                    1 => {
                        let c = rng.below(cameras as u64) as usize;
                        end_faces[c] = Some([far_ends[c][0] + windows[c] + 0.5, far_ends[c][1]]);
                        keep = false;
                    }
                    _ => {}
                }
            }
            if keep {
                kept.push((
                    far_ends.iter().flatten().copied().collect(),
                    offsets.iter().flatten().copied().collect(),
                ));
            }
            samples.push(CorrectionSample {
                far_ends,
                end_faces,
            });
        }
        if kept.len() < 20 {
            assert!(matches!(
                TipCorrection::learn(&samples, &windows),
                Err(ServoError::NotEnoughData(_))
            ));
            continue;
        }
        let (model, report) = TipCorrection::learn(&samples, &windows).unwrap();
        learned += 1;
        assert_eq!(
            (report.poses, report.samples),
            (poses, kept.len()),
            "case {case}"
        );
        let h = model.bandwidth();
        assert_eq!(report.bandwidth, h);
        // The leave-one-out error at the chosen bandwidth, per offset component.
        let dim = 2 * cameras;
        let sq: f64 = (0..kept.len())
            .map(|i| {
                let (o, _) = naive_nw(&kept, &kept[i].0, h, Some(i));
                o.iter()
                    .zip(&kept[i].1)
                    .map(|(a, b)| (a - b) * (a - b))
                    .sum::<f64>()
            })
            .sum();
        let loo_rms = (2.0 * sq / (kept.len() * dim) as f64).sqrt();
        assert!(
            (report.loo_rms_px - loo_rms).abs() < 1e-9,
            "case {case}: {} vs {loo_rms}",
            report.loo_rms_px
        );
        // Tips at new poses, with and without end faces, plain and gated.
        for _ in 0..6 {
            let far: Vec<[f64; 2]> = (0..cameras)
                .map(|_| [rng.uniform(100.0, 140.0), rng.uniform(60.0, 90.0)])
                .collect();
            let faces: Vec<Option<[f64; 2]>> = far
                .iter()
                .map(|f| match rng.below(4) {
                    0 => None,
                    1 => Some([f64::NAN, f[1]]),
                    // Near (passes through) or a few pixels off (clipped).
                    2 => Some([f[0] + rng.uniform(-0.3, 0.3), f[1] + rng.uniform(-0.3, 0.3)]),
                    _ => Some([f[0] + rng.uniform(-4.0, 4.0), f[1] + rng.uniform(-4.0, 4.0)]),
                })
                .collect();
            let z: Vec<f64> = far.iter().flatten().copied().collect();
            let (o, spread) = naive_nw(&kept, &z, h, None);
            for gate in [0.0, 1.5] {
                let got = model.tips_gated(&far, &faces, gate).unwrap();
                let plain = model.tips(&far, &faces).unwrap();
                for c in 0..cameras {
                    let p = [far[c][0] + o[2 * c], far[c][1] + o[2 * c + 1]];
                    let want = match faces[c].filter(|e| e[0].is_finite() && e[1].is_finite()) {
                        None => p,
                        Some(e) => {
                            let clip = 0.5f64.max(gate * spread[c]);
                            let (rx, ry) = (e[0] - p[0], e[1] - p[1]);
                            let r = rx.hypot(ry);
                            let g = if r > clip { clip / r } else { 1.0 };
                            [p[0] + g * rx, p[1] + g * ry]
                        }
                    };
                    for k in 0..2 {
                        assert!(
                            (got[c].position[k] - want[k]).abs() < 1e-9,
                            "case {case}, camera {c}, gate {gate}: {:?} vs {want:?}",
                            got[c].position
                        );
                    }
                    assert!((got[c].spread - spread[c]).abs() < 1e-9, "case {case}");
                    if gate == 0.0 {
                        assert_eq!(plain[c], got[c].position);
                    }
                }
            }
        }
    }
    assert!(learned >= 12, "{learned} of 24 cases learned");
}

#[test]
fn random_commands_are_uniform_in_their_ranges() {
    let explore = [
        [1000.0, 2000.0],
        [-3.0, -1.0],
        [1500.0, 1500.0],
        [-8e307, 8e307],
        [0.0, 1e-300],
    ];
    let n = 4000;
    let mut commands = RandomCommands::new(&explore, 17).unwrap();
    let draws: Vec<Vec<f64>> = (0..n).map(|_| commands.next_command()).collect();
    let mut again = RandomCommands::new(&explore, 17).unwrap();
    assert_eq!(
        (0..n).map(|_| again.next_command()).collect::<Vec<_>>(),
        draws
    );
    for (j, &[lo, hi]) in explore.iter().enumerate() {
        let xs: Vec<f64> = draws.iter().map(|y| y[j]).collect();
        assert!(
            xs.iter().all(|&x| x.is_finite() && lo <= x && x <= hi),
            "joint {j}: outside [{lo}, {hi}]"
        );
        if lo == hi {
            continue;
        }
        // In units of the range: mean 1/2 and variance 1/12, within about five standard errors.
        let u: Vec<f64> = xs
            .iter()
            .map(|&x| (x / 2.0 - lo / 2.0) / (hi / 2.0 - lo / 2.0))
            .collect();
        let mean = u.iter().sum::<f64>() / n as f64;
        let var = u.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / n as f64;
        assert!(
            (mean - 0.5).abs() < 5.0 * (1.0 / 12.0 / n as f64).sqrt(),
            "joint {j}: mean {mean}"
        );
        assert!(
            (var - 1.0 / 12.0).abs() < 0.006,
            "joint {j}: variance {var}"
        );
    }
}
