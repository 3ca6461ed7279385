//! Independent oracles for the crate's smaller computations: scores against a plain loop,
//! the training scales against their per-axis definitions (on axis-symmetric data, see
//! `scales_follow_their_definitions_on_axis_symmetric_data`), the spacing rules in closed
//! form, the grid's cell centres against chan-repr's flat index, axes against their covering
//! promise, the UNGM generator and the particle filter's UNGM motion against the written
//! recursion, and the exact recovery of a start by every layout's decoder.

use crate::common;

use cbt_tracker::metrics::score;
use cbt_tracker::sim::{Ungm, rng_for};
use cbt_tracker::{
    CbtConfig, CbtModel, CbtTracker, DEFAULT_KERNEL, Detection, Frame, Layout, Order,
    ParticleFilter, PfModel, Point, Scales, Sequence, Space, Tracker, axis,
};
use chan_repr::{ChannelBasis, Kernel};
use rand::RngExt;

/// `score` against a plain loop: frames `k ≥ 1` with a truth, the first `dims` coordinates
/// (the other one may be anything, NaN included, when `dims` is 1), a frame lost when its
/// error is strictly above the radius; radius 0 and ∞, empty and truth-less inputs.
#[test]
fn score_is_the_rmse_and_loss_share_of_the_scored_frames() {
    for seed in 0..400 {
        let mut rng = rng_for(seed, 1);
        let n = rng.random_range(0..8usize);
        let dims = 1 + (seed as usize % 2);
        let coord =
            |rng: &mut rand::rngs::Xoshiro256PlusPlus| f64::from(rng.random_range(-4..=4i32));
        let est: Vec<Point> = (0..n)
            .map(|_| {
                let x = coord(&mut rng);
                [x, if dims == 1 { f64::NAN } else { coord(&mut rng) }]
            })
            .collect();
        let truth: Vec<Option<Point>> = (0..n)
            .map(|_| {
                let p = [coord(&mut rng), coord(&mut rng)];
                (rng.random_range(0..4) != 0).then_some(p)
            })
            .collect();
        let radius = [0.0, 1.0, 3.0, 5.0, f64::INFINITY][seed as usize % 5];
        let s = score(&est, &truth, dims, radius).unwrap();
        let (mut se, mut lost, mut frames) = (0.0, 0, 0);
        for k in 1..n {
            let Some(t) = truth[k] else { continue };
            let mut d2 = (est[k][0] - t[0]).powi(2);
            if dims == 2 {
                d2 += (est[k][1] - t[1]).powi(2);
            }
            se += d2;
            lost += usize::from(d2.sqrt() > radius);
            frames += 1;
        }
        assert_eq!(s.frames, frames, "seed {seed}");
        if frames == 0 {
            assert_eq!((s.rmse, s.loss_share), (0.0, 0.0));
        } else {
            assert!(
                (s.rmse - (se / frames as f64).sqrt()).abs() < 1e-12,
                "seed {seed}"
            );
            assert_eq!(s.loss_share, lost as f64 / frames as f64, "seed {seed}");
        }
    }
    // An error of exactly the radius is not a loss (3-4-5).
    let s = score(&[[0.0; 2]; 2], &[None, Some([3.0, 4.0])], 2, 5.0).unwrap();
    assert_eq!((s.rmse, s.loss_share, s.frames), (5.0, 0.0, 1));
}

/// The upper middle of the sorted values (the crate's median of an even count).
fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// [`Scales`] by their documented definitions, both axes pooled: `accel` the RMS of the
/// truth's second differences over windows of three frames with truth; `noise` 1.4826 · the
/// upper median |residual| of the detection nearest to the truth (Euclidean), residuals of at
/// least `extent / 10` ignored (0 without any).
fn scales_reference(train: &[Sequence], extent: f64) -> Scales {
    let (mut s2, mut n) = (0.0, 0);
    let mut res = Vec::new();
    for d in 0..2 {
        for s in train {
            for k in 2..s.frames.len() {
                let t: Vec<Point> = s.frames[k - 2..=k].iter().filter_map(|f| f.truth).collect();
                if t.len() == 3 {
                    s2 += (t[2][d] - 2.0 * t[1][d] + t[0][d]).powi(2);
                    n += 1;
                }
            }
            for f in &s.frames {
                let Some(t) = f.truth else { continue };
                let mut best: Option<(f64, Point)> = None;
                for det in &f.detections {
                    let e = (det.pos[0] - t[0]).powi(2) + (det.pos[1] - t[1]).powi(2);
                    if best.is_none_or(|b| e < b.0) {
                        best = Some((e, det.pos));
                    }
                }
                if let Some((_, p)) = best
                    && (p[d] - t[d]).abs() < extent / 10.0
                {
                    res.push((p[d] - t[d]).abs());
                }
            }
        }
    }
    let accel = (s2 / n as f64).sqrt();
    let noise = if res.is_empty() {
        0.0
    } else {
        1.4826 * median(res)
    };
    Scales { accel, noise }
}

