//! Figures with plotters (PNG and SVG), using the embedded DejaVu Sans font.

use anyhow::{anyhow, Result};
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::FontStyle;
use std::path::Path;
use std::sync::Once;
use vibrobar_core::State;

use vibrobar_io::csv::write_text;
use vibrobar_io::ensure_parent;

static FONT: &[u8] = include_bytes!("../assets/DejaVuSans.ttf");
static REGISTER: Once = Once::new();

/// Register the embedded font as "sans-serif" (once per process); every figure calls it.
pub fn register_font() {
    REGISTER.call_once(|| {
        // The font is embedded and known to be valid; failure would be a build defect.
        let _ = plotters::style::register_font("sans-serif", FontStyle::Normal, FONT);
    });
}

fn pe<E: std::fmt::Display>(e: E) -> anyhow::Error {
    anyhow!("plotting failed: {e}")
}

/// One curve of a line plot.
#[derive(Debug, Clone)]
pub struct Curve {
    /// Legend label.
    pub label: String,
    /// Points.
    pub points: Vec<(f64, f64)>,
    /// Colour.
    pub color: RGBColor,
    /// Draw markers at the points.
    pub markers: bool,
    /// Dashed (used for reference curves).
    pub dashed: bool,
    /// Line width in px. Keep 1 for dense records: plotters' thick-line polygons of
    /// near-vertical segments overshoot the plot area.
    pub width: u32,
}

/// Render `draw` to `stem.png` and `stem.svg` (each written atomically).
fn render_both(
    stem: &Path,
    size: (u32, u32),
    draw: &dyn Fn(&DrawingArea<SVGBackend, Shift>) -> Result<()>,
    draw_png: &dyn Fn(&DrawingArea<BitMapBackend, Shift>) -> Result<()>,
) -> Result<()> {
    register_font();
    ensure_parent(stem)?;
    let png = with_suffix(stem, ".png");
    let tmp = with_suffix(stem, ".partial.png");
    // plotters writes the bitmap itself: an interrupt must still remove it.
    vibrobar_io::track_partial(&tmp);
    {
        let root = BitMapBackend::new(&tmp, size).into_drawing_area();
        root.fill(&WHITE).map_err(pe)?;
        draw_png(&root)?;
        root.present().map_err(pe)?;
    }
    vibrobar_io::publish(&tmp, &png)?;
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, size).into_drawing_area();
        root.fill(&WHITE).map_err(pe)?;
        draw(&root)?;
        root.present().map_err(pe)?;
    }
    Ok(write_text(&with_suffix(stem, ".svg"), &svg)?)
}

/// `stem` + `suffix` (stems may contain dots, e.g. `gap0.1mm`, so no `with_extension`).
fn with_suffix(stem: &Path, suffix: &str) -> std::path::PathBuf {
    let mut s = stem.as_os_str().to_os_string();
    s.push(suffix);
    s.into()
}

fn range_of(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for v in values.filter(|v| v.is_finite()) {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if !lo.is_finite() {
        return (-1.0, 1.0);
    }
    let pad = ((hi - lo) * 0.06)
        .max(hi.abs().max(lo.abs()) * 1e-3)
        .max(1e-12);
    (lo - pad, hi + pad)
}

/// A line chart with several curves and a legend.
#[allow(clippy::too_many_arguments)]
fn line_chart<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    caption: &str,
    x_label: &str,
    y_label: &str,
    curves: &[Curve],
    hlines: &[f64],
    legend: bool,
    y_floor_zero: bool,
) -> Result<()> {
    let (x0, x1) = range_of(curves.iter().flat_map(|c| c.points.iter().map(|p| p.0)));
    let (mut y0, y1) = range_of(
        curves
            .iter()
            .flat_map(|c| c.points.iter().map(|p| p.1))
            .chain(hlines.iter().copied()),
    );
    if y_floor_zero {
        y0 = 0.0;
    }
    let mut chart = ChartBuilder::on(area)
        .caption(caption, ("sans-serif", 20))
        .margin(12)
        .x_label_area_size(42)
        .y_label_area_size(72)
        .build_cartesian_2d(x0..x1, y0..y1)
        .map_err(pe)?;
    chart
        .configure_mesh()
        .x_desc(x_label)
        .y_desc(y_label)
        .label_style(("sans-serif", 15))
        .axis_desc_style(("sans-serif", 16))
        .x_labels(8)
        .y_labels(7)
        .light_line_style(RGBColor(235, 235, 235))
        .draw()
        .map_err(pe)?;
    for &h in hlines {
        chart
            .draw_series(DashedLineSeries::new(
                vec![(x0, h), (x1, h)],
                6,
                4,
                RED.stroke_width(1),
            ))
            .map_err(pe)?;
    }
    for c in curves {
        let style = c.color.stroke_width(c.width);
        let s = if c.dashed {
            chart
                .draw_series(DashedLineSeries::new(c.points.clone(), 8, 5, style))
                .map_err(pe)?
        } else {
            chart
                .draw_series(LineSeries::new(c.points.clone(), style))
                .map_err(pe)?
        };
        let color = c.color;
        s.label(c.label.clone()).legend(move |(x, y)| {
            PathElement::new(vec![(x, y), (x + 20, y)], color.stroke_width(2))
        });
        if c.markers {
            chart
                .draw_series(
                    c.points
                        .iter()
                        .map(|&p| Circle::new(p, 4, c.color.filled())),
                )
                .map_err(pe)?;
        }
    }
    if legend {
        chart
            .configure_series_labels()
            .label_font(("sans-serif", 15))
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .position(SeriesLabelPosition::UpperRight)
            .draw()
            .map_err(pe)?;
    }
    Ok(())
}

