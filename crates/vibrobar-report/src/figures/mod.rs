//! Figures of the design analyses (PNG for viewing, SVG for papers), drawn with plotters and the
//! embedded DejaVu Sans font (no system fonts needed).

/// Draw one figure to `stem.png` and `stem.svg` (`size` in pixels) and return both paths: each
/// drawn to a temporary that an interrupt removes, then published under the output-path policy
/// (atomic, links followed). A macro because plotters' two backends are different types and the
/// `draw` expression is generic over them; `|root|` names the drawing area it is given.
macro_rules! png_and_svg {
    ($stem:expr, $size:expr, |$root:ident| $draw:expr) => {{
        use plotters::prelude::IntoDrawingArea as _;
        let stem: &std::path::Path = $stem;
        let png = $crate::figures::with_ext(stem, "png");
        let svg = $crate::figures::with_ext(stem, "svg");
        let png_tmp = $crate::figures::with_ext(stem, "partial.png");
        let svg_tmp = $crate::figures::with_ext(stem, "partial.svg");
        vibrobar_io::track_partial(&png_tmp);
        vibrobar_io::track_partial(&svg_tmp);
        {
            let $root = plotters::prelude::BitMapBackend::new(&png_tmp, $size).into_drawing_area();
            $draw?;
            $root.present().map_err($crate::figures::err)?;
        }
        vibrobar_io::publish(&png_tmp, &png)?;
        {
            let $root = plotters::prelude::SVGBackend::new(&svg_tmp, $size).into_drawing_area();
            $draw?;
            $root.present().map_err($crate::figures::err)?;
        }
        vibrobar_io::publish(&svg_tmp, &svg)?;
        Ok(vec![png, svg])
    }};
}

pub mod branch;
pub mod fit;
pub mod frf;
pub mod lobe_design;
pub mod lobes;
pub mod map;
pub mod placement;

use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::{Path, PathBuf};

/// Register the embedded font as "sans-serif" (once per process).
pub fn init_font() {
    crate::plot::register_font();
}

/// Error of a drawing call, as text (plotters' errors are generic over the backend).
pub fn err<E: std::fmt::Debug>(e: E) -> anyhow::Error {
    anyhow::anyhow!("drawing failed: {e:?}")
}

/// Viridis, sampled at 9 points and interpolated linearly; `t` in [0, 1].
pub fn viridis(t: f64) -> RGBColor {
    const C: [(u8, u8, u8); 9] = [
        (68, 1, 84),
        (72, 40, 120),
        (62, 73, 137),
        (49, 104, 142),
        (38, 130, 142),
        (31, 158, 137),
        (53, 183, 121),
        (110, 206, 88),
        (253, 231, 37),
    ];
    let t = if t.is_nan() { 0.0 } else { t.clamp(0.0, 1.0) };
    let x = t * 8.0;
    let i = (x.floor() as usize).min(7);
    let f = x - i as f64;
    let lerp = |a: u8, b: u8| (a as f64 + (b as f64 - a as f64) * f).round() as u8;
    RGBColor(
        lerp(C[i].0, C[i + 1].0),
        lerp(C[i].1, C[i + 1].1),
        lerp(C[i].2, C[i + 1].2),
    )
}

/// Contour levels at a "nice" step (1, 2, 2.5, 5 × 10^k) giving about `n` lines inside `(lo, hi)`.
pub fn nice_levels(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    if !(lo.is_finite() && hi.is_finite()) || hi <= lo {
        return Vec::new();
    }
    let raw = (hi - lo) / n.max(1) as f64;
    let mag = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 2.5, 5.0, 10.0]
        .iter()
        .map(|m| m * mag)
        .find(|s| *s >= raw)
        .unwrap_or(10.0 * mag);
    let mut v = Vec::new();
    let mut k = (lo / step).floor() as i64;
    loop {
        let x = k as f64 * step;
        if x >= hi {
            break;
        }
        if x > lo {
            v.push(x);
        }
        k += 1;
    }
    v
}

