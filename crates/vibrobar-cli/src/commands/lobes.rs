//! `vibrobar lobes`: exact linear stability lobes of regenerative chatter
//! ([`vibrobar_core::analysis::lobes`]) of a `[cutting]` scenario, on any structure (lumped
//! bar, `[beam]`, `[[modes]]`): the damped bar with the ball free and with the ball stuck, and
//! the solid reference. CSV schema `vibrobar_io::csv::lobes_schema`, metadata beside it, and a
//! figure (`STEM.png`, `STEM.svg`) of the boundaries with their stable sides shaded.

use anyhow::{Context, Result};
use clap::Args;
use serde::Serialize;
use std::path::PathBuf;
use vibrobar_core::analysis::lobes::{LobeRow, Lobes};

use crate::scenario::{spindle_speeds, Scenario};

/// `vibrobar lobes`.
#[derive(Debug, Args)]
pub struct LobesArgs {
    /// Scenario file (TOML) with a `[cutting]` section (K_f and the direction factors set the
    /// boundary; width, feed and spindle speed do not enter it); its bar is `[bar]`, `[beam]`
    /// or `[[modes]]`.
    #[arg(long, value_name = "FILE.toml")]
    pub scenario: PathBuf,
    /// Spindle speeds in rpm as START:STOP:STEP, STOP included, each in [1, 200000]
    /// (1000:50000:49 is 1001 speeds).
    #[arg(long, value_name = "START:STOP:STEP")]
    pub rpm: String,
    /// Number of modes N of a `[beam]` scenario, overriding `[beam] modes`, in [1, 32].
    #[arg(long, value_name = "N")]
    pub beam_modes: Option<usize>,
    /// Cavity centre (the ball) of a `[beam]` scenario in mm from the clamp, overriding
    /// `[beam] cavity_position_m`.
    #[arg(long, value_name = "X", allow_negative_numbers = true)]
    pub cavity_position_mm: Option<f64>,
    /// No figure (CSV and metadata only).
    #[arg(long)]
    pub no_figure: bool,
    /// Time-domain lobes: per speed the largest acceptable width of the solid and
    /// the damped bar from the small and the large disturbance of `[time_domain]` (lumped bar;
    /// see `vibrobar width-diagram`), instead of the exact linear lobes.
    #[arg(long)]
    pub time_domain: bool,
    /// With --time-domain: complete an interrupted run from its journal.
    #[arg(long, requires = "time_domain")]
    pub resume: bool,
    /// With --time-domain: compute only shard K of N (speeds K, K+N, …); join with `vibrobar
    /// merge`.
    #[arg(long, value_name = "K/N", requires = "time_domain")]
    pub shard: Option<String>,
    /// Lobes straight from a measured FRF instead of the scenario's structure: a tap test at
    /// the tool tip, measured in the direction that the `[cutting]` direction factors assume
    /// (a universal file, dataset 58 or 58b with 164, or plain columns: frequency in Hz and
    /// re/im or magnitude/phase). The receptance is interpolated between the measured lines by
    /// a natural cubic spline; no modal fit. Only `[cutting]` of the scenario is used. Output
    /// CSV: spindle_rpm,b_lim_m,chatter_frequency_hz,lobe; the figure (STEM.png, STEM.svg)
    /// shows the lobes of the modes fitted to the same FRF beside them.
    #[arg(long, value_name = "FILE", conflicts_with_all = ["time_domain", "beam_modes", "cavity_position_mm"])]
    pub frf: Option<PathBuf>,
    /// With --frf: units of plain columns (or replacing a universal file's): m/N, mm/N, µm/N,
    /// in/lbf, (m/s)/N, (m/s²)/N or g/N. Without it, plain columns are taken as SI.
    #[arg(long, value_name = "UNITS", requires = "frf")]
    pub frf_units: Option<String>,
    /// With --frf: receptance, mobility or accelerance, where the file does not say.
    #[arg(long, value_name = "KIND", requires = "frf")]
    pub frf_type: Option<String>,
    /// With --frf: layout of plain columns without a header: re-im (default), mag-deg or
    /// mag-rad (a fourth column is a coherence).
    #[arg(long, value_name = "LAYOUT", requires = "frf")]
    pub frf_columns: Option<String>,
    /// With --frf: the FRF record of a universal file holding records of several
    /// response/reference pairs (1-based among its FRF records).
    #[arg(long, value_name = "N", requires = "frf")]
    pub frf_record: Option<usize>,
    /// With --frf: conjugate the values (an FRF written under the e^{−iωt} convention).
    #[arg(long, requires = "frf")]
    pub frf_conjugate: bool,
    /// With --frf: negate the values (hammer or sensor pointing the other way).
    #[arg(long, requires = "frf")]
    pub frf_negate: bool,
    /// With --frf: cancel the mass of the accelerometer at the tip, in grams, in [0, 1e6]:
    /// H = H_m/(1 + m_a ω² H_m).
    #[arg(long, value_name = "GRAMS", requires = "frf")]
    pub frf_accelerometer_mass_g: Option<f64>,
    /// Output CSV: spindle_rpm,b_lim_m,chatter_frequency_hz,b_lim_ball_stuck_m,
    /// chatter_frequency_ball_stuck_hz,b_lim_solid_m,chatter_frequency_solid_hz,lobe,
    /// lobe_ball_stuck,lobe_solid; parameters go to FILE.meta.json, the figure to STEM.png and
    /// STEM.svg.
    #[arg(long, value_name = "FILE.csv")]
    pub out: PathBuf,
}