/// Min/max decimation to `bins` columns: keeps every peak of a long oscillating record, so the
/// full-length panels show the true envelope instead of aliasing.
pub fn minmax_decimate(points: &[(f64, f64)], bins: usize) -> Vec<(f64, f64)> {
    if points.len() <= 2 * bins || bins == 0 {
        return points.to_vec();
    }
    let per = points.len().div_ceil(bins);
    let mut out = Vec::with_capacity(2 * bins + 2);
    for chunk in points.chunks(per) {
        let lo = chunk.iter().copied().min_by(|a, b| a.1.total_cmp(&b.1));
        let hi = chunk.iter().copied().max_by(|a, b| a.1.total_cmp(&b.1));
        if let (Some(lo), Some(hi)) = (lo, hi) {
            if lo.0 <= hi.0 {
                out.extend([lo, hi]);
            } else {
                out.extend([hi, lo]);
            }
        }
    }
    out
}

/// Panel caption, axis label, colour, value in plot units, horizontal reference lines.
type Quantity<'a> = (
    &'a str,
    &'a str,
    RGBColor,
    Box<dyn Fn(&State) -> f64>,
    Vec<f64>,
);

/// Fig. 2/4 style: (a) bar displacement, (b) ball displacement, (c) relative displacement with
/// the walls at ±l_g, (d) relative velocity. Left column: the whole run (min/max envelope);
/// right column: the last `zoom_s` seconds, where single impacts are visible.
pub fn time_history(
    stem: &Path,
    title: &str,
    samples: &[State],
    half_gap_m: f64,
    zoom_s: f64,
) -> Result<()> {
    let um = 1e6;
    let t_end = samples.last().map_or(0.0, |s| s.t_s);
    let t_zoom = t_end - zoom_s;
    let quantities: [Quantity; 4] = [
        (
            "(a) Bar displacement u",
            "u (µm)",
            BLUE,
            Box::new(move |s| s.u_m * um),
            vec![],
        ),
        (
            "(b) Ball displacement v",
            "v (µm)",
            RGBColor(0, 128, 0),
            Box::new(move |s| s.v_m * um),
            vec![],
        ),
        (
            "(c) Relative displacement w = v − u, walls ±l_g dashed",
            "w (µm)",
            RGBColor(120, 0, 160),
            Box::new(move |s| s.w_m() * um),
            vec![half_gap_m * um, -half_gap_m * um],
        ),
        (
            "(d) Relative velocity ẇ",
            "ẇ (mm/s)",
            RGBColor(200, 90, 0),
            Box::new(|s| s.dw_m_s() * 1e3),
            vec![],
        ),
    ];
    let mut panels: Vec<(String, String, Vec<Curve>, Vec<f64>)> = Vec::new();
    for (cap, yl, color, f, h) in &quantities {
        let all: Vec<(f64, f64)> = samples.iter().map(|s| (s.t_s, f(s))).collect();
        let curve = |points| {
            vec![Curve {
                label: String::new(),
                points,
                color: *color,
                markers: false,
                dashed: false,
                width: 1,
            }]
        };
        panels.push((
            format!("{cap}: whole run"),
            yl.to_string(),
            curve(minmax_decimate(&all, 1200)),
            h.clone(),
        ));
        panels.push((
            format!("{cap}: last {:.0} ms", zoom_s * 1e3),
            yl.to_string(),
            curve(all.into_iter().filter(|p| p.0 >= t_zoom).collect()),
            h.clone(),
        ));
    }
    fn draw<DB: DrawingBackend>(
        root: &DrawingArea<DB, Shift>,
        title: &str,
        panels: &[(String, String, Vec<Curve>, Vec<f64>)],
    ) -> Result<()> {
        let root = root.titled(title, ("sans-serif", 24)).map_err(pe)?;
        let areas = root.split_evenly((4, 2));
        for (a, (cap, yl, curves, h)) in areas.iter().zip(panels) {
            line_chart(a, cap, "t (s)", yl, curves, h, false, false)?;
        }
        Ok(())
    }
    render_both(stem, (1600, 1800), &|r| draw(r, title, &panels), &|r| {
        draw(r, title, &panels)
    })
}