/// Line segments of the contour `z = level` over a grid of cell centres (marching squares with
/// linear interpolation); `z[i][j]` at `(xs[i], ys[j])`. Cells with a NaN corner are skipped.
pub fn contour_segments(
    xs: &[f64],
    ys: &[f64],
    z: &[Vec<f64>],
    level: f64,
) -> Vec<[(f64, f64); 2]> {
    let mut out = Vec::new();
    for i in 0..xs.len().saturating_sub(1) {
        for j in 0..ys.len().saturating_sub(1) {
            let c = [
                (xs[i], ys[j], z[i][j]),
                (xs[i + 1], ys[j], z[i + 1][j]),
                (xs[i + 1], ys[j + 1], z[i + 1][j + 1]),
                (xs[i], ys[j + 1], z[i][j + 1]),
            ];
            if c.iter().any(|p| p.2.is_nan()) {
                continue;
            }
            let mut pts = Vec::new();
            for k in 0..4 {
                let (a, b) = (c[k], c[(k + 1) % 4]);
                let (da, db) = (a.2 - level, b.2 - level);
                if (da < 0.0) != (db < 0.0) {
                    let t = da / (da - db);
                    pts.push((a.0 + t * (b.0 - a.0), a.1 + t * (b.1 - a.1)));
                }
            }
            match pts.len() {
                2 => out.push([pts[0], pts[1]]),
                4 => {
                    // Saddle: pair by the value at the centre.
                    let centre = c.iter().map(|p| p.2).sum::<f64>() / 4.0;
                    if (centre < level) == (c[0].2 < level) {
                        out.push([pts[0], pts[3]]);
                        out.push([pts[1], pts[2]]);
                    } else {
                        out.push([pts[0], pts[1]]);
                        out.push([pts[2], pts[3]]);
                    }
                }
                _ => {}
            }
        }
    }
    out
}

/// Cell edges around sorted centres (midpoints; the ends extend half a spacing).
pub fn cell_edges(c: &[f64]) -> Vec<f64> {
    if c.len() == 1 {
        let h = if c[0] == 0.0 { 0.5 } else { c[0].abs() * 0.01 };
        return vec![c[0] - h, c[0] + h];
    }
    let mut e = Vec::with_capacity(c.len() + 1);
    e.push(c[0] - (c[1] - c[0]) / 2.0);
    for w in c.windows(2) {
        e.push((w[0] + w[1]) / 2.0);
    }
    let n = c.len();
    e.push(c[n - 1] + (c[n - 1] - c[n - 2]) / 2.0);
    e
}

/// A heat map over x × y with contours and markers.
pub struct Heat<'a> {
    /// Title.
    pub title: &'a str,
    /// x label.
    pub x_label: &'a str,
    /// y label.
    pub y_label: &'a str,
    /// Colour-bar label.
    pub z_label: &'a str,
    /// Sorted x centres.
    pub xs: &'a [f64],
    /// Sorted y centres.
    pub ys: &'a [f64],
    /// `z[i][j]` at `(xs[i], ys[j])`; NaN = no data (grey).
    pub z: &'a [Vec<f64>],
    /// Contour levels.
    pub levels: Vec<f64>,
    /// A level drawn thicker (e.g. 0 % reduction), if inside the range.
    pub strong_level: Option<f64>,
    /// Marked points with their legend label.
    pub markers: Option<(&'a str, Vec<(f64, f64)>)>,
    /// Horizontal lines (y, label, colour).
    pub hlines: Vec<(f64, String, RGBColor)>,
    /// Vertical lines (x, label, colour), e.g. the nodes of a mode.
    pub vlines: Vec<(f64, String, RGBColor)>,
}

/// A curve drawn over a heat map (e.g. a stability boundary from two-parameter continuation).
#[derive(Debug, Clone)]
pub struct HeatCurve {
    /// Legend label (only the first curve of each label is put in the legend).
    pub label: String,
    /// Colour.
    pub colour: RGBColor,
    /// Points `(x, y)` in order; a `NaN` breaks the line.
    pub points: Vec<(f64, f64)>,
    /// Points marked with a square (codimension-two points), with no legend.
    pub marks: Vec<(f64, f64)>,
}

