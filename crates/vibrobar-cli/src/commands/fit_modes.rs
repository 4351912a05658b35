//! `vibrobar fit-modes`: `[[modes]]` from a measured FRF (a tap test at the tool tip).
//!
//! Reads the FRF (universal file 58/58b or plain columns), fits it (LSCF poles with a
//! stabilisation chart, LSFD residues, nonlinear refinement: `vibrobar_core::structure::fit`),
//! and writes the modes that pass `[[modes]]` validation as TOML, with the stabilisation chart
//! and the measured-against-fitted FRF beside them (CSV and figures).

use anyhow::{bail, Context, Result};
use clap::Args;
use std::f64::consts::PI;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use vibrobar_core::structure::fit::{self, FitSettings, FrfLines, ModalFit};
use vibrobar_core::structure::frf_data::{FrfKind, MeasuredFrf};
use vibrobar_core::structure::MeasuredMode;
use vibrobar_io::csv::write_text;
use vibrobar_io::frf::{read_frf, ColumnLayout, FrfReadOptions, PLAIN_UNITS};

/// `vibrobar fit-modes`.
#[derive(Debug, Args)]
pub struct FitModesArgs {
    /// The driving-point FRF at the tool tip: a universal file (dataset 58 or 58b, units from
    /// dataset 164 or its labels) or plain columns (frequency in Hz, then re/im or mag/phase).
    /// The modes describe the bar WITHOUT the ball: tap it with the ball removed, or locked with
    /// its mass subtracted.
    #[arg(long, value_name = "FILE")]
    pub frf: PathBuf,
    /// A cross FRF between the cavity and the tip (tap at the cavity, response at the tip, or
    /// the reverse): gives each mode's shape at the cavity. Same lines and kind as --frf.
    #[arg(long, value_name = "FILE")]
    pub cross: Option<PathBuf>,
    /// Units of plain columns (also gives the kind): m/N, mm/N, µm/N, in/lbf, (m/s)/N,
    /// (m/s²)/N or g/N [default: SI of the kind].
    #[arg(long, value_name = "UNITS")]
    pub units: Option<String>,
    /// The FRF's kind where the file does not say: receptance, mobility or accelerance.
    #[arg(long, value_name = "KIND")]
    pub frf_type: Option<String>,
    /// Layout of plain columns without a header: re-im, mag-deg or mag-rad.
    #[arg(long, value_name = "LAYOUT", default_value = "re-im")]
    pub frf_columns: String,
    /// Which FRF record of a universal file (1-based), where it holds several pairs.
    #[arg(long, value_name = "N")]
    pub frf_record: Option<usize>,
    /// The band to fit, LOW:HIGH in Hz [default: the whole record].
    #[arg(long, value_name = "LOW:HIGH")]
    pub band_hz: Option<String>,
    /// Highest LSCF model order (even; poles counting conjugates), at most 200 and below the
    /// number of lines in the band.
    #[arg(long, value_name = "N", default_value_t = 40)]
    pub max_order: usize,
    /// Orders at which a pole must be stable (frequency within 1 %, damping within 5 % of the
    /// lower order's, damping > 0) to count as a mode.
    #[arg(long, value_name = "N", default_value_t = 4)]
    pub min_stable_orders: usize,
    /// Take the stable poles nearest these frequencies (Hz, comma-separated) instead of the
    /// automatic choice.
    #[arg(long, value_name = "F1,F2,...", value_delimiter = ',')]
    pub poles_hz: Option<Vec<f64>>,
    /// Fit a lower residual (modes below the band; off: a clamped bar has no rigid-body mode).
    #[arg(long)]
    pub lower_residual: bool,
    /// Skip the upper residual (modes above the band).
    #[arg(long)]
    pub no_upper_residual: bool,
    /// Turn the upper residual into a pseudo-mode at this frequency (Hz, above the band) and
    /// write it with the modes.
    #[arg(long, value_name = "HZ")]
    pub pseudo_mode_hz: Option<f64>,
    /// Skip the nonlinear refinement of poles and residues (LSCF and LSFD only).
    #[arg(long)]
    pub no_refine: bool,
    /// Without --cross: the bar's length (mm), with --cavity-from-clamp-mm, for the cavity
    /// shape of a uniform clamped–free bar (mode k of the fit taken as bending mode k).
    #[arg(long, value_name = "MM")]
    pub length_mm: Option<f64>,
    /// Without --cross: the cavity centre's distance from the clamp (mm), with --length-mm.
    #[arg(long, value_name = "MM")]
    pub cavity_from_clamp_mm: Option<f64>,
    /// Output TOML with the `[[modes]]` tables; beside it FILE.stabilisation.csv/.png/.svg and
    /// FILE.fit.csv/.png/.svg (measured against fitted).
    #[arg(long, value_name = "FILE.toml")]
    pub out: PathBuf,
}

