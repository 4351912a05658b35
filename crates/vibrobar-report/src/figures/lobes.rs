//! The figure of `vibrobar lobes`: the stability boundary of regenerative chatter over spindle
//! speed for the damped bar (ball free, ball stuck) and the solid reference, each with its
//! stable side (below the curve) shaded. Drawn like the other figures (plotters, PNG + SVG,
//! published atomically under the output-path policy).
use super::{err, init_font};
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::{Path, PathBuf};
use vibrobar_core::analysis::lobes::LobeRow;

/// The y axis ends at this multiple of the highest of the three curves' minima: the peaks
/// between lobes rise without bound and would flatten the lobes themselves.
const Y_RANGE_OF_MINIMA: f64 = 6.0;

/// A curve ready to draw: label, colour, points (rpm, mm).
type Drawn = (&'static str, RGBColor, Vec<(f64, f64)>);

/// One curve: label, colour, `b_lim` of a row.
type CurveDef = (&'static str, RGBColor, fn(&LobeRow) -> f64);

const CURVES: [CurveDef; 3] = [
    ("solid reference", RGBColor(110, 110, 110), |r| {
        r.solid.b_lim_m
    }),
    ("damped bar, ball free", RGBColor(31, 90, 160), |r| {
        r.ball_free.b_lim_m
    }),
    ("damped bar, ball stuck", RGBColor(220, 110, 20), |r| {
        r.ball_stuck.b_lim_m
    }),
];

fn draw<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    rows: &[LobeRow],
    title: &str,
) -> anyhow::Result<()> {
    init_font();
    root.fill(&WHITE).map_err(err)?;
    let x0 = rows.first().map_or(0.0, |r| r.spindle_rpm);
    let x1 = rows.last().map_or(1.0, |r| r.spindle_rpm);
    let x1 = if x1 > x0 { x1 } else { x0 + 1.0 };
    let y_max = CURVES
        .iter()
        .map(|c| {
            rows.iter()
                .map(|r| c.2(r) * 1e3)
                .fold(f64::INFINITY, f64::min)
        })
        .fold(0.0, f64::max)
        * Y_RANGE_OF_MINIMA;
    let y_max = if y_max.is_finite() && y_max > 0.0 {
        y_max
    } else {
        1.0
    };
    let mut chart = ChartBuilder::on(root)
        .caption(title, ("sans-serif", 22))
        .margin(15)
        .x_label_area_size(45)
        .y_label_area_size(70)
        .build_cartesian_2d(x0..x1, 0.0..y_max)
        .map_err(err)?;
    chart
        .configure_mesh()
        .x_desc("spindle speed (rpm)")
        .y_desc("limiting width of cut b_lim (mm)")
        .x_label_formatter(&|x| format!("{x:.0}"))
        .label_style(("sans-serif", 15))
        .axis_desc_style(("sans-serif", 17))
        .light_line_style(WHITE.mix(0.0))
        .draw()
        .map_err(err)?;
    let curves: Vec<Drawn> = CURVES
        .iter()
        .map(|&(label, col, b)| {
            let pts = rows
                .iter()
                .map(|r| (r.spindle_rpm, (b(r) * 1e3).min(y_max)))
                .collect();
            (label, col, pts)
        })
        .collect();
    for (_, col, pts) in &curves {
        chart
            .draw_series(AreaSeries::new(pts.iter().copied(), 0.0, col.mix(0.12)))
            .map_err(err)?;
    }
    // Damped curves first, the solid reference on top (thinner); each segment drawn alone: a
    // thick polyline's mitred joins spike at the sharp corners between lobes.
    for (label, col, pts) in curves.iter().skip(1).chain(curves.iter().take(1)) {
        let (col, width) = (*col, if *label == CURVES[0].0 { 1 } else { 2 });
        chart
            .draw_series(
                pts.windows(2)
                    .map(|w| PathElement::new(vec![w[0], w[1]], col.stroke_width(width))),
            )
            .map_err(err)?
            .label(format!("{label} (stable below)"))
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 20, y)], col.stroke_width(width))
            });
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .label_font(("sans-serif", 14))
        .draw()
        .map_err(err)?;
    Ok(())
}

/// Draw `STEM.png` and `STEM.svg` beside `csv` (STEM = the CSV path without `.csv`); returns
/// both paths.
pub fn draw_lobes_figure(
    csv: &Path,
    rows: &[LobeRow],
    title: &str,
) -> anyhow::Result<Vec<PathBuf>> {
    let stem = csv.with_extension("");
    png_and_svg!(&stem, (1000, 650), |root| draw(&root, rows, title))
}
