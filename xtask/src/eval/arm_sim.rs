//! `cargo xtask eval arm-sim`: what the simulated arm's cameras see.
//!
//! Writes `camera-<i>.png` (a rendered frame of the default simulator in a fixed pose, with the
//! ground-truth gripper tip marked by a red cross), `workspace.svg` (the tip positions of 3,000
//! quasi-random reachable poses projected into each camera's image), `summary.json` (the pose's
//! ground truth and workspace statistics) and `default-config.json` (every simulator parameter,
//! a starting point for a user's own arm model). Everything is deterministic.

use arm_sim::{ArmSim, NUM_SERVOS, SimConfig};
use image::{Rgb, RgbImage};
use plotters::prelude::*;
use serde::Serialize;

use super::{EvalContext, write_json};
use crate::Result;

/// The pose shown in the PNGs (µs): reaching forward and down, gripper half open.
const SHOWN_POSE: [f64; NUM_SERVOS] = [1650.0, 1750.0, 1650.0, 1850.0, 1500.0, 1500.0];
/// Number of quasi-random poses sampled for the workspace plot.
const WORKSPACE_SAMPLES: usize = 3000;

#[derive(Serialize)]
struct CameraSummary {
    tip_px: [f64; 2],
    workspace_in_image: usize,
    workspace_px_min: [f64; 2],
    workspace_px_max: [f64; 2],
}

#[derive(Serialize)]
struct Summary {
    description: &'static str,
    seed: u64,
    set_points_us: [f64; NUM_SERVOS],
    nominal_angles_deg: [f64; NUM_SERVOS],
    true_angles_deg: [f64; NUM_SERVOS],
    tip_mm: [f64; 3],
    workspace_samples: usize,
    workspace_table_contacts: usize,
    cameras: Vec<CameraSummary>,
}

/// Radical inverse of `i` in base `b` (Halton sequence), in [0, 1).
fn halton(mut i: usize, b: usize) -> f64 {
    let (mut f, mut r) = (1.0, 0.0);
    while i > 0 {
        f /= b as f64;
        r += f * (i % b) as f64;
        i /= b;
    }
    r
}

/// Runs the target.
pub fn run(ctx: &EvalContext) -> Result<()> {
    let config = SimConfig::default();
    config.write_file(ctx.out_dir.join("default-config.json"))?;
    let mut sim = ArmSim::new(config.clone())?;
    sim.command(&SHOWN_POSE)?;
    let images = sim.capture();
    let inspect = sim.inspect();
    let tips = inspect.tip_pixels()?;
    for (i, (img, tip)) in images.iter().zip(&tips).enumerate() {
        let mut rgb = RgbImage::from_fn(img.width(), img.height(), |x, y| {
            let g = img.get_pixel(x, y)[0];
            Rgb([g, g, g])
        });
        mark(&mut rgb, *tip);
        crate::output::write_png(&ctx.out_dir.join(format!("camera-{i}.png")), &rgb)?;
    }
    let tip = inspect.tip();
    let mut summary = Summary {
        description: "arm-sim default configuration: one frame per camera in a fixed pose, \
                      and the tip over 3000 quasi-random (Halton) set-points",
        seed: config.seed,
        set_points_us: SHOWN_POSE,
        nominal_angles_deg: inspect.nominal_angles(&SHOWN_POSE)?,
        true_angles_deg: inspect.joint_angles(),
        tip_mm: [tip.x, tip.y, tip.z],
        workspace_samples: WORKSPACE_SAMPLES,
        workspace_table_contacts: 0,
        cameras: Vec::new(),
    };

    // Workspace: base, shoulder, elbow, wrist pitch over their full servo range (Halton
    // bases 2, 3, 5, 7); wrist roll and gripper centred.
    let mut points: Vec<Vec<(f64, f64, f64)>> = vec![Vec::new(); sim.num_cameras()];
    let mut contacts = 0;
    for k in 1..=WORKSPACE_SAMPLES {
        let mut set = [1500.0; NUM_SERVOS];
        for (j, base) in [2, 3, 5, 7].into_iter().enumerate() {
            let [lo, hi] = sim.servo_range(j).expect("servo exists");
            set[j] = lo + (hi - lo) * halton(k, base);
        }
        sim.command(&set)?;
        if sim.inspect().last_move().table_contact {
            contacts += 1;
            continue;
        }
        let tip = sim.inspect().tip();
        for (c, pts) in points.iter_mut().enumerate() {
            let cam = sim.inspect().camera(c)?.clone();
            if let Ok(uv) = cam.project(&tip)
                && cam.in_image(uv)
            {
                pts.push((uv[0], uv[1], tip.z));
            }
        }
    }
    summary.workspace_table_contacts = contacts;
    for (c, pts) in points.iter().enumerate() {
        let fold = |f: fn(f64, f64) -> f64, init: f64, pick: fn(&(f64, f64, f64)) -> f64| {
            pts.iter().map(pick).fold(init, f)
        };
        summary.cameras.push(CameraSummary {
            tip_px: tips[c],
            workspace_in_image: pts.len(),
            workspace_px_min: [
                fold(f64::min, f64::INFINITY, |p| p.0),
                fold(f64::min, f64::INFINITY, |p| p.1),
            ],
            workspace_px_max: [
                fold(f64::max, f64::NEG_INFINITY, |p| p.0),
                fold(f64::max, f64::NEG_INFINITY, |p| p.1),
            ],
        });
    }
    write_json(&ctx.out_dir, "summary.json", &summary)?;
    plot_workspace(&points, &config, &ctx.out_dir.join("workspace.svg"))
}

