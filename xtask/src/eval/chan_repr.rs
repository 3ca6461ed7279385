//! `cargo xtask eval chan-repr`: the thesis's worked example (eq. 2.3–2.9) as JSON, and the ten
//! cos² kernels of Figure 2.1 as SVG.

use chan_repr::{ChannelBasis, Kernel, Mode, WindowEstimate};
use plotters::prelude::*;
use serde::Serialize;

use super::{EvalContext, write_json};
use crate::Result;

#[derive(Serialize)]
struct WorkedExample {
    description: &'static str,
    basis: ChannelBasis,
    representable_range: (f64, f64),
    /// eq. 2.3: the channel vector of 3.3.
    encode_3_3: Vec<f64>,
    /// eq. 2.6, 2.7: every window's estimate and certainty.
    windows_3_3: Vec<WindowEstimate>,
    modes_3_3: Vec<Mode>,
    /// eq. 2.8: the channel vector of 6.8.
    encode_6_8: Vec<f64>,
    /// eq. 2.9: the soft histogram of 3.3 and 6.8.
    soft_histogram: Vec<f64>,
    modes_soft_histogram: Vec<Mode>,
}

/// Runs the target.
pub fn run(ctx: &EvalContext) -> Result<()> {
    let basis = ChannelBasis::integer(10, Kernel::Cos2 { m: 3 })?;
    let c1 = basis.encode(3.3)?;
    let c2 = basis.encode(6.8)?;
    let sum: Vec<f64> = c1.iter().zip(&c2).map(|(a, b)| a + b).collect();
    let example = WorkedExample {
        description: "Thesis ch. 2: ten cos² channels on centres 1..10, a = π/3",
        representable_range: basis.representable_range(),
        windows_3_3: basis.decode_windows(&c1)?,
        modes_3_3: basis.decode(&c1)?,
        modes_soft_histogram: basis.decode(&sum)?,
        encode_3_3: c1,
        encode_6_8: c2,
        soft_histogram: sum,
        basis: basis.clone(),
    };
    write_json(&ctx.out_dir, "worked-example.json", &example)?;
    plot_kernels(&basis, &ctx.out_dir.join("figure-2-1.svg"))
}

/// Figure 2.1: the ten kernels over [0, 11].
fn plot_kernels(basis: &ChannelBasis, path: &std::path::Path) -> Result<()> {
    let root = SVGBackend::new(path, (720, 240)).into_drawing_area();
    root.fill(&WHITE)?;
    let mut chart = ChartBuilder::on(&root)
        .caption(
            "Figure 2.1: ten cos² kernels on integer centres (a = π/3)",
            ("sans-serif", 16),
        )
        .margin(10)
        .x_label_area_size(30)
        .y_label_area_size(30)
        .build_cartesian_2d(0.0f64..11.0, 0.0f64..1.05)?;
    chart
        .configure_mesh()
        .x_labels(12)
        .y_labels(3)
        .disable_mesh()
        .draw()?;
    let kernel = basis.kernel();
    for k in 0..basis.len() {
        let centre = basis.centre(k);
        let points = (0..=1100).map(|i| {
            let x = i as f64 / 100.0;
            (x, kernel.value((x - centre) / basis.spacing()))
        });
        chart.draw_series(LineSeries::new(
            points,
            crate::palette::series(k).stroke_width(2),
        ))?;
    }
    root.present()?;
    Ok(())
}
