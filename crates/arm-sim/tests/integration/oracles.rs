//! Independent oracles for the arm's mechanics and the camera, over the whole allowed range
//! (any base yaw, negative angles, reversed servos, rolled cameras), each written from the
//! documented model rather than from the code:
//! - gravity torques as 3-D moments `((P − J) × m g) · axis` about each pitch axis;
//! - gravity sag as the fixed point `q' = q + c τ(q')`, solved to convergence;
//! - the servo's documented recurrence (quantise, calibrate, deadband, backlash);
//! - a camera's roll as a rotation of the image about the principal point.

use arm_sim::kinematics::GRAVITY;
use arm_sim::servo::{ServoState, calibrated_target};
use arm_sim::{
    ArmGeometry, Camera, CameraConfig, SagConfig, ServoConfig, SimConfig, apply_sag,
    forward_kinematics, gravity_torques,
};
use nalgebra::Vector3;
use rand::SeedableRng;
use rand::rngs::Xoshiro256PlusPlus;

/// A small LCG: uniform values in `[lo, hi)`.
struct Lcg(u64);

impl Lcg {
    fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        lo + (hi - lo) * ((self.0 >> 11) as f64 / (1u64 << 53) as f64)
    }
    fn angles(&mut self) -> [f64; 6] {
        [
            self.uniform(-180.0, 180.0),
            self.uniform(-100.0, 100.0),
            self.uniform(-150.0, 150.0),
            self.uniform(-120.0, 120.0),
            self.uniform(-180.0, 180.0),
            self.uniform(-90.0, 90.0),
        ]
    }
}

/// The torques by 3-D moments: masses at the middles of upper arm, forearm and hand and at the
/// elbow and wrist (SagConfig's documentation), gravity `−m g ẑ`, each moment about the joint
/// projected on the pitch axis (positive = increasing the joint angle, leaning forward).
fn moments(g: &ArmGeometry, sag: &SagConfig, q: &[f64; 6]) -> [f64; 3] {
    let pose = forward_kinematics(g, q);
    let [m_upper, m_fore, m_elbow, m_wrist, m_hand] = sag.masses_kg;
    let masses = [
        (m_upper, (pose.shoulder + pose.elbow) * 0.5, 0),
        (m_elbow, pose.elbow, 1),
        (m_fore, (pose.elbow + pose.wrist) * 0.5, 1),
        (m_wrist, pose.wrist, 2),
        (m_hand, (pose.wrist + pose.tip) * 0.5, 2),
    ];
    // Which masses lie beyond each joint: index ≥ the joint's first link.
    let joints = [pose.shoulder, pose.elbow, pose.wrist];
    let weight = |m: f64| Vector3::new(0.0, 0.0, -m * GRAVITY);
    let axis = pose.pitch_axis;
    std::array::from_fn(|j| {
        masses
            .iter()
            .filter(|(_, _, link)| *link >= j)
            .map(|(m, p, _)| ((p - joints[j]) * 1e-3).cross(&weight(*m)).dot(&axis))
            .sum()
    })
}

#[test]
fn gravity_torques_are_the_three_d_moments_about_the_pitch_axes() {
    let g = ArmGeometry::default();
    let mut rng = Lcg(1);
    let mut signs = [0usize; 2];
    for _ in 0..400 {
        let sag = SagConfig {
            compliance_deg_per_nm: [1.0; 3],
            masses_kg: std::array::from_fn(|_| rng.uniform(0.0, 0.2)),
        };
        let q = rng.angles();
        let t = gravity_torques(&g, &sag, &q);
        let want = moments(&g, &sag, &q);
        for j in 0..3 {
            assert!(
                (t[j] - want[j]).abs() <= 1e-12 * (1.0 + want[j].abs()),
                "joint {j} at {q:?}: {} vs moment {}",
                t[j],
                want[j]
            );
            signs[usize::from(t[j] > 0.0)] += 1;
        }
        // Base yaw, wrist roll and gripper move no mass horizontally relative to the joints.
        let mut turned = q;
        turned[0] = rng.uniform(-180.0, 180.0);
        turned[4] = rng.uniform(-180.0, 180.0);
        turned[5] = rng.uniform(-90.0, 90.0);
        let t2 = gravity_torques(&g, &sag, &turned);
        for j in 0..3 {
            assert!((t2[j] - t[j]).abs() <= 1e-12 * (1.0 + t[j].abs()), "{q:?}");
        }
        // Mirrored pitch angles mirror the torques.
        let mirrored = [q[0], -q[1], -q[2], -q[3], q[4], q[5]];
        let t3 = gravity_torques(&g, &sag, &mirrored);
        for j in 0..3 {
            assert!((t3[j] + t[j]).abs() <= 1e-12 * (1.0 + t[j].abs()), "{q:?}");
        }
    }
    assert!(signs[0] > 100 && signs[1] > 100, "both signs: {signs:?}");
}

