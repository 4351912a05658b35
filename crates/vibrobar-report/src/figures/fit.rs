//! The stabilisation chart of a modal fit: every LSCF pole by frequency and model order, the
//! stable ones filled, the others hollow, the modes taken marked by vertical lines.

use super::err;
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::{Path, PathBuf};

/// What the chart shows.
pub struct StabilisationChart<'a> {
    /// Title.
    pub title: &'a str,
    /// Stable poles, `(frequency Hz, model order)`.
    pub stable: &'a [(f64, f64)],
    /// The other poles.
    pub unstable: &'a [(f64, f64)],
    /// Frequencies of the modes taken, Hz.
    pub picked_hz: &'a [f64],
    /// The band, Hz.
    pub band_hz: (f64, f64),
}

fn draw<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    c: &StabilisationChart,
) -> anyhow::Result<()> {
    super::init_font();
    root.fill(&WHITE).map_err(err)?;
    let top = c
        .stable
        .iter()
        .chain(c.unstable)
        .map(|p| p.1)
        .fold(2.0, f64::max)
        + 2.0;
    let mut chart = ChartBuilder::on(root)
        .caption(c.title, ("sans-serif", 22))
        .margin(15)
        .x_label_area_size(45)
        .y_label_area_size(60)
        .build_cartesian_2d(c.band_hz.0..c.band_hz.1, 0.0..top)
        .map_err(err)?;
    chart
        .configure_mesh()
        .x_desc("frequency (Hz)")
        .y_desc("model order")
        .label_style(("sans-serif", 15))
        .axis_desc_style(("sans-serif", 17))
        .light_line_style(WHITE.mix(0.0))
        .draw()
        .map_err(err)?;
    let grey = RGBColor(150, 150, 150);
    let blue = RGBColor(31, 90, 160);
    let red = RGBColor(200, 40, 40);
    for &f in c.picked_hz {
        chart
            .draw_series(LineSeries::new([(f, 0.0), (f, top)], red.mix(0.6)))
            .map_err(err)?;
    }
    chart
        .draw_series(c.unstable.iter().map(|&p| Circle::new(p, 3, grey)))
        .map_err(err)?
        .label("not stable")
        .legend(move |(x, y)| Circle::new((x + 10, y), 3, grey));
    chart
        .draw_series(c.stable.iter().map(|&p| Circle::new(p, 4, blue.filled())))
        .map_err(err)?
        .label("stable (frequency and damping)")
        .legend(move |(x, y)| Circle::new((x + 10, y), 4, blue.filled()));
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .label_font(("sans-serif", 15))
        .draw()
        .map_err(err)?;
    Ok(())
}

/// Write the chart as `stem.png` and `stem.svg`.
pub fn stabilisation_files(stem: &Path, c: &StabilisationChart) -> anyhow::Result<Vec<PathBuf>> {
    png_and_svg!(stem, (1000, 700), |root| draw(&root, c))
}
