//! SVG plots of the tracking study (deterministic: no timings).

use std::path::Path;

use plotters::prelude::*;

use super::study::{SetKind, SetResult, aggregate};
use crate::Result;
use cbt_tracker::Sequence;

/// Truth, detections (near the truth / other) and every tracker's estimate for one sequence.
pub fn trajectories(set: &SetResult, seq: &Sequence, index: usize, path: &Path) -> Result<()> {
    let SetKind::Image {
        x_lo,
        x_hi,
        y_lo,
        y_hi,
    } = set.kind
    else {
        return Ok(());
    };
    let near = set.calibration.map_or(10.0, |c| 3.0 * c.meas_sigma);
    let res = &set.sequences[index];
    let root = SVGBackend::new(path, (800, 640)).into_drawing_area();
    root.fill(&WHITE)?;
    let mut chart = ChartBuilder::on(&root)
        .caption(
            format!(
                "{} / {}: truth, detections and estimates",
                set.set, res.sequence
            ),
            ("sans-serif", 16),
        )
        .margin(10)
        .x_label_area_size(30)
        .y_label_area_size(40)
        .build_cartesian_2d(x_lo..x_hi, y_hi..y_lo)?;
    chart
        .configure_mesh()
        .x_desc("x (px)")
        .y_desc("y (px, down)")
        .disable_mesh()
        .draw()?;
    let (mut target, mut other) = (Vec::new(), Vec::new());
    for f in &seq.frames {
        for d in &f.detections {
            let p = (d.pos[0], d.pos[1]);
            match f.truth {
                Some(t) if (d.pos[0] - t[0]).hypot(d.pos[1] - t[1]) <= near => target.push(p),
                _ => other.push(p),
            }
        }
    }
    chart
        .draw_series(
            other
                .iter()
                .map(|&p| Cross::new(p, 2, RGBColor(190, 190, 190))),
        )?
        .label("other detections (clutter)")
        .legend(|(x, y)| Cross::new((x + 8, y), 3, RGBColor(190, 190, 190)));
    chart
        .draw_series(
            target
                .iter()
                .map(|&p| Circle::new(p, 2, RGBColor(90, 90, 90).filled())),
        )?
        .label(format!("detections within {near:.0} px of the truth"))
        .legend(|(x, y)| Circle::new((x + 8, y), 3, RGBColor(90, 90, 90).filled()));
    let truth: Vec<(f64, f64)> = seq
        .frames
        .iter()
        .filter_map(|f| f.truth.map(|t| (t[0], t[1])))
        .collect();
    chart
        .draw_series(LineSeries::new(truth, BLACK.stroke_width(3)))?
        .label("truth")
        .legend(|(x, y)| PathElement::new([(x, y), (x + 16, y)], BLACK.stroke_width(3)));
    for (i, r) in res.runs.iter().enumerate() {
        let c = crate::palette::series(i);
        let pts: Vec<(f64, f64)> = r
            .estimates
            .iter()
            .map(|p| (p[0].clamp(x_lo, x_hi), p[1].clamp(y_lo, y_hi)))
            .collect();
        chart
            .draw_series(LineSeries::new(pts, c.stroke_width(1)))?
            .label(format!("{} (RMSE {:.1})", r.tracker, r.score.rmse))
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 16, y)], c.stroke_width(2)));
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .label_font(("sans-serif", 11))
        .position(SeriesLabelPosition::UpperRight)
        .draw()?;
    root.present()?;
    Ok(())
}

/// Mean RMSE per tracker against the clutter rate of the synthetic levels (log scale).
pub fn rmse_vs_clutter(sets: &[&SetResult], path: &Path) -> Result<()> {
    let pts: Vec<(f64, Vec<(String, f64)>)> = sets
        .iter()
        .filter_map(|s| {
            s.clutter_rate.map(|c| {
                let agg = aggregate(&[s]);
                (
                    c,
                    agg.into_iter().map(|a| (a.tracker, a.mean_rmse)).collect(),
                )
            })
        })
        .collect();
    if pts.is_empty() {
        return Ok(());
    }
    let xmax = pts.iter().map(|p| p.0).fold(0.0f64, f64::max).max(1.0);
    let ymin = pts
        .iter()
        .flat_map(|p| p.1.iter().map(|q| q.1))
        .fold(f64::INFINITY, f64::min)
        .max(0.1);
    let ymax = pts
        .iter()
        .flat_map(|p| p.1.iter().map(|q| q.1))
        .fold(0.0f64, f64::max)
        .max(ymin * 2.0);
    let root = SVGBackend::new(path, (720, 480)).into_drawing_area();
    root.fill(&WHITE)?;
    let mut chart = ChartBuilder::on(&root)
        .caption(
            "Mean RMSE against clutter rate (synthetic levels L0-L4)",
            ("sans-serif", 16),
        )
        .margin(10)
        .x_label_area_size(35)
        .y_label_area_size(50)
        .build_cartesian_2d(-0.3f64..xmax + 0.3, (ymin * 0.8..ymax * 1.25).log_scale())?;
    chart
        .configure_mesh()
        .x_desc("clutter detections per frame (with P_D and noise growing alongside)")
        .y_desc("mean RMSE (px)")
        .draw()?;
    let names: Vec<String> = pts[0].1.iter().map(|p| p.0.clone()).collect();
    for (i, name) in names.iter().enumerate() {
        let c = crate::palette::series(i);
        let line: Vec<(f64, f64)> = pts
            .iter()
            .filter_map(|(x, v)| v.iter().find(|p| &p.0 == name).map(|p| (*x, p.1)))
            .collect();
        chart
            .draw_series(LineSeries::new(line.clone(), c.stroke_width(2)))?
            .label(name.as_str())
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 16, y)], c.stroke_width(2)));
        chart.draw_series(line.iter().map(|&p| Circle::new(p, 3, c.filled())))?;
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .position(SeriesLabelPosition::UpperLeft)
        .draw()?;
    root.present()?;
    Ok(())
}
