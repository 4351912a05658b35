//! Figures of a design map: the reduction heat map (ratio × gap, with contour lines, the best gap
//! per ratio and the best gaps over the band) and the impacts-per-cycle map.
//!
//! With optional axes (friction level, restitution, mass ratio) each ratio × gap cell shows the
//! best reduction over those axes (and the impacts per cycle of that best point).
use super::{heat_files, nice_levels, Heat};
use plotters::style::RGBColor;
use std::path::{Path, PathBuf};
use vibrobar_core::analysis::map::{Axis, Optimum};
use vibrobar_io::csv::MapTable;

fn sorted_unique(mut v: Vec<f64>) -> Vec<f64> {
    v.sort_by(f64::total_cmp);
    v.dedup_by(|a, b| a.total_cmp(b).is_eq());
    v
}

/// Draw `STEM.reduction.{png,svg}` and `STEM.impacts.{png,svg}` beside `map_csv`
/// (STEM = the CSV path without `.csv`).
pub fn draw_map_figures(map_csv: &Path, t: &MapTable, o: &Optimum) -> anyhow::Result<Vec<PathBuf>> {
    draw_map_figures_with(map_csv, t, o, &[])
}

/// [`draw_map_figures`] with `curves` (e.g. the stability boundary of the symmetric orbit, gap
/// in mm) drawn over the reduction map.
pub fn draw_map_figures_with(
    map_csv: &Path,
    t: &MapTable,
    o: &Optimum,
    curves: &[super::HeatCurve],
) -> anyhow::Result<Vec<PathBuf>> {
    let stem = map_csv.with_extension("");
    let xs = sorted_unique(t.rows.iter().map(|r| r.ratio).collect());
    let ys = sorted_unique(t.rows.iter().map(|r| r.gap_m * 1e3).collect());
    let mut red = vec![vec![f64::NAN; ys.len()]; xs.len()];
    let mut ipc = vec![vec![f64::NAN; ys.len()]; xs.len()];
    for r in &t.rows {
        let i = xs
            .binary_search_by(|x| x.total_cmp(&r.ratio))
            .expect("listed");
        let j = ys
            .binary_search_by(|y| y.total_cmp(&(r.gap_m * 1e3)))
            .expect("listed");
        // Best over the optional axes (NaN loses).
        if red[i][j].is_nan() || r.reduction_pct > red[i][j] {
            red[i][j] = r.reduction_pct;
            ipc[i][j] = r.impacts_per_cycle;
        }
    }
    let finite = |z: &Vec<Vec<f64>>| {
        z.iter()
            .flatten()
            .copied()
            .filter(|v| v.is_finite())
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
                (a.min(v), b.max(v))
            })
    };
    let (lo, hi) = finite(&red);
    let mut levels = nice_levels(lo, hi, 8);
    if lo < 0.0 && hi > 0.0 && !levels.iter().any(|l| l.abs() < 1e-12) {
        levels.push(0.0);
    }
    let gap_of = |d: &[(Axis, f64)]| d.iter().find(|(a, _)| *a == Axis::GapM).map(|x| x.1 * 1e3);
    let mut hlines = Vec::new();
    let fmt = vibrobar_io::csv::fmt_coord;
    let mean = o
        .best_mean_reduction
        .as_ref()
        .and_then(|b| gap_of(&b.design));
    let minimax = o.best_minimax_rms.as_ref().and_then(|b| gap_of(&b.design));
    match (mean, minimax) {
        (Some(a), Some(b)) if a.total_cmp(&b).is_eq() => hlines.push((
            a,
            format!(
                "best gap for the band, mean reduction and minimax RMS ({} mm)",
                fmt(a)
            ),
            RGBColor(230, 60, 40),
        )),
        _ => {
            if let Some(g) = mean {
                hlines.push((
                    g,
                    format!("best gap for the band, mean reduction ({} mm)", fmt(g)),
                    RGBColor(230, 60, 40),
                ));
            }
            if let Some(g) = minimax {
                hlines.push((
                    g,
                    format!("best gap for the band, minimax RMS ({} mm)", fmt(g)),
                    RGBColor(250, 160, 30),
                ));
            }
        }
    }
    let base = if t.extra.is_empty() {
        "RMS reduction vs solid bar".to_string()
    } else {
        "RMS reduction vs solid bar (best over the other axes)".to_string()
    };
    // Say which model made the map: friction law, its level and the solver, from the metadata.
    let title = match vibrobar_io::Metadata::read_beside(map_csv) {
        Ok(m) => {
            let p = &m.parameters;
            let friction = p["friction"].as_str().unwrap_or("?");
            let level = match p["friction_force_n"].as_f64() {
                Some(f) => format!(" {f} N"),
                None if friction == "none" => String::new(),
                None => " η/r·m_d·g".to_string(),
            };
            let solver = p["solver"].as_str().unwrap_or("?");
            format!("{base} — friction {friction}{level}, {solver}")
        }
        Err(_) => base,
    };
    let mut files = super::heat_files_with_curves(
        &super::with_ext(&stem, "reduction"),
        &Heat {
            title: &title,
            x_label: "frequency ratio Ω/ωn",
            y_label: "gap (mm)",
            z_label: "reduction (%)",
            xs: &xs,
            ys: &ys,
            z: &red,
            levels,
            strong_level: Some(0.0),
            markers: Some((
                "best gap at each ratio",
                o.per_ratio
                    .iter()
                    .map(|r| (r.ratio, r.gap_m * 1e3))
                    .collect(),
            )),
            hlines,
            vlines: Vec::new(),
        },
        curves,
    )?;
    let (lo, hi) = finite(&ipc);
    let levels = if hi - lo <= 8.0 {
        (lo.floor() as i64..=hi.ceil() as i64)
            .map(|k| k as f64)
            .filter(|&k| k > lo && k < hi)
            .collect()
    } else {
        nice_levels(lo, hi, 8)
    };
    files.extend(heat_files(
        &super::with_ext(&stem, "impacts"),
        &Heat {
            title: "Impacts per forcing cycle (steady state)",
            x_label: "frequency ratio Ω/ωn",
            y_label: "gap (mm)",
            z_label: "impacts per cycle",
            xs: &xs,
            ys: &ys,
            z: &ipc,
            levels,
            strong_level: None,
            markers: None,
            hlines: Vec::new(),
            vlines: Vec::new(),
        },
    )?);
    Ok(files)
}