/// What the metadata records: the scenario (with its `[cutting]` and, for `[[modes]]` alone,
/// `reference = "no_ball"`) and the speeds asked for.
#[derive(Serialize)]
struct LobesParams<'a> {
    scenario: &'a Scenario,
    rpm_start: f64,
    rpm_stop: f64,
    rpm_step: f64,
}

/// Parse `--rpm START:STOP:STEP` into the speeds.
pub fn parse_rpm(text: &str) -> Result<(f64, f64, f64, Vec<f64>)> {
    let v = start_stop_step("--rpm", text, "START:STOP:STEP (e.g. 1000:50000:49)")?;
    Ok((v[0], v[1], v[2], spindle_speeds("--rpm", v[0], v[1], v[2])?))
}

/// The three numbers of `flag`'s `START:STOP:STEP` text, each named in its error; `form` is the
/// expected form as the error shows it.
pub fn start_stop_step(flag: &str, text: &str, form: &str) -> Result<[f64; 3]> {
    let parts: Vec<&str> = text.split(':').collect();
    if parts.len() != 3 {
        anyhow::bail!("{flag} must be {form}, got {text:?}");
    }
    let mut v = [0.0; 3];
    for (i, (p, name)) in parts.iter().zip(["START", "STOP", "STEP"]).enumerate() {
        v[i] = p.trim().parse::<f64>().map_err(|_| {
            anyhow::anyhow!("{flag} {name} must be a number, got {p:?} (in {text:?})")
        })?;
    }
    Ok(v)
}