/// Random sequences and their mirror images (x and y swapped), so that both axes have the
/// same statistics: there, the pooled and the per-axis readings agree.
fn mirrored_sequences(seed: u64) -> Vec<Sequence> {
    let one = common::lattice_sequences(seed, 2);
    let swap = |p: Point| [p[1], p[0]];
    let mirror = one.iter().map(|s| Sequence {
        frames: s
            .frames
            .iter()
            .map(|f| Frame {
                truth: f.truth.map(swap),
                detections: f
                    .detections
                    .iter()
                    .map(|d| Detection::new(d.pos[1], d.pos[0]))
                    .collect(),
            })
            .collect(),
        ..Default::default()
    });
    one.iter().cloned().chain(mirror).collect()
}

/// [`Scales::estimate`] against its definitions (both axes pooled), on random sequences with
/// and without their mirror images, and on two cases worked by hand where the axes differ;
/// [`Scales::spacing`] / [`Scales::fine_spacing`] against their closed forms.
#[test]
fn scales_follow_their_definitions() {
    // x = 1.5 k², y constant: second differences 3 in x and 0 in y, RMS √(9/2) pooled.
    let frames = (0..10)
        .map(|k| {
            let t = [1.5 * f64::from(k * k), 50.0];
            Frame {
                truth: Some(t),
                detections: vec![Detection::new(t[0], t[1])],
            }
        })
        .collect();
    let estimate = |frames: Vec<Frame>| {
        let one = Sequence {
            frames,
            ..Default::default()
        };
        Scales::estimate(&[one], 640.0).unwrap()
    };
    let got = estimate(frames);
    assert!((got.accel - 4.5f64.sqrt()).abs() < 1e-12, "{got:?}");
    // Residuals (0, 0), (4, 0), (4, 0): pooled |r| = 0, 0, 4, 0, 4, 0, upper median 0.
    let frames = [0.0, 4.0, 4.0]
        .iter()
        .map(|&r| Frame {
            truth: Some([10.0, 10.0]),
            detections: vec![Detection::new(10.0 + r, 10.0)],
        })
        .collect();
    assert_eq!(estimate(frames).noise, 0.0);
    let mut checked = 0;
    for seed in 0..600 {
        let all = mirrored_sequences(seed / 2);
        let train = if seed % 2 == 0 {
            &all[..]
        } else {
            &all[..all.len() / 2]
        };
        let extent = [20.0, 60.0, 200.0][seed as usize % 3];
        let Ok(got) = Scales::estimate(train, extent) else {
            continue;
        };
        let want = scales_reference(train, extent);
        assert!(
            (got.accel - want.accel).abs() <= 1e-12 * want.accel.max(1.0),
            "seed {seed}: accel {} vs {}",
            got.accel,
            want.accel
        );
        assert_eq!(got.noise, want.noise, "seed {seed}: noise");
        for e in [1.0, extent, 640.0] {
            let clamp = |v: f64, lo: f64, hi: f64| v.max(lo).min(hi);
            let s = clamp(1.5 * got.noise.max(got.accel), e / 48.0, e / 12.0);
            assert_eq!(got.spacing(e).unwrap(), s);
            let f = clamp(0.75 * got.noise, e / 1000.0, e / 12.0);
            assert_eq!(got.fine_spacing(e).unwrap(), f);
        }
        checked += 1;
    }
    assert!(checked > 200, "{checked}");
}

/// `Space::cell_centre(g)` is the centre of the channels whose chan-repr flat index is `g`,
/// on a 1-D space and on non-square 2-D grids (both axis orders of sizes).
#[test]
fn cell_centres_follow_the_grid_index() {
    let b = |lo: f64, hi: f64, n: usize| ChannelBasis::covering(lo, hi, n, DEFAULT_KERNEL).unwrap();
    let spaces = [
        Space::new(vec![b(0.0, 10.0, 5)], vec![b(-3.0, 4.0, 7)]).unwrap(),
        Space::new(
            vec![b(0.0, 10.0, 5), b(-2.0, 5.0, 8)],
            vec![b(0.0, 1.0, 3); 2],
        )
        .unwrap(),
        Space::new(
            vec![b(-2.0, 5.0, 8), b(0.0, 10.0, 5)],
            vec![b(0.0, 1.0, 3); 2],
        )
        .unwrap(),
        Space::image(50.0, 17.0, 3.0).unwrap(),
    ];
    for space in &spaces {
        let grid = space.grid();
        let ny = if space.dims() == 2 {
            space.axis_len(1)
        } else {
            1
        };
        let mut seen = vec![false; space.cells()];
        for ix in 0..space.axis_len(0) {
            for iy in 0..ny {
                let idx: Vec<usize> = [ix, iy][..space.dims()].to_vec();
                let g = grid.flat_index(&idx).unwrap();
                let want = [
                    space.state_basis(0).centre(ix),
                    if space.dims() == 2 {
                        space.state_basis(1).centre(iy)
                    } else {
                        0.0
                    },
                ];
                assert_eq!(space.cell_centre(g), want, "cell ({ix}, {iy})");
                seen[g] = true;
            }
        }
        assert!(seen.iter().all(|&s| s));
    }
}