fn draw_heat<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    h: &Heat,
    curves: &[HeatCurve],
) -> anyhow::Result<()> {
    init_font();
    root.fill(&WHITE).map_err(err)?;
    let (w, _) = root.dim_in_pixel();
    let (main, bar) = root.split_horizontally(w as i32 - 130);
    let xe = cell_edges(h.xs);
    let ye = cell_edges(h.ys);
    let finite = h.z.iter().flatten().copied().filter(|v| v.is_finite());
    let (zlo, zhi) = finite.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
        (a.min(v), b.max(v))
    });
    let (zlo, zhi) = if zlo.is_finite() {
        if zhi > zlo {
            (zlo, zhi)
        } else {
            (zlo - 1.0, zhi + 1.0)
        }
    } else {
        (0.0, 1.0)
    };
    let norm = |v: f64| (v - zlo) / (zhi - zlo);
    let mut chart = ChartBuilder::on(&main)
        .caption(h.title, ("sans-serif", 22))
        .margin(12)
        .x_label_area_size(45)
        .y_label_area_size(65)
        .build_cartesian_2d(xe[0]..xe[xe.len() - 1], ye[0]..ye[ye.len() - 1])
        .map_err(err)?;
    chart
        .configure_mesh()
        .disable_mesh()
        .x_desc(h.x_label)
        .y_desc(h.y_label)
        .label_style(("sans-serif", 15))
        .axis_desc_style(("sans-serif", 17))
        .draw()
        .map_err(err)?;
    let mut cells = Vec::new();
    for i in 0..h.xs.len() {
        for j in 0..h.ys.len() {
            let v = h.z[i][j];
            let col = if v.is_finite() {
                viridis(norm(v))
            } else {
                RGBColor(200, 200, 200)
            };
            cells.push(Rectangle::new(
                [(xe[i], ye[j]), (xe[i + 1], ye[j + 1])],
                col.filled(),
            ));
        }
    }
    chart.draw_series(cells).map_err(err)?;
    for &lv in &h.levels {
        let strong = h.strong_level.is_some_and(|s| (s - lv).abs() < 1e-12);
        let style = if strong {
            ShapeStyle::from(&BLACK).stroke_width(3)
        } else {
            ShapeStyle::from(&WHITE.mix(0.8)).stroke_width(1)
        };
        chart
            .draw_series(
                contour_segments(h.xs, h.ys, h.z, lv)
                    .into_iter()
                    .map(|s| PathElement::new(s.to_vec(), style)),
            )
            .map_err(err)?;
    }
    for (y, label, col) in &h.hlines {
        let col = *col;
        chart
            .draw_series(std::iter::once(PathElement::new(
                vec![(xe[0], *y), (xe[xe.len() - 1], *y)],
                col.stroke_width(2),
            )))
            .map_err(err)?
            .label(label.as_str())
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], col.stroke_width(2)));
    }
    for (x, label, col) in &h.vlines {
        let col = *col;
        chart
            .draw_series(std::iter::once(PathElement::new(
                vec![(*x, ye[0]), (*x, ye[ye.len() - 1])],
                col.stroke_width(2),
            )))
            .map_err(err)?
            .label(label.as_str())
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], col.stroke_width(2)));
    }
    if let Some((label, pts)) = &h.markers {
        chart
            .draw_series(pts.iter().map(|&p| {
                EmptyElement::at(p)
                    + Circle::new((0, 0), 5, WHITE.filled())
                    + Circle::new((0, 0), 5, BLACK.stroke_width(1))
            }))
            .map_err(err)?
            .label(*label)
            .legend(|(x, y)| {
                EmptyElement::at((x + 10, y))
                    + Circle::new((0, 0), 5, WHITE.filled())
                    + Circle::new((0, 0), 5, BLACK.stroke_width(1))
            });
    }
    let (x0, x1, y0, y1) = (xe[0], xe[xe.len() - 1], ye[0], ye[ye.len() - 1]);
    let inside = |p: &(f64, f64)| p.0 >= x0 && p.0 <= x1 && p.1 >= y0 && p.1 <= y1;
    let mut labelled: Vec<&str> = Vec::new();
    for c in curves {
        let col = c.colour;
        // Pieces between NaNs and outside the plot.
        let mut pieces: Vec<Vec<(f64, f64)>> = vec![Vec::new()];
        for p in &c.points {
            if p.0.is_finite() && p.1.is_finite() && inside(p) {
                if let Some(v) = pieces.last_mut() {
                    v.push(*p);
                }
            } else if pieces.last().is_some_and(|v| !v.is_empty()) {
                pieces.push(Vec::new());
            }
        }
        let pieces: Vec<Vec<(f64, f64)>> = pieces.into_iter().filter(|v| v.len() > 1).collect();
        if pieces.is_empty() {
            continue;
        }
        let series = chart
            .draw_series(
                pieces
                    .into_iter()
                    .map(|v| PathElement::new(v, col.stroke_width(3))),
            )
            .map_err(err)?;
        if !labelled.contains(&c.label.as_str()) {
            labelled.push(c.label.as_str());
            series.label(c.label.as_str()).legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 20, y)], col.stroke_width(3))
            });
        }
        chart
            .draw_series(c.marks.iter().filter(|p| inside(p)).map(|&p| {
                EmptyElement::at(p)
                    + Rectangle::new([(-5, -5), (5, 5)], WHITE.filled())
                    + Rectangle::new([(-5, -5), (5, 5)], BLACK.stroke_width(2))
            }))
            .map_err(err)?;
    }
    if h.markers.is_some() || !h.hlines.is_empty() || !h.vlines.is_empty() || !labelled.is_empty() {
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperRight)
            .background_style(WHITE.mix(0.7))
            .border_style(BLACK)
            .label_font(("sans-serif", 14))
            .draw()
            .map_err(err)?;
    }
    // Colour bar.
    let mut cb = ChartBuilder::on(&bar)
        .margin_top(45)
        .margin_bottom(57)
        .margin_right(10)
        .y_label_area_size(70)
        .build_cartesian_2d(0.0..1.0, zlo..zhi)
        .map_err(err)?;
    cb.configure_mesh()
        .disable_mesh()
        .disable_x_axis()
        .y_desc(h.z_label)
        .label_style(("sans-serif", 14))
        .axis_desc_style(("sans-serif", 16))
        .draw()
        .map_err(err)?;
    let n = 100;
    cb.draw_series((0..n).map(|k| {
        let a = zlo + (zhi - zlo) * k as f64 / n as f64;
        let b = zlo + (zhi - zlo) * (k + 1) as f64 / n as f64;
        Rectangle::new(
            [(0.0, a), (1.0, b)],
            viridis((k as f64 + 0.5) / n as f64).filled(),
        )
    }))
    .map_err(err)?;
    for &lv in &h.levels {
        cb.draw_series(std::iter::once(PathElement::new(
            vec![(0.0, lv), (1.0, lv)],
            WHITE.stroke_width(1),
        )))
        .map_err(err)?;
    }
    Ok(())
}

