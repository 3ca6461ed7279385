//! SVG figures laid out like Paper A's: Figures 4–6 (precision against recall, eight curves,
//! "Existing matches: N") and Figures 7–9 (precision against the number of matches with
//! preselection, four curves), with the paper's legend names. Canonical sampling is drawn solid,
//! affine-arc-length sampling dashed.

use std::path::Path;

use plotters::prelude::*;

use super::evaluate::{CombinationCurve, Group};
use super::report::SequenceReport;
use super::sequence::Sequence;
use crate::Result;

/// The paper's figure numbers for a sequence: (precision–recall, preselection).
fn figure_numbers(sequence: &str) -> Option<(u32, u32)> {
    match sequence {
        "leuven" => Some((4, 7)),
        "boat" => Some((5, 8)),
        "graf" => Some((6, 9)),
        _ => None,
    }
}

/// File stem of a group's figures, e.g. `leuven-img1-vs-img2-6`.
pub fn stem(sequence: &str, group: &Group) -> String {
    let images = &group.images;
    match images.as_slice() {
        [k] => format!("{sequence}-img1-vs-img{k}"),
        [first, .., last] => format!("{sequence}-img1-vs-img{first}-{last}"),
        [] => format!("{sequence}-empty"),
    }
}

/// Which points to draw: (x, y) for each grid threshold with a defined precision.
fn points(c: &CombinationCurve, x_is_matches: bool) -> Vec<(f64, f64)> {
    c.curve
        .points
        .iter()
        .filter_map(|p| {
            let x = if x_is_matches {
                p.matches as f64
            } else {
                p.recall?
            };
            Some((x, p.precision?))
        })
        .collect()
}

fn draw(
    path: &Path,
    caption: &str,
    x_label: &str,
    curves: &[CombinationCurve],
    x_is_matches: bool,
    note: &str,
) -> Result<()> {
    let series: Vec<Vec<(f64, f64)>> = curves.iter().map(|c| points(c, x_is_matches)).collect();
    let x_max = series.iter().flatten().map(|p| p.0).fold(0.0f64, f64::max);
    let x_max = if x_is_matches {
        (x_max * 1.05).max(10.0).ceil()
    } else {
        ((x_max * 1.1 * 20.0).ceil() / 20.0).clamp(0.05, 1.0)
    };
    let root = SVGBackend::new(path, (760, 520)).into_drawing_area();
    root.fill(&WHITE)?;
    let mut chart = ChartBuilder::on(&root)
        .caption(caption, ("sans-serif", 17))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(50)
        .build_cartesian_2d(0.0..x_max, 0.0..1.0)?;
    chart
        .configure_mesh()
        .x_desc(x_label)
        .y_desc("Precision")
        .x_label_formatter(&|v| {
            if x_is_matches {
                format!("{v:.0}")
            } else {
                format!("{v:.2}")
            }
        })
        .y_label_formatter(&|v| format!("{v:.1}"))
        .draw()?;
    for (k, (c, pts)) in curves.iter().zip(&series).enumerate() {
        let style = crate::palette::series(k).stroke_width(2);
        let canonical = c.combination.ends_with("Canonical");
        let anno = if canonical {
            chart.draw_series(LineSeries::new(pts.iter().copied(), style))?
        } else {
            chart.draw_series(DashedLineSeries::new(pts.iter().copied(), 6, 4, style))?
        };
        anno.label(c.combination.clone()).legend(move |(x, y)| {
            PathElement::new(
                vec![(x, y), (x + 24, y)],
                crate::palette::series(k).stroke_width(2),
            )
        });
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .label_font(("sans-serif", 12))
        .draw()?;
    root.draw(&Text::new(
        note.to_string(),
        (70, 50),
        ("sans-serif", 13).into_font(),
    ))?;
    root.present()?;
    Ok(())
}

/// Writes both figures of every group of a sequence into `out`.
pub fn write_all(seq: &Sequence, report: &SequenceReport, out: &Path) -> Result<()> {
    let title = super::summary::display_name(&seq.name);
    for (gi, g) in report.groups.iter().enumerate() {
        let stem = stem(&seq.name, g);
        let numbers = figure_numbers(&seq.name).filter(|_| gi == 0);
        let fig = |n: Option<u32>| n.map_or(String::new(), |n| format!("Figure {n} (Paper A): "));
        let existing = match g.paper_existing {
            Some(p) => format!("Existing matches: {} (paper: {p})", g.existing),
            None => format!("Existing matches: {}", g.existing),
        };
        draw(
            &out.join(format!("{stem}-pr.svg")),
            &format!(
                "{}{title}, {} — precision-recall",
                fig(numbers.map(|n| n.0)),
                g.label
            ),
            "Recall",
            &g.curves,
            false,
            &existing,
        )?;
        draw(
            &out.join(format!("{stem}-preselection.svg")),
            &format!(
                "{}{title}, {} — with preselection",
                fig(numbers.map(|n| n.1)),
                g.label
            ),
            "Number of matches",
            &g.preselection,
            true,
            &existing,
        )?;
    }
    Ok(())
}