/// A line plot of several curves (legend on, y from zero), with `hlines` drawn across.
pub fn lines(
    stem: &Path,
    title: &str,
    x_label: &str,
    y_label: &str,
    curves: &[Curve],
    hlines: &[f64],
) -> Result<()> {
    render_both(
        stem,
        (1100, 750),
        &|r| line_chart(r, title, x_label, y_label, curves, hlines, true, true),
        &|r| line_chart(r, title, x_label, y_label, curves, hlines, true, true),
    )
}

/// Fig. 3/5 style: RMS vs ratio, several curves.
pub fn rms_vs_ratio(stem: &Path, title: &str, curves: &[Curve]) -> Result<()> {
    let scaled: Vec<Curve> = curves
        .iter()
        .map(|c| Curve {
            points: c.points.iter().map(|&(x, y)| (x, y * 1e6)).collect(),
            ..c.clone()
        })
        .collect();
    fn draw<DB: DrawingBackend>(
        root: &DrawingArea<DB, Shift>,
        title: &str,
        c: &[Curve],
    ) -> Result<()> {
        line_chart(
            root,
            title,
            "frequency ratio Ω/ωn",
            "RMS bar displacement (µm)",
            c,
            &[],
            true,
            true,
        )
    }
    render_both(stem, (1100, 750), &|r| draw(r, title, &scaled), &|r| {
        draw(r, title, &scaled)
    })
}

/// One panel of [`panels`]: caption, x label, y label, curves.
pub type Panel = (String, String, String, Vec<Curve>);

/// Line panels on a grid of `rows × cols` (e.g. a study against the number of modes), with
/// legends; `stem.png` and `stem.svg`.
pub fn panels(stem: &Path, title: &str, rows: usize, cols: usize, ps: &[Panel]) -> Result<()> {
    fn draw<DB: DrawingBackend>(
        root: &DrawingArea<DB, Shift>,
        title: &str,
        grid: (usize, usize),
        ps: &[Panel],
    ) -> Result<()> {
        let root = root.titled(title, ("sans-serif", 24)).map_err(pe)?;
        let areas = root.split_evenly(grid);
        for (a, (cap, xl, yl, curves)) in areas.iter().zip(ps) {
            line_chart(a, cap, xl, yl, curves, &[], true, false)?;
        }
        Ok(())
    }
    let size = (700 * cols as u32, 480 * rows as u32 + 40);
    render_both(stem, size, &|r| draw(r, title, (rows, cols), ps), &|r| {
        draw(r, title, (rows, cols), ps)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn decimation_keeps_every_extreme_in_time_order() {
        let pts: Vec<(f64, f64)> = (0..10_000)
            .map(|i| {
                let t = i as f64 * 1e-4;
                (t, (t * 600.0 * std::f64::consts::TAU).sin() * (1.0 + t))
            })
            .collect();
        let d = minmax_decimate(&pts, 100);
        assert!(d.len() <= 200);
        assert!(d.windows(2).all(|w| w[0].0 <= w[1].0));
        let max = |v: &[(f64, f64)]| v.iter().map(|p| p.1).fold(f64::MIN, f64::max);
        let min = |v: &[(f64, f64)]| v.iter().map(|p| p.1).fold(f64::MAX, f64::min);
        assert_eq!(max(&d).to_bits(), max(&pts).to_bits());
        assert_eq!(min(&d).to_bits(), min(&pts).to_bits());
        // Short records are left alone.
        assert_eq!(minmax_decimate(&pts[..50], 100), pts[..50].to_vec());
    }
}
