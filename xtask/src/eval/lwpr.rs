//! `cargo xtask eval lwpr`: learning curves of our LWPR on the cross function
//! (docs/methods.md § LWPR): test nMSE on the 41×41 grid and the number of receptive fields against
//! the number of training samples, for setting A (20 000 fresh samples, the stream of the
//! reference's `bench_cross.c`, seed 1) and setting B (500 samples, 20 shuffled epochs, seed 1).
//!
//! Deterministic (seeded data, no timings). The reference library's curve is not in the
//! fixture (building C code is not part of `eval`); `cargo xtask bench lwpr` prints both curves
//! side by side, and `crates/lwpr/tests/integration/reference.rs` checks that ours is bit-identical
//! to it.

// Included by both the bench and the eval module (it is also the tests' harness).
#[allow(clippy::duplicate_mod)]
#[path = "../../../crates/lwpr/peer/harness.rs"]
mod harness;

use harness::*;
use lwpr::Lwpr;
use plotters::prelude::*;
use serde::Serialize;

use super::{EvalContext, write_json};
use crate::Result;

#[derive(Serialize)]
struct Point {
    samples: usize,
    receptive_fields: usize,
    nmse: f64,
}

#[derive(Serialize)]
struct Curve {
    setting: &'static str,
    description: &'static str,
    points: Vec<Point>,
}

fn point(m: &Lwpr, samples: usize) -> Result<Point> {
    let (gx, gy) = cross_grid();
    Ok(Point {
        samples,
        receptive_fields: m.num_rfs()[0],
        nmse: nmse(&m.predict_batch(&gx, 0.001)?, &gy),
    })
}

fn setting_a() -> Result<Curve> {
    let (x, y) = cross_samples(1, 20_000, 0.1);
    let mut m = setting_a_builder(2).build()?;
    let marks = [50usize, 100, 200, 500, 1000, 2000, 5000, 10_000, 20_000];
    let mut points = Vec::new();
    for (t, (a, b)) in x.chunks(2).zip(&y).enumerate() {
        m.update(a, &[*b])?;
        if marks.contains(&(t + 1)) {
            points.push(point(&m, t + 1)?);
        }
    }
    Ok(Curve {
        setting: "A",
        description: "20000 fresh samples, N(0, 0.1²) noise, init_D = 50 I, init_alpha = 250, w_gen = 0.2, rest default",
        points,
    })
}

fn setting_b() -> Result<Curve> {
    let (x, y) = cross_samples(1, 500, 0.1);
    let mut m = setting_b_builder().build()?;
    let mut rng = Rng::new(1 ^ 0xB);
    let mut order: Vec<usize> = (0..500).collect();
    let mut points = Vec::new();
    for epoch in 1..=20 {
        for i in (1..order.len()).rev() {
            let j = (rng.uniform() * (i + 1) as f64) as usize;
            order.swap(i, j);
        }
        for &k in &order {
            m.update(&x[2 * k..2 * k + 2], &[y[k]])?;
        }
        points.push(point(&m, 500 * epoch)?);
    }
    Ok(Curve {
        setting: "B",
        description: "500 samples, N(0, 0.1²) noise, 20 shuffled epochs, init_D = 25 I full, init_alpha = 250, w_gen = 0.2, meta",
        points,
    })
}

fn plot(curves: &[Curve], path: &std::path::Path) -> Result<()> {
    let root = SVGBackend::new(path, (760, 520)).into_drawing_area();
    root.fill(&WHITE)?;
    let (top, bottom) = root.split_vertically(260);
    let x_range = (40.0f64..25_000.0).log_scale();
    let mut c1 = ChartBuilder::on(&top)
        .caption(
            "LWPR on the cross function: test nMSE (41×41 grid)",
            ("sans-serif", 15),
        )
        .margin(8)
        .x_label_area_size(28)
        .y_label_area_size(50)
        .build_cartesian_2d(x_range.clone(), (0.01f64..3.0).log_scale())?;
    c1.configure_mesh()
        .x_desc("training samples")
        .y_desc("nMSE")
        .draw()?;
    let mut c2 = ChartBuilder::on(&bottom)
        .caption("number of receptive fields", ("sans-serif", 15))
        .margin(8)
        .x_label_area_size(28)
        .y_label_area_size(50)
        .build_cartesian_2d(x_range, 0.0f64..70.0)?;
    c2.configure_mesh()
        .x_desc("training samples")
        .y_desc("RFs")
        .draw()?;
    for (k, c) in curves.iter().enumerate() {
        let color = crate::palette::series(k).to_rgba();
        let label = format!("setting {}", c.setting);
        let e: Vec<(f64, f64)> = c
            .points
            .iter()
            .map(|p| (p.samples as f64, p.nmse))
            .collect();
        let r: Vec<(f64, f64)> = c
            .points
            .iter()
            .map(|p| (p.samples as f64, p.receptive_fields as f64))
            .collect();
        c1.draw_series(LineSeries::new(e.clone(), color.stroke_width(2)))?
            .label(label.clone())
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 16, y)], color.stroke_width(2))
            });
        c1.draw_series(e.into_iter().map(|p| Circle::new(p, 3, color.filled())))?;
        c2.draw_series(LineSeries::new(r.clone(), color.stroke_width(2)))?;
        c2.draw_series(r.into_iter().map(|p| Circle::new(p, 3, color.filled())))?;
    }
    c1.configure_series_labels()
        .border_style(BLACK)
        .background_style(WHITE)
        .draw()?;
    root.present()?;
    Ok(())
}

/// Runs the target.
pub fn run(ctx: &EvalContext) -> Result<()> {
    let curves = vec![setting_a()?, setting_b()?];
    write_json(&ctx.out_dir, "learning-curves.json", &curves)?;
    plot(&curves, &ctx.out_dir.join("learning-curves.svg"))
}