/// The input files of the command (never overwritten by its outputs).
pub fn inputs(a: &FitModesArgs) -> Vec<&Path> {
    let mut v = vec![a.frf.as_path()];
    if let Some(c) = &a.cross {
        v.push(c.as_path());
    }
    v
}

fn read(path: &Path, a: &FitModesArgs, cross: bool) -> Result<(MeasuredFrf, Vec<String>)> {
    let kind = match &a.frf_type {
        Some(k) => Some(FrfKind::parse(k).with_context(|| {
            format!("--frf-type {k:?} is not one of receptance, mobility, accelerance")
        })?),
        None => None,
    };
    let columns = ColumnLayout::parse(&a.frf_columns).with_context(|| {
        format!(
            "--frf-columns {:?} is not one of re-im, mag-deg, mag-rad",
            a.frf_columns
        )
    })?;
    let opts = FrfReadOptions {
        units: a.units.clone(),
        kind,
        columns,
        record: a.frf_record,
        cross,
        ..FrfReadOptions::default()
    };
    let r = read_frf(path, &opts).with_context(|| {
        format!(
            "reading {} (plain-column units: {PLAIN_UNITS})",
            path.display()
        )
    })?;
    // The fit needs positive frequencies: a 0 Hz line (DC) carries no modal information.
    let frf = if r.frf.freqs_hz[0] == 0.0 {
        r.frf
            .without_zero_frequency()
            .map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?
    } else {
        r.frf
    };
    Ok((frf, r.notes))
}

fn parse_band(s: &str) -> Result<(f64, f64)> {
    let (a, b) = s
        .split_once(':')
        .with_context(|| format!("--band-hz {s:?}: expected LOW:HIGH in Hz"))?;
    let p = |x: &str| -> Result<f64> {
        let v: f64 = x
            .trim()
            .parse()
            .with_context(|| format!("--band-hz {s:?}: {x:?} is not a number"))?;
        if !(v.is_finite() && v > 0.0) {
            bail!("--band-hz = {v} is outside the allowed range (0, ∞) Hz");
        }
        Ok(v)
    };
    Ok((p(a)?, p(b)?))
}

