//! The figure of `vibrobar frf`: magnitude (log scale) above, phase below, of several FRFs
//! overlaid over frequency. Drawn like the other figures (plotters, PNG + SVG, published
//! atomically under the output-path policy).
use super::{err, init_font};
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::{Path, PathBuf};
use vibrobar_core::analysis::frf::FrfCurve;

const COLOURS: [RGBColor; 6] = [
    RGBColor(110, 110, 110),
    RGBColor(31, 90, 160),
    RGBColor(220, 110, 20),
    RGBColor(40, 150, 60),
    RGBColor(200, 40, 60),
    RGBColor(120, 60, 160),
];

/// The legend label of a curve.
fn label(name: &str) -> &str {
    match name {
        "solid" => "solid reference",
        "ball_free" => "damped bar, ball free",
        "ball_stuck" => "damped bar, ball stuck",
        "stepped_sine" => "stepped sine (first harmonic)",
        "tap" => "tap test (H1)",
        other => other,
    }
}

fn draw<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    lines_hz: &[f64],
    curves: &[FrfCurve],
    title: &str,
) -> anyhow::Result<()> {
    init_font();
    root.fill(&WHITE).map_err(err)?;
    let root = root.titled(title, ("sans-serif", 22)).map_err(err)?;
    let (top, bottom) = root.split_vertically((58).percent());
    let x0 = lines_hz.first().copied().unwrap_or(0.0);
    let x1 = lines_hz.last().copied().unwrap_or(1.0);
    let x1 = if x1 > x0 { x1 } else { x0 + 1.0 };
    let mags = curves
        .iter()
        .flat_map(|c| c.values_m_per_n.iter().map(|g| g.norm()))
        .filter(|m| m.is_finite() && *m > 0.0);
    let (lo, hi) = mags.fold((f64::INFINITY, 0.0f64), |(a, b), m| (a.min(m), b.max(m)));
    let (lo, hi) = if lo.is_finite() && hi > 0.0 {
        (lo / 2.0, hi * 2.0)
    } else {
        (1e-12, 1.0)
    };
    let mut mag = ChartBuilder::on(&top)
        .margin(12)
        .x_label_area_size(30)
        .y_label_area_size(80)
        .build_cartesian_2d(x0..x1, (lo..hi).log_scale())
        .map_err(err)?;
    mag.configure_mesh()
        .y_desc("|G| (m/N)")
        .y_label_formatter(&|y| format!("{y:.0e}"))
        .x_label_formatter(&|x| format!("{x:.0}"))
        .label_style(("sans-serif", 14))
        .axis_desc_style(("sans-serif", 16))
        .light_line_style(WHITE.mix(0.0))
        .draw()
        .map_err(err)?;
    for (k, c) in curves.iter().enumerate() {
        let col = COLOURS[k % COLOURS.len()];
        let pts: Vec<(f64, f64)> = lines_hz
            .iter()
            .zip(&c.values_m_per_n)
            .map(|(&f, g)| (f, g.norm().max(lo)))
            .collect();
        let width = if c.name == "solid" { 1 } else { 2 };
        mag.draw_series(LineSeries::new(pts, col.stroke_width(width)))
            .map_err(err)?
            .label(label(c.name))
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 20, y)], col.stroke_width(width))
            });
    }
    mag.configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .label_font(("sans-serif", 14))
        .draw()
        .map_err(err)?;
    let mut phase = ChartBuilder::on(&bottom)
        .margin(12)
        .x_label_area_size(45)
        .y_label_area_size(80)
        .build_cartesian_2d(x0..x1, -180.0..180.0)
        .map_err(err)?;
    phase
        .configure_mesh()
        .x_desc("frequency (Hz)")
        .y_desc("phase (deg)")
        .x_label_formatter(&|x| format!("{x:.0}"))
        .y_labels(9)
        .y_label_formatter(&|y| format!("{y:.0}"))
        .label_style(("sans-serif", 14))
        .axis_desc_style(("sans-serif", 16))
        .light_line_style(WHITE.mix(0.0))
        .draw()
        .map_err(err)?;
    for (k, c) in curves.iter().enumerate() {
        let col = COLOURS[k % COLOURS.len()];
        let width = if c.name == "solid" { 1 } else { 2 };
        // Phase as markers joined only where it does not wrap (a ±180° jump is no line).
        let pts: Vec<(f64, f64)> = lines_hz
            .iter()
            .zip(&c.values_m_per_n)
            .map(|(&f, g)| (f, g.arg().to_degrees()))
            .collect();
        phase
            .draw_series(
                pts.windows(2)
                    .filter(|w| (w[1].1 - w[0].1).abs() < 180.0)
                    .map(|w| PathElement::new(vec![w[0], w[1]], col.stroke_width(width))),
            )
            .map_err(err)?;
    }
    Ok(())
}

/// Draw `STEM.png` and `STEM.svg` beside `csv` (STEM = the CSV path without `.csv`); returns
/// both paths.
pub fn draw_frf_figure(
    csv: &Path,
    lines_hz: &[f64],
    curves: &[FrfCurve],
    title: &str,
) -> anyhow::Result<Vec<PathBuf>> {
    let stem = csv.with_extension("");
    png_and_svg!(&stem, (1000, 800), |root| draw(
        &root, lines_hz, curves, title
    ))
}