/// `axis(lo, hi, spacing, kernel)` covers `[lo, hi]` (both ends accepted) with channels
/// at most `spacing` apart, for ranges shorter than one spacing too, and every kernel.
#[test]
fn axes_cover_their_range_within_the_spacing() {
    let mut rng = rng_for(3, 3);
    let kernels = [
        DEFAULT_KERNEL,
        Kernel::Cos2 { m: 5 },
        Kernel::BSpline2,
        Kernel::Gaussian { sigma: 1.5 },
    ];
    let mut checked = 0;
    for i in 0..400 {
        let lo = rng.random_range(-1e3..1e3);
        let hi = lo + 10f64.powf(rng.random_range(-3.0..3.0));
        let spacing = (hi - lo) * 10f64.powf(rng.random_range(-3.0..1.0));
        let kernel = kernels[i % kernels.len()];
        let b = axis(lo, hi, spacing, kernel).unwrap();
        assert!(
            b.spacing() <= spacing * (1.0 + 1e-12),
            "{lo} {hi} {spacing}"
        );
        let (a, z) = b.representable_range();
        // Both ends, up to the rounding chan-repr's range check allows for (1e-9 spacings
        // and a few ulps of the coordinates). Channels may be far finer than the coordinates'
        // magnitude: an axis at x ≈ −664 with spacing 2e-5 used to refuse its own end.
        let slack = 1e-9 * b.spacing() + 8.0 * f64::EPSILON * lo.abs().max(hi.abs());
        assert!(
            a <= lo + slack && hi - slack <= z,
            "{lo} {hi} {spacing}: [{a}, {z}]"
        );
        assert!(
            b.checked_index(lo).is_ok() && b.checked_index(hi).is_ok(),
            "{lo:e} {hi:e} {spacing:e} {kernel:?}: {:?} {:?} first {} spacing {}",
            b.checked_index(lo),
            b.checked_index(hi),
            b.centre(0),
            b.spacing()
        );
        checked += 1;
    }
    assert_eq!(checked, 400);
}

/// UNGM by the written recursion `x_k = x_{k−1}/2 + 25 x_{k−1}/(1 + x_{k−1}²) + 8 cos(1.2 k)`,
/// `z_k = x_k²/20`: the generator without noise, and the particle filter's motion with
/// (almost) none, whose estimate after an empty frame is the propagated state.
#[test]
fn ungm_follows_the_written_recursion() {
    let f = |x: f64, k: u64| x / 2.0 + 25.0 * x / (1.0 + x * x) + 8.0 * (1.2 * k as f64).cos();
    for x0 in [0.1, -3.0, 0.0, 12.5] {
        let quiet = Ungm {
            process_var: 0.0,
            meas_var: 0.0,
            x0,
        };
        let s = quiet.generate(1, 20, 1).unwrap().remove(0);
        let mut x = x0;
        for (k, fr) in s.frames.iter().enumerate() {
            if k > 0 {
                x = f(x, k as u64);
            }
            let t = fr.truth.unwrap();
            assert!(
                (t[0] - x).abs() <= 1e-12 * x.abs().max(1.0),
                "x0 {x0} k {k}"
            );
            assert_eq!(t[1], 0.0);
            assert_eq!(fr.detections.len(), 1);
            let z = fr.detections[0].pos;
            assert!((z[0] - x * x / 20.0).abs() <= 1e-12 * (x * x).max(1.0));
            assert_eq!(z[1], 0.0);
            assert_eq!(Ungm::transition(x, k as u64 + 1), f(x, k as u64 + 1));
        }
        let model = PfModel::Ungm {
            process_var: 1e-20,
            meas_var: 1.0,
            init_sigma: 1e-12,
        };
        let mut pf = ParticleFilter::new(model, 16, 5).unwrap();
        pf.reset([x0, 0.0]).unwrap();
        let mut x = x0;
        for k in 1..15u64 {
            x = f(x, k);
            let e = pf.step(&[]).unwrap().position;
            assert!((e[0] - x).abs() < 1e-6, "x0 {x0} k {k}: {} vs {x}", e[0]);
        }
    }
}