/// Run the command.
pub fn run(args: &LobesArgs) -> Result<()> {
    let (start, stop, step, rpms) = parse_rpm(&args.rpm)?;
    if args.time_domain {
        if args.beam_modes.is_some() || args.cavity_position_mm.is_some() {
            anyhow::bail!(
                "--time-domain runs the scenario's own structure ([bar], [beam] or [[modes]]); \
                 --beam-modes and --cavity-position-mm do not apply to it"
            );
        }
        let _ = (start, stop, step);
        return super::time_domain::td_lobes(&super::time_domain::TdLobesArgs {
            scenario: args.scenario.clone(),
            rpms,
            resume: args.resume,
            shard: args.shard.clone(),
            no_figure: args.no_figure,
            out: args.out.clone(),
        });
    }
    if let Some(frf) = &args.frf {
        return frf_lobes(args, frf, (start, stop, step), &rpms);
    }
    let mut sc = Scenario::load_any(&args.scenario)?;
    sc.apply_beam_flags(args.beam_modes, args.cavity_position_mm)?;
    let spec = sc.lobe_spec()?;
    // Every file this command writes, refused up front if it is an input (the scenario): the
    // CSV, its metadata and the figure. A device or FIFO gets the CSV only (no sidecars).
    let draw = !args.no_figure && vibrobar_io::resolve_output(&args.out)?.is_regular();
    let stem = args.out.with_extension("");
    for p in [
        args.out.clone(),
        vibrobar_io::meta::meta_path(&args.out),
        vibrobar_report::figures::with_ext(&stem, "png"),
        vibrobar_report::figures::with_ext(&stem, "svg"),
    ] {
        vibrobar_io::refuse_input(&p)?;
    }
    let t0 = std::time::Instant::now();
    let mut lobes = Lobes::new(&spec)?;
    let rows: Vec<LobeRow> = rpms
        .iter()
        .map(|&n| lobes.row(n))
        .collect::<Result<_, _>>()?;
    let secs = t0.elapsed().as_secs_f64();
    vibrobar_io::csv::write_lobes_csv(&args.out, &rows)
        .with_context(|| format!("writing {}", args.out.display()))?;
    vibrobar_io::Metadata::new(
        "lobes",
        &vibrobar_io::csv::lobes_schema().header(),
        LobesParams {
            scenario: &sc,
            rpm_start: start,
            rpm_stop: stop,
            rpm_step: step,
        },
        None,
    )
    .write_beside(&args.out)
    .with_context(|| format!("metadata beside {}", args.out.display()))?;
    let structure = match (&sc.beam, &sc.modes) {
        (_, Some(m)) => format!("{} measured mode(s)", m.len()),
        (Some(_), None) => format!("beam, {} mode(s)", spec.damped.len()),
        (None, None) => "lumped bar".to_string(),
    };
    let figures = if !draw {
        Vec::new()
    } else {
        vibrobar_report::figures::lobes::draw_lobes_figure(
            &args.out,
            &rows,
            &format!("Stability lobes of regenerative chatter ({structure})"),
        )?
    };

    println!("vibrobar lobes ({})", crate::VERSION);
    let cut = sc.cutting.expect("lobe_spec checked it");
    println!(
        "  cut        : K_f = {:e} N/m², c_force = {}, c_chip = {} (K_f·c_force·c_chip = {:e} N/m²); {structure}; ball {} g",
        cut.coefficient_n_m2,
        cut.force_direction_factor,
        cut.chip_direction_factor,
        spec.oriented_coefficient_n_m2,
        spec.ball_mass_kg * 1e3
    );
    let reference = if sc.reference.is_some() {
        "solid reference = the same modes without the ball (no_ball)"
    } else {
        "solid reference bar"
    };
    for (label, t) in [
        ("ball free ", &lobes.tables()[0]),
        ("ball stuck", &lobes.tables()[1]),
        ("solid     ", &lobes.tables()[2]),
    ] {
        let (s, w) = t.minimum();
        println!(
            "  {label} : b_lim,min = {:.6} mm at {:.2} Hz (lowest point of every lobe)",
            s / spec.oriented_coefficient_n_m2 * 1e3,
            w / (2.0 * std::f64::consts::PI)
        );
    }
    println!(
        "  ({reference}; the ball acts only at finite amplitude: linearised, it is free or stuck)"
    );
    println!(
        "  output     : {} speeds {}–{} rpm to {} (+ .meta.json{}) in {}",
        rows.len(),
        vibrobar_io::csv::fmt_coord(start),
        vibrobar_io::csv::fmt_coord(rows.last().map_or(stop, |r| r.spindle_rpm)),
        args.out.display(),
        super::after_outputs(&figures),
        super::fmt_secs(secs)
    );
    Ok(())
}

/// What the metadata of `lobes --frf` records.
#[derive(Serialize)]
struct FrfLobesParams<'a> {
    scenario: &'a Scenario,
    frf_file: String,
    frf_format: &'a str,
    frf_kind: &'a str,
    frf_lines: usize,
    frf_band_hz: [f64; 2],
    frf_notes: &'a [String],
    rpm_start: f64,
    rpm_stop: f64,
    rpm_step: f64,
}

/// The read options of the `--frf*` flags.
pub fn frf_read_options(args: &LobesArgs) -> Result<vibrobar_io::frf::FrfReadOptions> {
    use vibrobar_core::structure::frf_data::FrfKind;
    let kind = match &args.frf_type {
        None => None,
        Some(t) => Some(FrfKind::parse(t).ok_or_else(|| {
            anyhow::anyhow!("--frf-type must be receptance, mobility or accelerance, got {t:?}")
        })?),
    };
    let columns = match &args.frf_columns {
        None => vibrobar_io::frf::ColumnLayout::default(),
        Some(c) => vibrobar_io::frf::ColumnLayout::parse(c).ok_or_else(|| {
            anyhow::anyhow!("--frf-columns must be re-im, mag-deg or mag-rad, got {c:?}")
        })?,
    };
    let mass = match args.frf_accelerometer_mass_g {
        None => None,
        Some(g) if (0.0..=1e6).contains(&g) => Some(g * 1e-3),
        Some(g) => anyhow::bail!("--frf-accelerometer-mass-g = {g} is outside [0, 1e6] grams"),
    };
    if let Some(u) = &args.frf_units {
        if vibrobar_io::frf::parse_frf_units(u).is_none() {
            anyhow::bail!(
                "--frf-units {u:?} is not an FRF unit; allowed {}",
                vibrobar_io::frf::PLAIN_UNITS
            );
        }
    }
    Ok(vibrobar_io::frf::FrfReadOptions {
        units: args.frf_units.clone(),
        kind,
        columns,
        record: args.frf_record,
        conjugate: args.frf_conjugate,
        negate: args.frf_negate,
        accelerometer_mass_kg: mass,
        cross: false,
    })
}