/// A red cross with a ring at the sub-pixel position `tip`.
fn mark(img: &mut RgbImage, tip: [f64; 2]) {
    let red = Rgb([255, 0, 0]);
    let (w, h) = (img.width() as i64, img.height() as i64);
    let (cu, cv) = (tip[0].round() as i64, tip[1].round() as i64);
    let mut put = |x: i64, y: i64| {
        if x >= 0 && y >= 0 && x < w && y < h {
            img.put_pixel(x as u32, y as u32, red);
        }
    };
    for d in 3..=9 {
        put(cu + d, cv);
        put(cu - d, cv);
        put(cu, cv + d);
        put(cu, cv - d);
    }
    put(cu, cv);
}

/// The tip positions in each camera's image, coloured by the tip's height above the table.
fn plot_workspace(
    points: &[Vec<(f64, f64, f64)>],
    config: &SimConfig,
    path: &std::path::Path,
) -> Result<()> {
    let root = SVGBackend::new(path, (1000, 440)).into_drawing_area();
    root.fill(&WHITE)?;
    let root = root.titled(
        "arm-sim: reachable gripper-tip positions projected into each camera (colour = height)",
        ("sans-serif", 16),
    )?;
    let panels = root.split_evenly((1, points.len()));
    let z_max = points.iter().flatten().map(|p| p.2).fold(1.0f64, f64::max);
    for (c, (panel, pts)) in panels.iter().zip(points).enumerate() {
        let cam = &config.cameras[c];
        let (w, h) = (cam.width as f64, cam.height as f64);
        let mut chart = ChartBuilder::on(panel)
            .caption(
                format!("camera {c} ({} poses in view)", pts.len()),
                ("sans-serif", 14),
            )
            .margin(8)
            .x_label_area_size(28)
            .y_label_area_size(36)
            .build_cartesian_2d(-0.5..w - 0.5, h - 0.5..-0.5)?;
        chart
            .configure_mesh()
            .x_desc("u (pixels)")
            .y_desc("v (pixels)")
            .disable_mesh()
            .draw()?;
        chart.draw_series(pts.iter().map(|&(u, v, z)| {
            let t = (z / z_max).clamp(0.0, 1.0);
            Circle::new((u, v), 1, HSLColor(0.66 * (1.0 - t), 0.85, 0.45).filled())
        }))?;
    }
    root.present()?;
    Ok(())
}