/// `apply_sag` approximates the fixed point `q'_j = q_j + c_j τ_j(q')` of the pitch joints
/// (two steps; the rest is second order), leaves the other joints alone, and is the identity
/// without compliance.
#[test]
fn sag_is_the_fixed_point_of_the_compliance_equation() {
    let g = ArmGeometry::default();
    let sag = SimConfig::default().sag;
    let rigid = SagConfig {
        compliance_deg_per_nm: [0.0; 3],
        ..sag.clone()
    };
    let mut rng = Lcg(2);
    let (mut largest, mut worst) = (0.0f64, 0.0f64);
    for _ in 0..300 {
        let q = rng.angles();
        assert_eq!(apply_sag(&g, &rigid, &q), q);
        let sagged = apply_sag(&g, &sag, &q);
        let mut fixed = q;
        for _ in 0..200 {
            let tau = gravity_torques(&g, &sag, &fixed);
            for j in 0..3 {
                fixed[j + 1] = q[j + 1] + sag.compliance_deg_per_nm[j] * tau[j];
            }
        }
        // Converged: the equation holds to rounding.
        let tau = gravity_torques(&g, &sag, &fixed);
        let mut pose_sag = 0.0f64;
        for j in 0..3 {
            let sag_j = fixed[j + 1] - q[j + 1];
            assert!((sag_j - sag.compliance_deg_per_nm[j] * tau[j]).abs() < 1e-9);
            pose_sag = pose_sag.max(sag_j.abs());
        }
        largest = largest.max(pose_sag);
        // Two steps leave a second-order error: small against the pose's sag.
        for j in 1..4 {
            let err = (sagged[j] - fixed[j]).abs();
            worst = worst.max(err / pose_sag.max(1e-300));
            assert!(
                err <= 0.01 * pose_sag + 1e-12,
                "joint {j} at {q:?}: {} vs fixed point {} (largest sag {pose_sag})",
                sagged[j],
                fixed[j]
            );
        }
        for i in [0, 4, 5] {
            assert_eq!(sagged[i], q[i]);
        }
    }
    assert!(largest > 1.0, "some poses sag by over a degree ({largest})");
    eprintln!("largest sag {largest}°, worst two-step error {worst} of the pose's sag");
}

/// The servo model of `arm_sim::servo`'s documentation, one set-point `p` from the motor angle
/// `motor`: `None` if the servo does not move, else the new (motor, output, direction).
fn documented_step(c: &ServoConfig, motor: f64, p: f64) -> Option<(f64, f64, f64)> {
    let pq = if c.quantum_us > 0.0 {
        c.centre_us + c.quantum_us * ((p - c.centre_us) / c.quantum_us).round()
    } else {
        p
    };
    let target = c.centre_deg + c.deg_per_us * (c.offset_us + c.gain * (pq - c.centre_us));
    let band = (c.deg_per_us * c.gain).abs() * c.deadband_us;
    let err = target - motor;
    if err.abs() <= band / 2.0 {
        return None;
    }
    let d = err.signum();
    let m = target - d * band / 2.0;
    Some((m, m - d * c.backlash_deg / 2.0, d))
}

/// Servos mounted either way (negative `deg_per_us`), with calibration error, quantisation,
/// deadband and backlash, against the documented recurrence; `stall_at` keeps the motor on the
/// backlash side, so the next move continues from there.
#[test]
fn servos_follow_the_documented_recurrence_in_both_mountings() {
    let mut rng = Lcg(3);
    let mut moves = [0usize; 2];
    for (k, (deg_per_us, gain, offset, quantum, deadband, backlash)) in [
        (0.09, 1.05, 18.0, 1.0, 6.0, 0.6),
        (-0.09, 0.96, -35.0, 8.0, 4.0, 1.0),
        (-0.045, 1.0, 0.0, 0.0, 0.0, 0.0),
        (0.12, 0.97, 40.0, 0.0, 8.0, 0.2),
    ]
    .into_iter()
    .enumerate()
    {
        let c = ServoConfig {
            deg_per_us,
            gain,
            offset_us: offset,
            quantum_us: quantum,
            deadband_us: deadband,
            backlash_deg: backlash,
            end_noise_deg: 0.0,
            ..SimConfig::default().servos[k].clone()
        };
        let start = rng.uniform(c.min_us, c.max_us);
        let mut s = ServoState::at_rest(&c, start);
        assert_eq!(s.output_deg, calibrated_target(&c, start));
        let (mut motor, mut output, mut dir) = (s.motor_deg, s.output_deg, 0.0);
        // No noise is drawn (end_noise_deg = 0).
        let mut noise = Xoshiro256PlusPlus::seed_from_u64(0);
        let mut p = start;
        for step in 0..300 {
            // Mostly small changes (inside and just beyond the deadband), some large ones.
            p = if step % 5 == 0 {
                rng.uniform(c.min_us, c.max_us)
            } else {
                (p + rng.uniform(-8.0, 8.0)).clamp(c.min_us, c.max_us)
            };
            let moved = s.step(&c, p, &mut noise).unwrap();
            let want = documented_step(&c, motor, p);
            assert_eq!(moved, want.is_some(), "servo {k}, step {step}, pulse {p}");
            if let Some((m, o, d)) = want {
                (motor, output, dir) = (m, o, d);
            }
            moves[usize::from(moved)] += 1;
            assert!(
                (s.motor_deg - motor).abs() < 1e-9
                    && (s.output_deg - output).abs() < 1e-9
                    && s.direction == dir,
                "servo {k}, step {step}: {s:?} vs motor {motor}, output {output}, dir {dir}"
            );
            if step % 37 == 36 {
                // A mechanical stop a little short of where the output went.
                let stop = output - dir * 0.3;
                s.stall_at(&c, stop).unwrap();
                assert_eq!(s.output_deg, stop);
                // The motor keeps the backlash side: output = motor − dir·b/2.
                motor = stop + dir * 0.5 * c.backlash_deg;
                output = stop;
                assert!((s.motor_deg - motor).abs() < 1e-12);
            }
        }
    }
    assert!(
        moves[0] > 50 && moves[1] > 200,
        "moves and non-moves: {moves:?}"
    );
}