/// Write a heat map as `stem.png` and `stem.svg`; returns both paths.
pub fn heat_files(stem: &Path, h: &Heat) -> anyhow::Result<Vec<PathBuf>> {
    heat_files_with_curves(stem, h, &[])
}

/// [`heat_files`] with curves drawn over the map (and in its legend).
pub fn heat_files_with_curves(
    stem: &Path,
    h: &Heat,
    curves: &[HeatCurve],
) -> anyhow::Result<Vec<PathBuf>> {
    png_and_svg!(stem, (1000, 700), |root| draw_heat(&root, h, curves))
}

/// `stem` + `.ext` (keeps dots in the stem).
pub fn with_ext(stem: &Path, ext: &str) -> PathBuf {
    let mut s = stem.as_os_str().to_os_string();
    s.push(".");
    s.push(ext);
    PathBuf::from(s)
}

/// A scatter plot of points (x, y).
pub struct Scatter<'a> {
    /// Title.
    pub title: &'a str,
    /// x label.
    pub x_label: &'a str,
    /// y label.
    pub y_label: &'a str,
    /// Points.
    pub points: &'a [(f64, f64)],
    /// Marker radius in pixels.
    pub radius: u32,
}

fn padded(lo: f64, hi: f64) -> (f64, f64) {
    if !(lo.is_finite() && hi.is_finite()) {
        return (-1.0, 1.0);
    }
    if hi > lo {
        let p = 0.05 * (hi - lo);
        (lo - p, hi + p)
    } else {
        let p = if lo == 0.0 { 1.0 } else { 0.05 * lo.abs() };
        (lo - p, hi + p)
    }
}

