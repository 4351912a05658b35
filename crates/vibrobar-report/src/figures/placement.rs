//! The figure of a cavity-placement study: the mean reduction over the band as a heat map of
//! cavity position × gap, with the nodes of modes 2 and 3 of the damped bar (vertical lines: a
//! cavity there has no share in that mode) and the optimum marked.
use super::{heat_files, nice_levels, Heat};
use plotters::style::RGBColor;
use std::path::{Path, PathBuf};
use vibrobar_core::analysis::placement::PlacementRow;

fn sorted_unique(mut v: Vec<f64>) -> Vec<f64> {
    v.sort_by(f64::total_cmp);
    v.dedup_by(|a, b| a.total_cmp(b).is_eq());
    v
}

/// Draw `STEM.reduction.{png,svg}` beside `csv` (STEM = the CSV path without `.csv`).
/// `nodes` are `(mode, node positions from the clamp in m)`; `title` says which model made it.
pub fn draw_placement_figure(
    csv: &Path,
    rows: &[PlacementRow],
    best: Option<&PlacementRow>,
    nodes: &[(usize, Vec<f64>)],
    title: &str,
) -> anyhow::Result<Vec<PathBuf>> {
    let stem = csv.with_extension("");
    let xs = sorted_unique(rows.iter().map(|r| r.point.position_m * 1e3).collect());
    let ys = sorted_unique(rows.iter().map(|r| r.point.gap_m * 1e3).collect());
    let mut z = vec![vec![f64::NAN; ys.len()]; xs.len()];
    for r in rows {
        let i = xs
            .binary_search_by(|x| x.total_cmp(&(r.point.position_m * 1e3)))
            .expect("listed");
        let j = ys
            .binary_search_by(|y| y.total_cmp(&(r.point.gap_m * 1e3)))
            .expect("listed");
        z[i][j] = r.mean_reduction_pct;
    }
    let (lo, hi) = z
        .iter()
        .flatten()
        .copied()
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
            (a.min(v), b.max(v))
        });
    let mut levels = nice_levels(lo, hi, 8);
    if lo < 0.0 && hi > 0.0 && !levels.iter().any(|l| l.abs() < 1e-12) {
        levels.push(0.0);
    }
    // Only the nodes inside the plotted positions (a line outside would leave the frame).
    let edges = super::cell_edges(&xs);
    let (x_lo, x_hi) = (edges[0], edges[edges.len() - 1]);
    let colours = [RGBColor(230, 60, 40), RGBColor(250, 160, 30)];
    let mut vlines = Vec::new();
    for (k, (mode, xs_m)) in nodes.iter().enumerate() {
        for x in xs_m {
            let mm = x * 1e3;
            if mm >= x_lo && mm <= x_hi {
                vlines.push((
                    mm,
                    format!("node of mode {mode} ({mm:.1} mm)"),
                    colours[k % colours.len()],
                ));
            }
        }
    }
    let marker = best.map(|b| {
        (
            format!(
                "optimum: {} mm, gap {} mm, {:.1} % mean reduction",
                vibrobar_io::csv::fmt_coord(b.point.position_m * 1e3),
                vibrobar_io::csv::fmt_coord(b.point.gap_m * 1e3),
                b.mean_reduction_pct
            ),
            vec![(b.point.position_m * 1e3, b.point.gap_m * 1e3)],
        )
    });
    heat_files(
        &super::with_ext(&stem, "reduction"),
        &Heat {
            title,
            x_label: "cavity position from the clamp (mm)",
            y_label: "gap (mm)",
            z_label: "mean reduction over the band (%)",
            xs: &xs,
            ys: &ys,
            z: &z,
            levels,
            strong_level: Some(0.0),
            markers: marker.as_ref().map(|(l, p)| (l.as_str(), p.clone())),
            hlines: Vec::new(),
            vlines,
        },
    )
}
