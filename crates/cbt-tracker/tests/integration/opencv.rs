//! With the `opencv` feature: our Kalman filter gives the same states and covariances as
//! OpenCV's `cv::KalmanFilter` (CV_64F) on the same sequence, to 1e-9.
#![cfg(feature = "opencv")]

use cbt_tracker::sim::{Level, Scenario, generate};
use cbt_tracker::{KalmanParams, KalmanTracker, Tracker};
use nalgebra::{Matrix4, Vector2, Vector4};
use opencv::core::{CV_64F, Mat, MatTrait, MatTraitConst};
use opencv::prelude::*;
use opencv::video::KalmanFilter;

fn to_mat(rows: usize, cols: usize, f: impl Fn(usize, usize) -> f64) -> Mat {
    let mut m = Mat::zeros(rows as i32, cols as i32, CV_64F)
        .unwrap()
        .to_mat()
        .unwrap();
    for r in 0..rows {
        for c in 0..cols {
            *m.at_2d_mut::<f64>(r as i32, c as i32).unwrap() = f(r, c);
        }
    }
    m
}

fn get(m: &Mat, r: usize, c: usize) -> f64 {
    *m.at_2d::<f64>(r as i32, c as i32).unwrap()
}

#[test]
fn kalman_matches_opencv() {
    let s = generate(&Scenario::default(), &Level::preset(1), 1, 150, 3)
        .unwrap()
        .remove(0);
    let params = KalmanParams {
        accel_sigma: 0.7,
        meas_sigma: 2.0,
        init_vel_sigma: 3.0,
        gate: 1e12,
    };
    let mut ours = KalmanTracker::new(params).unwrap();
    ours.reset(s.frames[0].truth.unwrap()).unwrap();
    let (f, q, h, r) = ours.matrices();
    let mut cv = KalmanFilter::new(4, 2, 0, CV_64F).unwrap();
    cv.set_transition_matrix(to_mat(4, 4, |i, j| f[(i, j)]));
    cv.set_process_noise_cov(to_mat(4, 4, |i, j| q[(i, j)]));
    cv.set_measurement_matrix(to_mat(2, 4, |i, j| h[(i, j)]));
    cv.set_measurement_noise_cov(to_mat(2, 2, |i, j| r[(i, j)]));
    let (x0, p0) = (ours.state(), ours.covariance());
    cv.set_state_post(to_mat(4, 1, |i, _| x0[i]));
    cv.set_error_cov_post(to_mat(4, 4, |i, j| p0[(i, j)]));
    let mut compared = 0;
    for frame in &s.frames[1..] {
        ours.predict();
        cv.predict(&Mat::default()).unwrap();
        // The first detection of the frame, when there is one (the same for both).
        if let Some(d) = frame.detections.first() {
            ours.correct(Vector2::new(d.pos[0], d.pos[1])).unwrap();
            cv.correct(&to_mat(2, 1, |i, _| d.pos[i])).unwrap();
        } else {
            // OpenCV keeps statePost from before predict when not corrected: copy the
            // prediction over, as a filter without a measurement does.
            let (pre, cov) = (cv.state_pre(), cv.error_cov_pre());
            cv.set_state_post(pre);
            cv.set_error_cov_post(cov);
        }
        let (x, p) = (cv.state_post(), cv.error_cov_post());
        let xs: Vector4<f64> = ours.state();
        let ps: Matrix4<f64> = ours.covariance();
        for i in 0..4 {
            assert!((get(&x, i, 0) - xs[i]).abs() <= 1e-9 * xs[i].abs().max(1.0));
            for j in 0..4 {
                assert!((get(&p, i, j) - ps[(i, j)]).abs() <= 1e-9 * ps[(i, j)].abs().max(1.0));
            }
        }
        compared += 1;
    }
    assert_eq!(compared, 149);
}