/// `vibrobar lobes --frf FILE`: the lobes of the measured receptance (module docs of
/// [`vibrobar_core::analysis::lobes_frf`]), at the oriented coefficient of `[cutting]`.
fn frf_lobes(
    args: &LobesArgs,
    frf_path: &std::path::Path,
    (start, stop, step): (f64, f64, f64),
    rpms: &[f64],
) -> Result<()> {
    use vibrobar_core::analysis::lobes_frf::{peak_resolution, FrfLobeTable};
    let opts = frf_read_options(args)?;
    let sc = Scenario::load_any(&args.scenario)?;
    let cut = sc.cutting.ok_or_else(|| {
        anyhow::anyhow!(
            "{}: lobes need a [cutting] section (coefficient_n_m2 and the direction factors)",
            args.scenario.display()
        )
    })?;
    cut.validate()?;
    let k_o = cut.coefficient_n_m2 * cut.force_direction_factor * cut.chip_direction_factor;
    vibrobar_io::refuse_input(&args.out)?;
    vibrobar_io::refuse_input(&vibrobar_io::meta::meta_path(&args.out))?;
    let read = vibrobar_io::frf::read_frf(frf_path, &opts)?;
    let frf = &read.frf;
    if !frf.driving_point {
        anyhow::bail!(
            "{}: the FRF is a cross FRF (response and reference at different points or directions); lobes need the driving-point FRF at the tool tip",
            frf_path.display()
        );
    }
    let data = |e: vibrobar_core::structure::frf_data::FrfDataError| {
        anyhow::anyhow!("{}: {e}", frf_path.display())
    };
    let t0 = std::time::Instant::now();
    let table = FrfLobeTable::new(frf).map_err(data)?;
    let rows: Vec<(f64, vibrobar_core::analysis::lobes::BoundaryPoint)> = rpms
        .iter()
        .map(|&n| table.boundary_at(n, k_o).map(|b| (n, b)))
        .collect::<Result<_, _>>()?;
    let secs = t0.elapsed().as_secs_f64();
    vibrobar_io::csv::write_lobes_frf_csv(&args.out, &rows)
        .with_context(|| format!("writing {}", args.out.display()))?;
    let band = [frf.freqs_hz[0], frf.freqs_hz[frf.len() - 1]];
    vibrobar_io::Metadata::new(
        "lobes-frf",
        &vibrobar_io::csv::lobes_frf_schema().header(),
        FrfLobesParams {
            scenario: &sc,
            frf_file: frf_path.display().to_string(),
            frf_format: read.format,
            frf_kind: frf.kind.name(),
            frf_lines: frf.len(),
            frf_band_hz: band,
            frf_notes: &read.notes,
            rpm_start: start,
            rpm_stop: stop,
            rpm_step: step,
        },
        None,
    )
    .write_beside(&args.out)
    .with_context(|| format!("metadata beside {}", args.out.display()))?;

    println!("vibrobar lobes --frf ({})", crate::VERSION);
    println!(
        "  FRF        : {} ({}, {}, {} lines, {}–{} Hz)",
        frf_path.display(),
        read.format,
        frf.kind.name(),
        frf.len(),
        band[0],
        band[1]
    );
    for n in &read.notes {
        println!("  note       : {n}");
    }
    println!(
        "  cut        : K_f·c_force·c_chip = {k_o:e} N/m² (the FRF must be measured in the direction these factors assume)"
    );
    let (s, w) = table.minimum();
    println!(
        "  measured   : b_lim,min = {:.6} mm at {:.2} Hz (lowest point of every lobe; spline through the measured lines, no fit)",
        s / k_o * 1e3,
        w / (2.0 * std::f64::consts::PI)
    );
    let mut fitted_curve = None;
    match fitted_table(frf) {
        Ok((mut ft, n)) => {
            let (sf, wf) = ft.minimum();
            println!(
                "  fitted     : b_lim,min = {:.6} mm at {:.2} Hz ({n} modes of `vibrobar fit-modes` with its defaults: {:+.2} % against the measured lines; what the fit costs)",
                sf / k_o * 1e3,
                wf / (2.0 * std::f64::consts::PI),
                100.0 * (sf / s - 1.0)
            );
            if !args.no_figure {
                fitted_curve = Some(
                    rpms.iter()
                        .map(|&n| ft.boundary_at(n, k_o).map(|b| (n, b.b_lim_m * 1e3)))
                        .collect::<Result<Vec<_>, _>>()?,
                );
            }
        }
        Err(e) => eprintln!("warning: no lobes of fitted modes beside the measured ones: the modal fit failed: {e:#}"),
    }
    if !args.no_figure && vibrobar_io::resolve_output(&args.out)?.is_regular() {
        use plotters::style::RGBColor;
        use vibrobar_report::plot::Curve;
        let curve = |label: &str, points: Vec<(f64, f64)>, color, dashed| Curve {
            label: label.into(),
            points,
            color,
            markers: false,
            dashed,
            width: 1,
        };
        let mut curves = vec![curve(
            "from the measured lines (spline, no fit)",
            rows.iter().map(|(n, b)| (*n, b.b_lim_m * 1e3)).collect(),
            RGBColor(120, 120, 120),
            false,
        )];
        if let Some(points) = fitted_curve {
            curves.push(curve(
                "from the fitted modes",
                points,
                RGBColor(200, 40, 40),
                true,
            ));
        }
        vibrobar_report::plot::lines(
            &args.out.with_extension(""),
            "stability lobes from a measured FRF",
            "spindle speed (rpm)",
            "b_lim (mm)",
            &curves,
            &[],
        )?;
    }
    for p in peak_resolution(frf).map_err(data)? {
        if p.under_resolved {
            eprintln!(
                "warning: the peak at {:.1} Hz is under-resolved: ζ·f ≈ {:.3} Hz is less than 5 line spacings ({:.3} Hz each); its lobes are not reliable: measure with finer lines",
                p.peak_hz, p.zeta_f_hz, p.line_spacing_hz
            );
        }
    }
    let (lo, hi) = table.band_edges_negative();
    if lo || hi {
        eprintln!(
            "warning: Re G < 0 at the {} of the measured band: chatter frequencies continue outside it, and lobes there are not seen",
            match (lo, hi) {
                (true, true) => "lowest and the highest line",
                (true, false) => "lowest line",
                _ => "highest line",
            }
        );
    }
    println!(
        "  output     : {} speeds {}–{} rpm to {} (+ .meta.json) in {}",
        rows.len(),
        vibrobar_io::csv::fmt_coord(start),
        vibrobar_io::csv::fmt_coord(rows.last().map_or(stop, |r| r.0)),
        args.out.display(),
        super::fmt_secs(secs)
    );
    Ok(())
}

