//! The figure of a design study by time-domain lobes: the worst-case acceptable width over the
//! band of spindle speeds as a heat map of gap × ball mass (lumped bar) or gap × cavity position
//! (beam), the solid bar's worst case as the thick contour (inside it the damper gains) and the
//! optimum marked.
use super::{heat_files, nice_levels, Heat};
use std::path::{Path, PathBuf};
use vibrobar_core::analysis::lobe_design::{optimum, DesignAxis, DesignRow};

fn sorted_unique(mut v: Vec<f64>) -> Vec<f64> {
    v.sort_by(f64::total_cmp);
    v.dedup_by(|a, b| a.total_cmp(b).is_eq());
    v
}

/// Draw `STEM.{png,svg}` beside `csv` (STEM = the CSV path without `.csv`) from its rows.
pub fn draw_lobe_design_figure(
    csv: &Path,
    axis: DesignAxis,
    rows: &[DesignRow],
) -> anyhow::Result<Vec<PathBuf>> {
    // Display units: gap in mm, mass in g, position in mm, widths in µm.
    let (y_scale, y_label, y_unit) = match axis {
        DesignAxis::BallMass => (1e3, "ball mass (g)", "g"),
        DesignAxis::Position => (1e3, "cavity position from the clamp (mm)", "mm"),
    };
    let xs = sorted_unique(rows.iter().map(|r| r.point.gap_m * 1e3).collect());
    let ys = sorted_unique(rows.iter().map(|r| r.point.value * y_scale).collect());
    let mut z = vec![vec![f64::NAN; ys.len()]; xs.len()];
    for r in rows {
        let i = xs
            .binary_search_by(|x| x.total_cmp(&(r.point.gap_m * 1e3)))
            .expect("listed");
        let j = ys
            .binary_search_by(|y| y.total_cmp(&(r.point.value * y_scale)))
            .expect("listed");
        z[i][j] = r.damped.worst_width_m * 1e6;
    }
    let (lo, hi) = z
        .iter()
        .flatten()
        .copied()
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
            (a.min(v), b.max(v))
        });
    let solid = rows.first().map(|r| r.solid.worst_width_m * 1e6);
    let mut levels = nice_levels(lo, hi, 8);
    if let Some(s) = solid.filter(|s| *s > lo && *s < hi) {
        levels.push(s);
    }
    let best = optimum(rows);
    let marker = best.map(|b| {
        (
            format!(
                "optimum: gap {} mm, {} {y_unit}: worst {:.2} µm{}",
                vibrobar_io::csv::fmt_coord(b.point.gap_m * 1e3),
                vibrobar_io::csv::fmt_coord(b.point.value * y_scale),
                b.damped.worst_width_m * 1e6,
                b.worst_gain()
                    .map_or(String::new(), |g| format!(" ({g:.2}× the solid bar)"))
            ),
            vec![(b.point.gap_m * 1e3, b.point.value * y_scale)],
        )
    });
    let title = format!(
        "Worst-case width over the band, large disturbance (thick: solid bar, {} µm)",
        solid.map_or("—".into(), |s| format!("{s:.2}"))
    );
    heat_files(
        &csv.with_extension(""),
        &Heat {
            title: &title,
            x_label: "gap (mm)",
            y_label,
            z_label: "worst-case width of cut over the band (µm)",
            xs: &xs,
            ys: &ys,
            z: &z,
            levels,
            strong_level: solid,
            markers: marker.as_ref().map(|(l, p)| (l.as_str(), p.clone())),
            hlines: Vec::new(),
            vlines: Vec::new(),
        },
    )
}