/// A tracker reset at `p` decodes `p` (the local decoders recover an encoded value exactly):
/// separable 1-D and 2-D and sparse joint layouts, anywhere inside the grid (non-square, grid
/// points and between them); the stationary layout decodes the first moment of the start's
/// channel coefficients, computed here from chan-repr's encoding.
#[test]
fn a_start_decodes_to_itself_in_every_layout() {
    let one = ChannelBasis::covering(0.0, 30.0, 24, DEFAULT_KERNEL).unwrap();
    let cases = [
        (
            Space::new(vec![one.clone()], vec![one]).unwrap(),
            CbtConfig::default(),
        ),
        (Space::image(70.0, 40.0, 5.0).unwrap(), CbtConfig::default()),
        (
            Space::image(70.0, 40.0, 5.0).unwrap(),
            CbtConfig {
                layout: Layout::SparseJoint,
                order: Order::First,
                ..CbtConfig::default()
            },
        ),
        (
            Space::image(70.0, 40.0, 2.5).unwrap(),
            CbtConfig::stationary(),
        ),
    ];
    let mut rng = rng_for(11, 4);
    for (space, cfg) in cases {
        let mut t = CbtTracker::new(CbtModel::untrained(space.clone(), cfg).unwrap());
        let hi: [f64; 2] = [70.0, if space.dims() == 2 { 40.0 } else { 0.0 }];
        for i in 0..60 {
            let mut p = [rng.random_range(0.0..hi[0]), rng.random_range(0.0..=hi[1])];
            let c = space.cell_centre(rng.random_range(0..space.cells()));
            if i % 5 == 0 && c[0] <= hi[0].min(30.0) && c[1] <= hi[1] && c[0] >= 0.0 && c[1] >= 0.0
            {
                p = c;
            }
            if space.dims() == 1 {
                p[0] = p[0].min(30.0);
            }
            t.reset(p).unwrap();
            let e = t.estimate().position;
            if cfg.layout == Layout::Stationary {
                // The first moment of the start's channel coefficients (module docs of
                // `stationary::window`, step 4), within 0.04 channels of the start.
                for d in 0..2 {
                    let b = space.state_basis(d);
                    let c = b.encode(p[d]).unwrap();
                    let m: f64 = c.iter().enumerate().map(|(k, v)| b.centre(k) * v).sum();
                    let want = m / c.iter().sum::<f64>();
                    assert!((e[d] - want).abs() < 1e-9, "{p:?}: {e:?} against {want}");
                    assert!((e[d] - p[d]).abs() <= 0.04 * b.spacing(), "{p:?}: {e:?}");
                }
                continue;
            }
            for d in 0..space.dims() {
                assert!(
                    (e[d] - p[d]).abs() < 1e-9,
                    "{:?} dims {}: {p:?} decoded as {e:?}",
                    cfg.layout,
                    space.dims()
                );
            }
        }
    }
}

/// `Sequence::bounds` is the box of every truth and detection of every sequence (frames
/// without truth, without detections, sequences without frames; `None` without a position);
/// `start` the first frame with a truth; `training_frames` the truth as the one state.
#[test]
fn sequence_bounds_start_and_training_frames() {
    for seed in 0..200 {
        let train = mirrored_sequences(seed);
        let mut extra = train.clone();
        extra.push(Sequence::default());
        let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
        for s in &train {
            for f in &s.frames {
                let pts = f
                    .truth
                    .into_iter()
                    .chain(f.detections.iter().map(|d| d.pos));
                for p in pts {
                    for d in 0..2 {
                        lo[d] = lo[d].min(p[d]);
                        hi[d] = hi[d].max(p[d]);
                    }
                }
            }
            let first = (0..s.frames.len()).find(|&k| s.frames[k].truth.is_some());
            assert_eq!(s.start(), first);
            let tf = s.training_frames();
            assert_eq!(tf.len(), s.frames.len());
            for (t, f) in tf.iter().zip(&s.frames) {
                assert_eq!(t.states, f.truth.into_iter().collect::<Vec<_>>());
                assert_eq!(t.detections, f.detections);
            }
        }
        let want = lo[0].is_finite().then_some((lo, hi));
        assert_eq!(Sequence::bounds(&train), want, "seed {seed}");
        assert_eq!(Sequence::bounds(&extra), want, "seed {seed}");
    }
    assert_eq!(Sequence::bounds(&[Sequence::default()]), None);
}