/// The exact lobes of the modes fitted to `frf` (the fit's defaults, ball free) and the number
/// of modes.
fn fitted_table(
    frf: &vibrobar_core::structure::frf_data::MeasuredFrf,
) -> Result<(vibrobar_core::analysis::lobes::LobeTable, usize)> {
    use vibrobar_core::structure::fit::{fit_modes, FitSettings, FrfLines};
    use vibrobar_core::structure::MeasuredMode;
    let frf = if frf.freqs_hz[0] == 0.0 {
        frf.without_zero_frequency()?
    } else {
        frf.clone()
    };
    let r = fit_modes(&FrfLines::from(&frf), None, &FitSettings::default())?;
    let modes: Vec<_> = r
        .modes
        .iter()
        .map(|m| MeasuredMode {
            frequency_hz: m.frequency_hz,
            damping_ratio: m.damping_ratio,
            modal_mass_kg: m.modal_mass_kg,
            shape_cavity: 1.0,
            direction_deg: None,
        })
        .filter(|m| m.validate().is_ok())
        .collect();
    Ok((modes_lobe_table(&modes)?, modes.len()))
}

/// The exact lobes at the tip (ball free) of measured modes: the static compliance is the modes'
/// own (no residual).
pub fn modes_lobe_table(
    modes: &[vibrobar_core::structure::MeasuredMode],
) -> Result<vibrobar_core::analysis::lobes::LobeTable> {
    use vibrobar_core::analysis::lobes::{Linearisation, LobeTable, TipReceptance};
    let modes: Vec<_> = modes.iter().map(|m| m.mode()).collect();
    let stat = modes
        .iter()
        .map(|m| 1.0 / m.modal_stiffness_n_per_m())
        .sum();
    let model = vibrobar_core::structure::ModalModel::new(&modes, stat)?;
    Ok(LobeTable::new(TipReceptance::new(
        &model,
        Linearisation::BallFree,
    )?)?)
}