/// A camera's roll turns the image about the principal point by the roll angle (square pixels;
/// the radial distortion commutes with it): the distance from the principal point is kept and
/// the angle changes by ±roll, the same sign for every point and roll.
#[test]
fn roll_rotates_the_image_about_the_principal_point() {
    let base = CameraConfig::looking_at([450.0, -250.0, 380.0], [120.0, 20.0, 60.0]);
    assert_eq!(base.fx, base.fy, "square pixels");
    let flat = Camera::new(&base, 0).unwrap();
    let mut sign = 0.0;
    let mut rng = Lcg(4);
    for roll in [90.0, -30.0, 7.5, 180.0, 360.0] {
        let cam = Camera::new(
            &CameraConfig {
                roll_deg: roll,
                ..base.clone()
            },
            0,
        )
        .unwrap();
        for _ in 0..40 {
            let p = Vector3::new(
                rng.uniform(-50.0, 250.0),
                rng.uniform(-150.0, 150.0),
                rng.uniform(0.0, 200.0),
            );
            let [u0, v0] = flat.project(&p).unwrap();
            let [u, v] = cam.project(&p).unwrap();
            let (a0, b0) = (u0 - flat.cx, v0 - flat.cy);
            let (a, b) = (u - cam.cx, v - cam.cy);
            assert!(
                (a.hypot(b) - a0.hypot(b0)).abs() < 1e-9,
                "roll {roll}: radius"
            );
            if sign == 0.0 && roll == 90.0 {
                // Which way a positive roll turns the image (the documentation leaves it open).
                sign = (a0 * b - b0 * a).signum();
            }
            let (s, c) = (sign * roll).to_radians().sin_cos();
            assert!(
                (a - (c * a0 - s * b0)).abs() < 1e-9 && (b - (s * a0 + c * b0)).abs() < 1e-9,
                "roll {roll} at {p:?}: ({a}, {b}) vs ({a0}, {b0}) turned"
            );
        }
    }
}

/// Undistortion inverts the lens model for every lens the configuration accepts (barrel and
/// pincushion, none, non-square pixels, an off-centre principal point), over the whole image
/// including its corners: the pixel goes back to itself, and so does the ray's world point.
#[test]
fn undistortion_inverts_every_accepted_lens() {
    let mut rng = Lcg(5);
    for (k1, k2, fx, fy, cx, cy) in [
        (0.0, 0.0, 560.0, 560.0, 319.5, 239.5),
        (-0.2, 0.05, 560.0, 560.0, 319.5, 239.5),
        (0.08, 0.0, 500.0, 620.0, 300.0, 260.0),
        (-0.05, -0.02, 700.0, 650.0, 330.0, 230.0),
    ] {
        let cfg = CameraConfig {
            k1,
            k2,
            fx,
            fy,
            cx,
            cy,
            ..CameraConfig::looking_at([450.0, -250.0, 380.0], [120.0, 20.0, 60.0])
        };
        let cam = Camera::new(&cfg, 0).unwrap();
        let (w, h) = (f64::from(cam.width), f64::from(cam.height));
        let corners = [
            (-0.5, -0.5),
            (w - 0.5, -0.5),
            (-0.5, h - 0.5),
            (w - 0.5, h - 0.5),
        ];
        let inside = (0..60).map(|_| (rng.uniform(-0.5, w - 0.5), rng.uniform(-0.5, h - 0.5)));
        for (u, v) in corners.into_iter().chain([(cx, cy)]).chain(inside) {
            let [x, y] = cam.undistort(u, v).unwrap();
            let [u2, v2] = cam.normalised_to_pixel(x, y);
            assert!(
                (u - u2).abs() < 1e-9 && (v - v2).abs() < 1e-9,
                "lens {k1} {k2}: ({u}, {v}) -> ({x}, {y}) -> ({u2}, {v2})"
            );
            let ray = cam.ray(u, v).unwrap();
            assert!((ray.norm() - 1.0).abs() < 1e-12);
            let [u3, v3] = cam.project(&(cam.centre + ray * 600.0)).unwrap();
            assert!(
                (u - u3).abs() < 1e-7 && (v - v3).abs() < 1e-7,
                "lens {k1} {k2}: ray of ({u}, {v}) projects to ({u3}, {v3})"
            );
        }
    }
}