/// Run the command.
pub fn run(a: &FitModesArgs) -> Result<()> {
    if a.max_order > fit::MAX_MODEL_ORDER {
        bail!(
            "--max-order = {} is outside the allowed range [2, {}]",
            a.max_order,
            fit::MAX_MODEL_ORDER
        );
    }
    if a.min_stable_orders == 0 {
        bail!("--min-stable-orders = 0 is outside the allowed range [1, --max-order/2]");
    }
    if a.cross.is_some() && (a.length_mm.is_some() || a.cavity_from_clamp_mm.is_some()) {
        bail!("--length-mm and --cavity-from-clamp-mm give the cavity shape without --cross; with --cross the shape comes from the cross FRF: drop one");
    }
    if a.length_mm.is_some() != a.cavity_from_clamp_mm.is_some() {
        bail!("--length-mm and --cavity-from-clamp-mm go together");
    }
    let band_hz = a.band_hz.as_deref().map(parse_band).transpose()?;
    let (frf, mut notes) = read(&a.frf, a, false)?;
    let cross = match &a.cross {
        Some(p) => {
            let (c, n) = read(p, a, true)?;
            if c.freqs_hz != frf.freqs_hz || c.kind != frf.kind {
                bail!(
                    "--cross {}: its lines and kind must be those of --frf {} ({} lines of {}; the cross has {} lines of {})",
                    p.display(),
                    a.frf.display(),
                    frf.len(),
                    frf.kind.name(),
                    c.len(),
                    c.kind.name()
                );
            }
            notes.extend(n.into_iter().map(|s| format!("cross: {s}")));
            Some(c)
        }
        None => None,
    };
    let settings = FitSettings {
        band_hz,
        max_order: a.max_order,
        min_stable_orders: a.min_stable_orders,
        poles_hz: a.poles_hz.clone(),
        upper_residual: !a.no_upper_residual,
        lower_residual: a.lower_residual,
        refine: !a.no_refine,
        ..FitSettings::default()
    };
    let d = FrfLines::from(&frf);
    let c = cross.as_ref().map(|c| FrfLines {
        weights: d.weights,
        ..FrfLines::from(c)
    });
    let r = fit::fit_modes(&d, c.as_ref(), &settings)?;

    // The modes to write: those that pass [[modes]] validation.
    let mut warnings: Vec<String> = Vec::new();
    let mut written: Vec<(MeasuredMode, String)> = Vec::new();
    for (k, m) in r.modes.iter().enumerate() {
        let shape = match (m.shape_cavity, a.length_mm, a.cavity_from_clamp_mm) {
            (Some(s), _, _) => s,
            (None, Some(l), Some(x)) => fit::uniform_beam_shape(k + 1, x * 1e-3, l * 1e-3)?,
            _ => 1.0,
        };
        let mode = MeasuredMode {
            frequency_hz: m.frequency_hz,
            damping_ratio: m.damping_ratio,
            modal_mass_kg: m.modal_mass_kg,
            shape_cavity: shape,
            direction_deg: None,
        };
        if let Err(e) = mode.validate() {
            warnings.push(format!(
                "mode at {:.6} Hz not written: {e} (negative damping or mass: not a mode of a passive bar)",
                m.frequency_hz
            ));
            continue;
        }
        written.push((
            mode,
            format!(
                "LSCF order {}, residue phase {:.1}°, FRAC {:.4}, MPC {:.4}",
                m.order, m.residue_phase_deg, m.frac, m.mpc
            ),
        ));
    }
    if cross.is_none() && a.length_mm.is_none() {
        warnings.push("no --cross and no --length-mm/--cavity-from-clamp-mm: shape_cavity = 1 (the ball at the tip); give one of them for the real cavity".into());
    }
    if let Some(fp) = a.pseudo_mode_hz {
        if !(fp.is_finite() && fp > r.chart.band_hz.1) {
            bail!(
                "--pseudo-mode-hz = {fp} is outside the allowed range ({}, ∞) Hz (above the band)",
                r.chart.band_hz.1
            );
        }
        match r.pseudo_mode(fp) {
            Some(p) => written.push((
                p,
                "pseudo-mode standing in for the modes above the band (the upper residual), not a measured mode".into(),
            )),
            None => warnings.push(format!(
                "--pseudo-mode-hz: the upper residual is {:.3e} m/N, not positive: no pseudo-mode written",
                r.upper_residual
            )),
        }
    }
    if written.is_empty() {
        bail!("no fitted mode passes [[modes]] validation; nothing written (see the stabilisation chart with --max-order, --band-hz or --poles-hz)");
    }
    for m in &r.modes {
        let share = r.residual_share(2.0 * PI * m.frequency_hz);
        if share > 0.05 && a.pseudo_mode_hz.is_none() {
            warnings.push(format!(
                "the residuals are {:.1} % of |G| at {:.1} Hz and [[modes]] cannot hold them: they are dropped (or use --pseudo-mode-hz)",
                100.0 * share,
                m.frequency_hz
            ));
        }
    }

    write_outputs(a, &frf, cross.as_ref(), &r, &written)?;

    println!("vibrobar fit-modes ({})", crate::VERSION);
    println!(
        "  FRF        : {} ({}, {} lines; {})",
        a.frf.display(),
        frf.kind.name(),
        frf.len(),
        frf.units_note
    );
    println!(
        "  band       : {:.6}–{:.6} Hz, orders 2–{}, fit error {:.3e}{}, {} refinement iterations",
        r.chart.band_hz.0,
        r.chart.band_hz.1,
        a.max_order,
        r.fit_error,
        r.fit_error_cross
            .map_or(String::new(), |e| format!(" (cross {e:.3e})")),
        r.refine_iterations
    );
    println!("  modes      : frequency_hz  damping_ratio  modal_mass_kg  stiffness_n_per_m  shape_cavity");
    for (m, note) in &written {
        println!(
            "               {:>12.6}  {:>13.6}  {:>13.6}  {:>17.6e}  {:>12.6}   {note}",
            m.frequency_hz,
            m.damping_ratio,
            m.modal_mass_kg,
            m.modal_mass_kg * (2.0 * PI * m.frequency_hz).powi(2),
            m.shape_cavity
        );
    }
    println!(
        "  residuals  : upper {:.4e} m/N, lower {:.4e} 1/kg",
        r.upper_residual, r.lower_residual
    );
    for n in &notes {
        eprintln!("note: {n}");
    }
    for w in &warnings {
        eprintln!("warning: {w}");
    }
    println!("  wrote      : {}", a.out.display());
    Ok(())
}

fn stem(out: &Path, suffix: &str) -> PathBuf {
    let name = out
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    out.with_file_name(format!("{name}.{suffix}"))
}