fn draw_scatter<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    s: &Scatter,
) -> anyhow::Result<()> {
    init_font();
    root.fill(&WHITE).map_err(err)?;
    let f = |k: fn(&(f64, f64)) -> f64| {
        s.points
            .iter()
            .map(k)
            .filter(|v| v.is_finite())
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
                (a.min(v), b.max(v))
            })
    };
    let (x0, x1) = f(|p| p.0);
    let (y0, y1) = f(|p| p.1);
    let (x0, x1) = padded(x0, x1);
    let (y0, y1) = padded(y0, y1);
    let mut chart = ChartBuilder::on(root)
        .caption(s.title, ("sans-serif", 22))
        .margin(15)
        .x_label_area_size(45)
        .y_label_area_size(70)
        .build_cartesian_2d(x0..x1, y0..y1)
        .map_err(err)?;
    chart
        .configure_mesh()
        .x_desc(s.x_label)
        .y_desc(s.y_label)
        .label_style(("sans-serif", 15))
        .axis_desc_style(("sans-serif", 17))
        .light_line_style(WHITE.mix(0.0))
        .draw()
        .map_err(err)?;
    let col = RGBColor(31, 90, 160);
    chart
        .draw_series(
            s.points
                .iter()
                .filter(|p| p.0.is_finite() && p.1.is_finite())
                .map(|&p| Circle::new(p, s.radius, col.mix(0.7).filled())),
        )
        .map_err(err)?;
    Ok(())
}

/// Write a scatter plot as `stem.png` and `stem.svg`.
pub fn scatter_files(stem: &Path, s: &Scatter) -> anyhow::Result<Vec<PathBuf>> {
    png_and_svg!(stem, (900, 650), |root| draw_scatter(&root, s))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn contour_of_a_plane_is_where_the_plane_crosses_the_level() {
        // z = x + y over a 3 × 3 grid; the level 1.5 crosses x + y = 1.5.
        let xs = [0.0, 1.0, 2.0];
        let ys = [0.0, 1.0, 2.0];
        let z: Vec<Vec<f64>> = xs
            .iter()
            .map(|x| ys.iter().map(|y| x + y).collect())
            .collect();
        let segs = contour_segments(&xs, &ys, &z, 1.5);
        assert!(!segs.is_empty());
        for s in segs {
            for (x, y) in s {
                assert!((x + y - 1.5).abs() < 1e-12, "({x}, {y})");
            }
        }
    }

    #[test]
    fn nice_levels_are_inside_and_evenly_spaced() {
        let v = nice_levels(-12.0, 83.0, 10);
        assert_eq!(v.first().copied(), Some(-10.0));
        assert_eq!(v.last().copied(), Some(80.0));
        assert!(v.windows(2).all(|w| (w[1] - w[0] - 10.0).abs() < 1e-9));
    }

    #[test]
    fn cell_edges_bracket_centres() {
        assert_eq!(cell_edges(&[1.0, 2.0, 4.0]), vec![0.5, 1.5, 3.0, 5.0]);
        assert_eq!(cell_edges(&[2.0]).len(), 2);
    }
}
