//! The figure of a continuation branch: RMS against the followed parameter, stable parts solid,
//! unstable parts dashed, one colour per branch (the main one and those switched to at period
//! doublings), events marked and labelled.

use super::{err, init_font};
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::{Path, PathBuf};

/// One point of a branch figure.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BranchDot {
    /// Parameter.
    pub x: f64,
    /// RMS in µm.
    pub y: f64,
    /// Stable orbit.
    pub stable: bool,
    /// Branch number (0: main).
    pub branch: usize,
    /// Event name at this point.
    pub event: Option<&'static str>,
}

/// A branch figure.
pub struct BranchFigure<'a> {
    /// Title.
    pub title: &'a str,
    /// x label.
    pub x_label: &'a str,
    /// Points, branch by branch in continuation order.
    pub points: &'a [BranchDot],
}

const COLORS: [RGBColor; 4] = [
    RGBColor(31, 90, 160),
    RGBColor(200, 80, 30),
    RGBColor(40, 140, 60),
    RGBColor(130, 60, 160),
];

fn draw<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>, f: &BranchFigure) -> anyhow::Result<()> {
    init_font();
    root.fill(&WHITE).map_err(err)?;
    let fin: Vec<&BranchDot> = f
        .points
        .iter()
        .filter(|p| p.x.is_finite() && p.y.is_finite())
        .collect();
    let mm = |k: fn(&BranchDot) -> f64| {
        fin.iter()
            .map(|p| k(p))
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
                (a.min(v), b.max(v))
            })
    };
    let pad = |(lo, hi): (f64, f64)| {
        if !(lo.is_finite() && hi.is_finite()) {
            (-1.0, 1.0)
        } else if hi > lo {
            (lo - 0.05 * (hi - lo), hi + 0.05 * (hi - lo))
        } else {
            (
                lo - 0.05 * lo.abs().max(1e-12),
                hi + 0.05 * hi.abs().max(1e-12),
            )
        }
    };
    let (x0, x1) = pad(mm(|p| p.x));
    let (y0, y1) = pad(mm(|p| p.y));
    let (y0, y1) = (y0.min(0.0).max(y0 - (y1 - y0)), y1);
    let mut chart = ChartBuilder::on(root)
        .caption(f.title, ("sans-serif", 22))
        .margin(15)
        .x_label_area_size(45)
        .y_label_area_size(70)
        .build_cartesian_2d(x0..x1, y0..y1)
        .map_err(err)?;
    chart
        .configure_mesh()
        .x_desc(f.x_label)
        .y_desc("RMS bar displacement (µm)")
        .label_style(("sans-serif", 15))
        .axis_desc_style(("sans-serif", 17))
        .light_line_style(WHITE.mix(0.0))
        .draw()
        .map_err(err)?;
    for w in fin.windows(2) {
        let (a, b) = (w[0], w[1]);
        if a.branch != b.branch {
            continue;
        }
        let col = COLORS[a.branch % COLORS.len()];
        let seg = [(a.x, a.y), (b.x, b.y)];
        if a.stable && b.stable {
            chart
                .draw_series(LineSeries::new(seg, col.stroke_width(2)))
                .map_err(err)?;
        } else {
            chart
                .draw_series(DashedLineSeries::new(seg, 6, 4, col.stroke_width(1)))
                .map_err(err)?;
        }
    }
    for p in fin.iter().filter(|p| p.event.is_some()) {
        let label = p.event.unwrap_or_default();
        chart
            .draw_series(std::iter::once(
                EmptyElement::at((p.x, p.y))
                    + Circle::new((0, 0), 5, BLACK.filled())
                    + Text::new(label.to_string(), (7, -16), ("sans-serif", 14)),
            ))
            .map_err(err)?;
    }
    Ok(())
}

/// Write the figure as `stem.png` and `stem.svg`.
pub fn branch_files(stem: &Path, f: &BranchFigure) -> anyhow::Result<Vec<PathBuf>> {
    png_and_svg!(stem, (1000, 680), |root| draw(&root, f))
}