fn write_outputs(
    a: &FitModesArgs,
    frf: &MeasuredFrf,
    cross: Option<&MeasuredFrf>,
    r: &ModalFit,
    written: &[(MeasuredMode, String)],
) -> Result<()> {
    // The stabilisation chart.
    let mut csv =
        String::from("order,frequency_hz,damping_ratio,pole_re_rad_s,pole_im_rad_s,stable\n");
    for p in &r.chart.poles {
        let _ = writeln!(
            csv,
            "{},{:e},{:e},{:e},{:e},{}",
            p.order,
            p.frequency_hz,
            p.damping_ratio,
            p.pole.re,
            p.pole.im,
            p.stable() as u8
        );
    }
    let chart_stem = stem(&a.out, "stabilisation");
    write_text(&stem(&a.out, "stabilisation.csv"), &csv)?;
    let pts = |stable: bool| -> Vec<(f64, f64)> {
        r.chart
            .poles
            .iter()
            .filter(|p| p.stable() == stable)
            .map(|p| (p.frequency_hz, p.order as f64))
            .collect()
    };
    let picked: Vec<f64> = r.modes.iter().map(|m| m.frequency_hz).collect();
    vibrobar_report::figures::fit::stabilisation_files(
        &chart_stem,
        &vibrobar_report::figures::fit::StabilisationChart {
            title: "stabilisation chart (LSCF)",
            stable: &pts(true),
            unstable: &pts(false),
            picked_hz: &picked,
            band_hz: r.chart.band_hz,
        },
    )?;

    // Measured against fitted, in the FRF's own kind.
    let mut cols = vec![
        "frequency_hz",
        "measured_re",
        "measured_im",
        "fitted_re",
        "fitted_im",
    ];
    if cross.is_some() {
        cols.extend([
            "cross_measured_re",
            "cross_measured_im",
            "cross_fitted_re",
            "cross_fitted_im",
        ]);
    }
    let mut csv = cols.join(",");
    csv.push('\n');
    let mut mag = (Vec::new(), Vec::new());
    let mut ph = (Vec::new(), Vec::new());
    for (k, &f) in frf.freqs_hz.iter().enumerate() {
        let w = 2.0 * PI * f;
        let c = frf.kind.factor(w);
        let h = frf.values[k];
        let g = c * r.receptance(w);
        let _ = write!(csv, "{f:e},{:e},{:e},{:e},{:e}", h.re, h.im, g.re, g.im);
        if let Some(x) = cross {
            let hc = x.values[k];
            let gc = c * r.receptance_cross(w).unwrap_or_default();
            let _ = write!(csv, ",{:e},{:e},{:e},{:e}", hc.re, hc.im, gc.re, gc.im);
        }
        csv.push('\n');
        mag.0.push((f, 20.0 * h.norm().log10()));
        mag.1.push((f, 20.0 * g.norm().log10()));
        ph.0.push((f, h.arg().to_degrees()));
        ph.1.push((f, g.arg().to_degrees()));
    }
    let fit_stem = stem(&a.out, "fit");
    write_text(&stem(&a.out, "fit.csv"), &csv)?;
    let curve =
        |label: &str, points: Vec<(f64, f64)>, measured: bool| vibrobar_report::plot::Curve {
            label: label.into(),
            points,
            color: if measured {
                plotters::style::RGBColor(120, 120, 120)
            } else {
                plotters::style::RGBColor(200, 40, 40)
            },
            markers: false,
            dashed: !measured,
            width: 1,
        };
    let unit = frf.kind.si_unit();
    vibrobar_report::plot::panels(
        &fit_stem,
        "measured against fitted FRF",
        2,
        1,
        &[
            (
                format!("magnitude, dB re 1 {unit}"),
                "frequency (Hz)".into(),
                "dB".into(),
                vec![
                    curve("measured", mag.0, true),
                    curve("fitted", mag.1, false),
                ],
            ),
            (
                "phase".into(),
                "frequency (Hz)".into(),
                "degrees".into(),
                vec![curve("measured", ph.0, true), curve("fitted", ph.1, false)],
            ),
        ],
    )?;

    // The modes, last: a complete TOML means the fit finished.
    let mut t = String::new();
    let _ = writeln!(
        t,
        "# Modes fitted by `vibrobar fit-modes` ({}) to {}.",
        crate::VERSION,
        a.frf.display()
    );
    t.push_str("# They describe the bar WITHOUT the ball (tap it with the ball removed, or locked with its\n# mass subtracted). Shapes are 1 at the tool tip; modal_mass_kg is in that normalisation.\n");
    if cross.is_none() {
        t.push_str(match (a.length_mm, a.cavity_from_clamp_mm) {
            (Some(_), Some(_)) => "# shape_cavity: a uniform clamped–free bar's mode shape (no cross FRF measured).\n",
            _ => "# shape_cavity = 1: the ball assumed at the tip (no cross FRF, no bar geometry given).\n",
        });
    }
    for (m, note) in written {
        let _ = write!(
            t,
            "\n# {note}\n[[modes]]\nfrequency_hz = {:?}\ndamping_ratio = {:?}\nmodal_mass_kg = {:?}\nshape_cavity = {:?}\n",
            m.frequency_hz, m.damping_ratio, m.modal_mass_kg, m.shape_cavity
        );
    }
    write_text(&a.out, &t)?;
    Ok(())
}
