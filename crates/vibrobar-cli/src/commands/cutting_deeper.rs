//! `vibrobar cutting-deeper` (issue #14 §4): the generated document (`docs/cutting-deeper.md`)
//! on what the ball damper buys against regenerative chatter at the paper's bar, as the lumped
//! bar referred to the tool tip and as the continuous beam.
//!
//! Every number in the document comes from this run, through the core's analyses: the bars from
//! the beam model (the tip-referred mass and stiffness are the first mode's modal mass at the tip
//! and `m₁ω₁²`, issue #8), the cut from the cited Kienzle data, the designs by
//! `analysis::lobe_design` (the functions of `vibrobar lobe-design`), the forced-response optimum
//! by `analysis::map` (lumped) and `analysis::placement` (beam). The two scenarios are written
//! beside the document (`DIR/lumped.toml`, `DIR/beam.toml`, `DIR` the document's path without
//! `.md`), with the design tables and heat maps, so every part can be rerun by `vibrobar
//! lobe-design` alone. All files are written atomically, the document last.
use super::placement::case_for;
use super::{check_value, fmt_coord, make_solver, parse_range};
use crate::progress::Progress;
use anyhow::{bail, Context, Result};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;
use vibrobar_core::analysis::batch::Runner;
use vibrobar_core::analysis::lobe_design::{
    chaos_spread, design_searches, optimum, solid_reference, DesignAxis, DesignGrid, DesignRow,
    LobeDesignSpec, SolidReference, DAMPED_LARGE, SOLID_LARGE, SPREAD_REL, SPREAD_SEEDS,
};
use vibrobar_core::analysis::map::{self, Axis, Grid, GridAxis, MapSpec};
use vibrobar_core::analysis::placement::{self, PlacementGrid, PlacementSpec, PointFailed};
use vibrobar_core::analysis::regime::Tolerances;
use vibrobar_core::analysis::time_domain::{
    td_lobes, width_diagram, width_spread, CutProblem, DiagramRow, Disturbance, Search, TdLobeRow,
    TimeDomainSettings,
};
use vibrobar_core::analysis::SweepBase;
use vibrobar_core::excitation::CuttingForceLaw;
use vibrobar_core::params::STANDARD_GRAVITY_M_S2;
use vibrobar_core::structure::Beam;
use vibrobar_core::{Forcing, FrictionModel, RunSettings, State};
use vibrobar_io::csv::{
    lobe_design_schema, lobe_design_values, td_lobes_schema, td_lobes_values, width_diagram_schema,
    width_diagram_values,
};
use vibrobar_scenario::Scenario;

/// Specific cutting force `k_c1.1` of non-alloy steel with ≥ 0.25 % C, annealed (material
/// group 2 of VDI 3323 / ISO 513, e.g. C45 = AISI 1045, 650 N/mm² tensile strength), N/mm²:
/// the force per mm² of chip 1 mm thick. ISCAR turning catalogue 2017, table "Material groups".
pub const KC11_N_MM2: f64 = 1500.0;
/// Its Kienzle exponent `m_c` (the same table): `k_c(h) = k_c1.1 · (h / 1 mm)^(−m_c)`.
pub const KIENZLE_MC: f64 = 0.22;
/// The paper's gap, m (the ball template's; the designs set their own).
const PAPER_GAP_M: f64 = 1e-4;
/// The nominal chip (feed), m: 0.1 mm per revolution, a finishing boring cut.
const FEED_M: f64 = 1e-4;

/// `vibrobar cutting-deeper`.
#[derive(Debug, Clone, clap::Args)]
pub struct CuttingDeeperArgs {
    /// The Markdown document to write (e.g. docs/cutting-deeper.md); its data and figures go to
    /// the directory of the same name without `.md`.
    #[arg(long)]
    pub out: PathBuf,
    /// Spindle speeds of the lumped bar's band, rpm, START:STOP:STEP (inclusive), in [1, 200000].
    #[arg(
        long,
        default_value = "4000:10000:1000",
        value_name = "START:STOP:STEP"
    )]
    pub rpm: String,
    /// Gaps of the lumped designs, mm, START:STOP:STEP (inclusive), each > 0.
    #[arg(long, default_value = "0.05:0.2:0.05", value_name = "START:STOP:STEP")]
    pub gaps_mm: String,
    /// Ball masses of the lumped designs, g, START:STOP:STEP (inclusive), each > 0.
    #[arg(long, default_value = "10:40:10", value_name = "START:STOP:STEP")]
    pub ball_masses_g: String,
    /// Spindle speeds of the beam's band, rpm (fewer: a beam run costs more).
    #[arg(
        long,
        default_value = "6000:10000:2000",
        value_name = "START:STOP:STEP"
    )]
    pub beam_rpm: String,
    /// Gaps of the beam designs, mm.
    #[arg(long, default_value = "0.05:0.15:0.05", value_name = "START:STOP:STEP")]
    pub beam_gaps_mm: String,
    /// Cavity centres of the beam designs, mm from the clamp, inside the bar.
    #[arg(long, default_value = "117:157:20", value_name = "START:STOP:STEP")]
    pub positions_mm: String,
    /// Frequency ratios Ω/ω₁ of the forced-response band (map and placement).
    #[arg(long, default_value = "0.95:1.05:0.05", value_name = "START:STOP:STEP")]
    pub ratios: String,
    /// Simulated time of each forced-response run, s (RMS over its last 80 %).
    #[arg(long, default_value_t = 1.0, allow_negative_numbers = true)]
    pub forced_duration: f64,
    /// The cutting force law: `three-quarter` or `linear`.
    #[arg(long, default_value = "three-quarter")]
    pub force_law: String,
    /// Settling window, spindle revolutions [default: the judge's].
    #[arg(long, allow_negative_numbers = true)]
    pub settle_revs: Option<f64>,
    /// Judging window, spindle revolutions [default: the judge's].
    #[arg(long, allow_negative_numbers = true)]
    pub judge_revs: Option<f64>,
    /// Widths checked below each bisection result [default: the judge's].
    #[arg(long)]
    pub monotonic_checks: Option<u32>,
    /// Leave the beam out (its part of the document then says so).
    #[arg(long)]
    pub lumped_only: bool,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
}

/// The specific cutting force at the feed, `k_c(h0)`, N/m² (Kienzle).
pub fn kienzle_kc_n_m2(feed_m: f64) -> f64 {
    KC11_N_MM2 * 1e6 * (feed_m / 1e-3).powf(-KIENZLE_MC)
}

/// The coefficient `K_f` of the three-quarter law `F = (4/3) K_f b h0 (h/h0)^{3/4}` that gives
/// the Kienzle force at the nominal chip: `(4/3) K_f = k_c(h0)`, N/m². The linear law takes the
/// same `K_f` (the same slope at `h0`, hence the same linear lobes).
pub fn cutting_coefficient_n_m2(feed_m: f64) -> f64 {
    0.75 * kienzle_kc_n_m2(feed_m)
}

/// The tip-referred lumped bar of the paper's geometry: the first mode's modal mass at the tip
/// (shape 1 there), `m₁ω₁²` and its damping ratio.
pub fn tip_referred_bar(beam: &Beam) -> Result<(f64, f64, f64)> {
    let model = beam.solid_reference(n_modes(beam)?).modal_model()?;
    let m1 = model.modes()[0];
    Ok((
        m1.modal_mass_kg,
        m1.modal_mass_kg * m1.omega_rad_s * m1.omega_rad_s,
        m1.damping_ratio,
    ))
}

/// The number of modes of `beam` (its own, or the default rule of issue #8).
fn n_modes(beam: &Beam) -> Result<usize> {
    Ok(match beam.modes {
        Some(n) => n,
        None => beam.modal_model()?.len(),
    })
}

fn law_word(law: CuttingForceLaw) -> &'static str {
    match law {
        CuttingForceLaw::Linear => "linear",
        CuttingForceLaw::ThreeQuarter => "three-quarter",
    }
}

fn td_section(s: &TimeDomainSettings) -> String {
    format!(
        "[time_domain]\nsettle_revs = {:?}\njudge_revs = {:?}\ngrowth_tolerance_per_rev = {:?}\n\
         bisection_tolerance = {:?}\nmonotonic_checks = {}\n",
        s.settle_revs,
        s.judge_revs,
        s.growth_tolerance_per_rev,
        s.bisection_tolerance,
        s.monotonic_checks
    )
}

fn cutting_section(kf: f64, law: CuttingForceLaw) -> String {
    format!(
        "[cutting]\ncoefficient_n_m2 = {kf:?}\nwidth_m = 2.0e-5\nfeed_m = {FEED_M:?}\n\
         spindle_rpm = 5000.0\nforce_law = \"{}\"\n",
        law_word(law)
    )
}

/// The lumped scenario: the tip-referred bar (damped and solid: the beam has no cavity
/// section, so both are the same bar), the paper's ball, the cut.
pub fn lumped_toml(beam: &Beam, law: CuttingForceLaw, td: &TimeDomainSettings) -> Result<String> {
    let (m, k, z) = tip_referred_bar(beam)?;
    let kf = cutting_coefficient_n_m2(FEED_M);
    Ok(format!(
        "# Generated by `vibrobar cutting-deeper`: the paper's bar referred to the tool tip (the\n\
         # first mode's modal mass at the tip and m1*w1^2 of the beam model), the paper's ball.\n\
         gravity_m_s2 = {STANDARD_GRAVITY_M_S2:?}\n\n\
         [bar]\nmass_kg = {m:?}\nstiffness_n_per_m = {k:?}\ndamping_ratio = {z:?}\n\n\
         [solid_bar]\nmass_kg = {m:?}\nstiffness_n_per_m = {k:?}\ndamping_ratio = {z:?}\n\n\
         [damper]\ngap_m = {PAPER_GAP_M:?}\nfriction = \"none\"\n\n{}\n{}",
        cutting_section(kf, law),
        td_section(td)
    ))
}

/// The beam scenario: the paper's geometry (the `[beam]` defaults), the cavity 38 mm from the
/// free end, the number of modes by the default rule, the paper's ball, the cut.
pub fn beam_toml(beam: &Beam, law: CuttingForceLaw, td: &TimeDomainSettings) -> String {
    let kf = cutting_coefficient_n_m2(FEED_M);
    format!(
        "# Generated by `vibrobar cutting-deeper`: the paper's bar as a clamped-free beam, the\n\
         # cavity 38 mm from the free end, the paper's ball.\n\
         gravity_m_s2 = {STANDARD_GRAVITY_M_S2:?}\n\n\
         [beam]\nlength_m = {:?}\ndiameter_m = {:?}\nyoungs_modulus_pa = {:?}\n\
         density_kg_m3 = {:?}\ncavity_position_m = {:?}\n\n\
         [damper]\ngap_m = {PAPER_GAP_M:?}\nfriction = \"none\"\n\n{}\n{}",
        beam.length_m,
        beam.diameter_m,
        beam.youngs_modulus_pa,
        beam.density_kg_m3,
        beam.cavity_position_m,
        cutting_section(kf, law),
        td_section(td)
    )
}

/// One study (lumped or beam): its scenario, the solid reference, every design's searches and
/// rows, and the forced-response ranking of the same designs.
struct Study {
    name: &'static str,
    toml: String,
    problem: CutProblem,
    grid: DesignGrid,
    solid: SolidReference,
    searches: Vec<Vec<Search>>,
    rows: Vec<DesignRow>,
    /// Mean forced-response reduction (%) of each design over the ratio band, by design index.
    forced_mean_reduction_pct: Vec<f64>,
    /// Index of the forced-response optimum among the designs.
    forced_best: usize,
    csv: PathBuf,
    figures: Vec<PathBuf>,
    /// The best design's time-domain lobes from both disturbances, and its width diagram.
    bistable: Bistable,
    secs: f64,
}

/// The bistable band of one study's best design: its time-domain lobes over the study's band
/// (solid and damped, small and large disturbance) and, on the lumped bar, its width diagram
/// at the solid bar's worst speed.
struct Bistable {
    rows: Vec<TdLobeRow>,
    /// Per speed, `(min, mean, max)` of the large-disturbance width over the seeded
    /// perturbations of the disturbance: `[solid, damped]`.
    spread: Vec<[(f64, f64, f64); 2]>,
    csv: PathBuf,
    figure: PathBuf,
    /// Speed, the rows, the CSV and the figure.
    diagram: Option<(f64, Vec<DiagramRow>, PathBuf, PathBuf)>,
}

/// Widths of the width diagram: `DIAGRAM_POINTS` evenly over `[0.5, 1.5]·b_lim_solid`, the
/// solid bar's linear boundary at that speed in the middle.
const DIAGRAM_POINTS: usize = 21;

/// The time-domain lobes (both disturbances, both bars) of design `d` over `rpms`, written as
/// `DIR/NAME-bistable.csv` (the schema of `vibrobar lobes --time-domain`) with its figure; with
/// `diagram_at`, also the width diagram at that speed (`DIR/NAME-width-diagram.csv`).
fn bistable(
    name: &str,
    spec: &LobeDesignSpec,
    d: &vibrobar_core::analysis::lobe_design::DesignPoint,
    rpms: &[f64],
    diagram_at: Option<f64>,
    runner: Runner<'_>,
    dir: &Path,
) -> Result<Bistable> {
    let p = spec.problem(d)?;
    let bar = Progress::new(
        &format!("cutting-deeper: {name} bistable band"),
        4 * rpms.len(),
        0,
    );
    let cb = bar.callback();
    let rows = td_lobes(&p, rpms, &runner.with_progress(&cb));
    bar.finish();
    let rows = rows.map_err(|e| anyhow::anyhow!("{name} bistable band: {e}"))?;
    let csv = dir.join(format!("{name}-bistable.csv"));
    vibrobar_io::csv::write_csv(&csv, &td_lobes_schema(), rows.iter().map(td_lobes_values))?;
    // A damped bar's verdict near its threshold moves with the run at the rounding level (a
    // rattling ball), so the best design's widths are searched again at every speed over the
    // seeded disturbances, and the solid bar's beside them for a like comparison.
    let jobs: Vec<(usize, usize)> = (0..rpms.len())
        .flat_map(|i| [(i, SOLID_LARGE), (i, DAMPED_LARGE)])
        .collect();
    let bar = Progress::new(
        &format!("cutting-deeper: {name} seeded spread"),
        jobs.len(),
        0,
    );
    let cb = bar.callback();
    let found = runner.with_progress(&cb).each(&jobs, |&(i, k)| {
        width_spread(&p, rpms[i], &rows[i].linear, k, SPREAD_SEEDS, SPREAD_REL)
    });
    bar.finish();
    let found = found.map_err(|e| anyhow::anyhow!("{name} seeded spread: {e}"))?;
    let spread = found.chunks(2).map(|c| [c[0], c[1]]).collect();
    super::time_domain::td_lobes_figure(&csv)?;
    let diagram = match diagram_at {
        None => None,
        Some(rpm) => {
            let b0 = vibrobar_core::analysis::time_domain::linear_at(&p, &[rpm])?[0].b_lim_solid_m;
            let widths: Vec<f64> = (0..DIAGRAM_POINTS)
                .map(|i| b0 * (0.5 + i as f64 / (DIAGRAM_POINTS - 1) as f64))
                .collect();
            let bar = Progress::new(
                &format!("cutting-deeper: {name} width diagram"),
                4 * widths.len(),
                0,
            );
            let cb = bar.callback();
            let drows = width_diagram(&p, rpm, &widths, &runner.with_progress(&cb));
            bar.finish();
            let drows = drows.map_err(|e| anyhow::anyhow!("{name} width diagram: {e}"))?;
            let dcsv = dir.join(format!("{name}-width-diagram.csv"));
            vibrobar_io::csv::write_csv(
                &dcsv,
                &width_diagram_schema(),
                drows.iter().map(|r| width_diagram_values(r, rpm)),
            )?;
            super::time_domain::width_diagram_figure(&dcsv)?;
            Some((rpm, drows, dcsv.clone(), dcsv.with_extension("png")))
        }
    };
    Ok(Bistable {
        rows,
        spread,
        figure: csv.with_extension("png"),
        csv,
        diagram,
    })
}

/// What [`design_study`] computes: the scenario, the spec, the grid, the solid reference and
/// every design's searches (one per speed) and row (with its chaos spread).
pub(crate) type Computed = (
    Scenario,
    LobeDesignSpec,
    DesignGrid,
    SolidReference,
    Vec<(Vec<Search>, DesignRow)>,
);

/// One design study: the scenario written to `DIR/NAME.toml`, the solid bar searched once per
/// speed, every design's searches and its seeded spread (the functions of `vibrobar
/// lobe-design`).
#[allow(clippy::too_many_arguments)]
pub(crate) fn design_study(
    name: &'static str,
    toml: String,
    axis: DesignAxis,
    gaps_m: Vec<f64>,
    values: Vec<f64>,
    rpms: &[f64],
    runner: Runner<'_>,
    dir: &Path,
) -> Result<Computed> {
    let sc = Scenario::from_toml(&toml).with_context(|| format!("the {name} scenario"))?;
    vibrobar_io::csv::write_text(&dir.join(format!("{name}.toml")), &toml)?;
    let spec = LobeDesignSpec {
        base: sc.cut_problem()?,
        beam: sc.beam.clone(),
        axis,
    };
    let grid = DesignGrid::new(axis, gaps_m, values)?;
    for d in grid.points() {
        spec.problem(&d)?;
    }
    let bar = Progress::new(
        &format!("cutting-deeper: {name}, solid reference"),
        rpms.len(),
        0,
    );
    let cb = bar.callback();
    let solid = solid_reference(&spec.base, rpms, &runner.with_progress(&cb));
    bar.finish();
    let solid = solid.map_err(|e| anyhow::anyhow!("{name} solid reference: {e}"))?;
    let points = grid.points();
    let bar = Progress::new(&format!("cutting-deeper: {name} designs"), points.len(), 0);
    let cb = bar.callback();
    let searches = runner.with_progress(&cb).each(&points, |d| {
        let searches = design_searches(&spec, d, &solid)?;
        let mut row = DesignRow::from_searches(d, &solid, &searches);
        chaos_spread(&spec, &mut row)?;
        Ok::<_, vibrobar_core::SimError>((searches, row))
    });
    bar.finish();
    let searches = searches.map_err(|e| anyhow::anyhow!("{name} designs: {e}"))?;
    Ok((sc, spec, grid, solid, searches))
}

/// `vibrobar cutting-deeper`.
pub fn run(args: &CuttingDeeperArgs) -> Result<()> {
    let t0 = Instant::now();
    let law = match args.force_law.as_str() {
        "three-quarter" => CuttingForceLaw::ThreeQuarter,
        "linear" => CuttingForceLaw::Linear,
        other => bail!("--force-law must be three-quarter or linear, got {other:?}"),
    };
    let mut td = TimeDomainSettings::default();
    if let Some(s) = args.settle_revs {
        td.settle_revs = s;
    }
    if let Some(j) = args.judge_revs {
        td.judge_revs = j;
    }
    if let Some(n) = args.monotonic_checks {
        td.monotonic_checks = n;
    }
    td.validate()
        .map_err(|e| anyhow::anyhow!("{e} (--settle-revs, --judge-revs, --monotonic-checks)"))?;
    let (_, _, _, rpms) = super::lobes::parse_rpm(&args.rpm)?;
    let (_, _, _, beam_rpms) =
        super::lobes::parse_rpm(&args.beam_rpm).map_err(|e| anyhow::anyhow!("--beam-rpm: {e}"))?;
    let mm = |v: Vec<f64>| v.iter().map(|x| x / 1e3).collect::<Vec<f64>>();
    let gaps = mm(parse_range(
        "--gaps-mm",
        &args.gaps_mm,
        |x| x > 0.0,
        "(0, ∞) mm",
    )?);
    let masses = mm(parse_range(
        "--ball-masses-g",
        &args.ball_masses_g,
        |x| x > 0.0,
        "(0, ∞) g",
    )?);
    let beam_gaps = mm(parse_range(
        "--beam-gaps-mm",
        &args.beam_gaps_mm,
        |x| x > 0.0,
        "(0, ∞) mm",
    )?);
    let positions = mm(parse_range(
        "--positions-mm",
        &args.positions_mm,
        |x| x >= 0.0,
        "[0, L] mm",
    )?);
    let ratios = parse_range("--ratios", &args.ratios, |x| x > 0.0, "(0, ∞)")?;
    let forced = RunSettings {
        duration_s: check_value(
            "--forced-duration",
            args.forced_duration,
            |x| x > 0.0 && x <= 100.0,
            "(0, 100] s",
        )?,
        dt_s: 1e-6,
        rms_fraction: 0.8,
    };
    forced.validate()?;
    let dir = args.out.with_extension("");
    std::fs::create_dir_all(&dir).with_context(|| format!("creating {}", dir.display()))?;
    let runner = Runner::default().with_threads(args.threads);
    let beam = Beam::default();

    // Lumped: the tip-referred bar, gap × ball mass.
    let t = Instant::now();
    let toml = lumped_toml(&beam, law, &td)?;
    let (sc, spec, grid, solid, searches) = design_study(
        "lumped",
        toml.clone(),
        DesignAxis::BallMass,
        gaps,
        masses,
        &rpms,
        runner,
        &dir,
    )?;
    // The forced-response map of the same designs (ratio × gap × mass ratio), the tip-referred
    // bar under the paper's 15 N harmonic force, from rest.
    let bar_model = sc.damped_system()?.bar;
    let m_kg = match bar_model {
        vibrobar_core::params::BarModel::Lumped(b) => b.mass_kg,
        vibrobar_core::params::BarModel::Modal(_) => {
            bail!("the lumped scenario must have a lumped bar")
        }
    };
    let mspec = MapSpec {
        base: SweepBase {
            damped_bar: bar_model,
            solid_bar: bar_model,
            ball: spec.base.damped.damper.expect("the scenario has a ball"),
            forcing: Forcing::paper(1.0),
            gravity_m_s2: STANDARD_GRAVITY_M_S2,
            init: State::REST,
        },
        friction: FrictionModel::None,
        settings: forced,
        tolerances: Tolerances::default(),
    };
    let mgrid = Grid::new(vec![
        GridAxis {
            axis: Axis::GapM,
            values: grid.gaps_m().to_vec(),
        },
        GridAxis {
            axis: Axis::MassRatio,
            values: grid.values().iter().map(|m| m / m_kg).collect(),
        },
        GridAxis {
            axis: Axis::FreqRatio,
            values: ratios.clone(),
        },
    ])?;
    let solver = make_solver("exact", &forced)?;
    let bar = Progress::new("cutting-deeper: lumped forced-response map", mgrid.len(), 0);
    let cb = bar.callback();
    let mrows = super::with_threads(args.threads, || {
        map::run_map(&mspec, solver.as_ref(), &mgrid.points(), &cb)
    })?;
    bar.finish();
    let mrows = mrows.map_err(|e| anyhow::anyhow!("lumped forced-response map: {e}"))?;
    // Gap-major, mass, then ratio: design i owns rows i·n_r … (i+1)·n_r − 1.
    let nr = ratios.len();
    let forced_lumped: Vec<f64> = (0..grid.len())
        .map(|i| {
            mrows[i * nr..(i + 1) * nr]
                .iter()
                .map(|r| r.reduction_pct)
                .sum::<f64>()
                / nr as f64
        })
        .collect();
    let best = map::optimum(&mrows)
        .best_mean_reduction
        .context("the forced-response map has no complete design")?;
    let forced_best = (0..grid.len())
        .find(|&i| {
            let p = grid.point(i).expect("inside the grid");
            best.design
                .iter()
                .any(|&(a, v)| a == Axis::GapM && v == p.gap_m)
                && best
                    .design
                    .iter()
                    .any(|&(a, v)| a == Axis::MassRatio && v == p.value / m_kg)
        })
        .context("the map's optimum is a design of the grid")?;
    let lumped = finish_study(
        "lumped",
        toml,
        spec,
        grid,
        solid,
        searches,
        forced_lumped,
        forced_best,
        true,
        runner,
        &dir,
        t,
    )?;

    // Beam: gap × cavity position.
    let beam_study = if args.lumped_only {
        None
    } else {
        let t = Instant::now();
        let toml = beam_toml(&beam, law, &td);
        let (sc, spec, grid, solid, searches) = design_study(
            "beam",
            toml.clone(),
            DesignAxis::Position,
            beam_gaps,
            positions,
            &beam_rpms,
            runner,
            &dir,
        )?;
        let pspec = PlacementSpec {
            beam: sc.beam.clone().context("the beam scenario has a [beam]")?,
            ball: spec.base.damped.damper.expect("the scenario has a ball"),
            forcing: Forcing::paper(1.0),
            gravity_m_s2: STANDARD_GRAVITY_M_S2,
            settings: forced,
            tolerances: Tolerances::default(),
        };
        // Placement's grid is position-major; the designs are gap-major.
        let pgrid = PlacementGrid::new(
            grid.values().to_vec(),
            grid.gaps_m().to_vec(),
            ratios.clone(),
        )?;
        let points: Vec<_> = (0..pgrid.len()).filter_map(|i| pgrid.point(i)).collect();
        let owned = case_for("exact", &pspec, forced, false)?;
        let case = |s: &vibrobar_core::System| owned.run(s);
        let bar = Progress::new("cutting-deeper: beam placement", points.len(), 0);
        let cb = bar.callback();
        let prows = placement::run(
            &pspec,
            &pgrid,
            &points,
            runner.with_progress(&cb),
            &case,
            Ok::<_, PointFailed>,
        );
        bar.finish();
        let prows = prows.map_err(|e| anyhow::anyhow!("beam placement: {e}"))?;
        let design_of = |x: f64, g: f64| {
            (0..grid.len()).find(|&i| {
                let p = grid.point(i).expect("inside the grid");
                p.gap_m == g && p.value == x
            })
        };
        let mut forced_beam = vec![f64::NAN; grid.len()];
        for r in &prows {
            if let Some(i) = design_of(r.point.position_m, r.point.gap_m) {
                forced_beam[i] = r.mean_reduction_pct;
            }
        }
        let best = placement::optimum(&prows).context("the placement study has no row")?;
        let forced_best = design_of(best.point.position_m, best.point.gap_m)
            .context("the placement optimum is a design of the grid")?;
        Some(finish_study(
            "beam",
            toml,
            spec,
            grid,
            solid,
            searches,
            forced_beam,
            forced_best,
            false,
            runner,
            &dir,
            t,
        )?)
    };
    let doc = render(
        args,
        law,
        &td,
        &ratios,
        &forced,
        &lumped,
        beam_study.as_ref(),
        t0,
    )?;
    vibrobar_io::csv::write_text(&args.out, &doc)
        .with_context(|| format!("writing {}", args.out.display()))?;
    println!("wrote {}", args.out.display());
    Ok(())
}

#[allow(clippy::too_many_arguments)]
fn finish_study(
    name: &'static str,
    toml: String,
    spec: LobeDesignSpec,
    grid: DesignGrid,
    solid: SolidReference,
    computed: Vec<(Vec<Search>, DesignRow)>,
    forced_mean_reduction_pct: Vec<f64>,
    forced_best: usize,
    diagram: bool,
    runner: Runner<'_>,
    dir: &Path,
    t: Instant,
) -> Result<Study> {
    let (searches, rows): (Vec<Vec<Search>>, Vec<DesignRow>) = computed.into_iter().unzip();
    let best = optimum(&rows).context("no designs")?;
    let bistable = bistable(
        name,
        &spec,
        &best.point,
        &solid.rpms,
        diagram.then_some(solid.score.worst_rpm),
        runner,
        dir,
    )?;
    let axis = grid.axis();
    let schema = lobe_design_schema(axis);
    let csv = dir.join(format!("{name}-design.csv"));
    vibrobar_io::csv::write_csv(&csv, &schema, rows.iter().map(lobe_design_values))?;
    let figures =
        vibrobar_report::figures::lobe_design::draw_lobe_design_figure(&csv, axis, &rows)?;
    Ok(Study {
        name,
        toml,
        problem: spec.base,
        grid,
        solid,
        searches,
        rows,
        forced_mean_reduction_pct,
        forced_best,
        csv,
        figures,
        bistable,
        secs: t.elapsed().as_secs_f64(),
    })
}

fn um(x: f64) -> String {
    format!("{:.2}", x * 1e6)
}

fn gain(g: Option<f64>) -> String {
    g.map_or("—".into(), |g| format!("{g:.3}"))
}

fn rel(path: &Path, doc: &Path) -> String {
    let base = doc.parent().unwrap_or(Path::new(""));
    path.strip_prefix(base)
        .unwrap_or(path)
        .display()
        .to_string()
}

fn describe(axis: DesignAxis, gap_m: f64, value: f64) -> String {
    match axis {
        DesignAxis::BallMass => format!(
            "gap {} mm, ball {} g",
            fmt_coord(gap_m * 1e3),
            fmt_coord(value * 1e3)
        ),
        DesignAxis::Position => format!(
            "gap {} mm, cavity {} mm from the clamp",
            fmt_coord(gap_m * 1e3),
            fmt_coord(value * 1e3)
        ),
    }
}

/// The section of one study.
fn study_section(d: &mut String, s: &Study, doc: &Path) -> Result<()> {
    let axis = s.grid.axis();
    let n = s.rows.len();
    let best = optimum(&s.rows).context("no designs")?;
    let rpms = &s.solid.rpms;
    let lin = vibrobar_core::analysis::time_domain::linear_at(&s.problem, rpms)?;
    writeln!(
        d,
        "Scenario `{}` (beside this document), {} designs × {} speeds ({} rpm), {} s wall.\n",
        rel(
            &doc.with_extension("").join(format!("{}.toml", s.name)),
            doc
        ),
        n,
        rpms.len(),
        rpms.iter()
            .map(|r| fmt_coord(*r))
            .collect::<Vec<_>>()
            .join(", "),
        s.secs.round()
    )?;
    writeln!(d, "```toml\n{}```\n", s.toml)?;
    for f in s
        .figures
        .iter()
        .filter(|f| f.extension().is_some_and(|e| e == "png"))
    {
        writeln!(
            d,
            "![worst-case width over the {} designs]({})\n",
            s.name,
            rel(f, doc)
        )?;
    }
    // Headline.
    writeln!(
        d,
        "- **Solid bar** over the band: worst {} µm (at {} rpm), mean {} µm.",
        um(s.solid.score.worst_width_m),
        fmt_coord(s.solid.score.worst_rpm),
        um(s.solid.score.mean_width_m)
    )?;
    writeln!(
        d,
        "- **Best design** (largest worst case; `lobe-design`'s optimum): {}: worst {} µm (at {} \
         rpm), **{}×** the solid bar's; mean {} µm, **{}×** the solid bar's.",
        describe(axis, best.point.gap_m, best.point.value),
        um(best.damped.worst_width_m),
        fmt_coord(best.damped.worst_rpm),
        gain(best.worst_gain()),
        um(best.damped.mean_width_m),
        gain(best.mean_gain())
    )?;
    let by_mean = s
        .rows
        .iter()
        .max_by(|a, b| {
            a.damped
                .mean_width_m
                .total_cmp(&b.damped.mean_width_m)
                .then(b.point.index.cmp(&a.point.index))
        })
        .expect("designs");
    writeln!(
        d,
        "- Largest mean: {}: mean {} µm ({}×), worst {} µm ({}×).",
        describe(axis, by_mean.point.gap_m, by_mean.point.value),
        um(by_mean.damped.mean_width_m),
        gain(by_mean.mean_gain()),
        um(by_mean.damped.worst_width_m),
        gain(by_mean.worst_gain())
    )?;
    // Forced-response optimum.
    let fb = &s.rows[s.forced_best];
    let rank = |i: usize| {
        1 + s
            .rows
            .iter()
            .filter(|r| r.damped.worst_width_m > s.rows[i].damped.worst_width_m)
            .count()
    };
    let frank = |i: usize| {
        1 + s
            .forced_mean_reduction_pct
            .iter()
            .filter(|&&r| r > s.forced_mean_reduction_pct[i])
            .count()
    };
    writeln!(
        d,
        "- **Forced-response optimum** (largest mean RMS reduction over the ratio band under the \
         harmonic force, `{}`): {}, mean reduction {:.1} %. Cutting, it reaches worst {} µm \
         ({}×), mean {} µm ({}×): rank {} of {n} by worst case. The lobe-design optimum's mean \
         forced reduction is {:.1} % (rank {} of {n}).",
        if s.name == "lumped" {
            "map"
        } else {
            "placement"
        },
        describe(axis, fb.point.gap_m, fb.point.value),
        s.forced_mean_reduction_pct[s.forced_best],
        um(fb.damped.worst_width_m),
        gain(fb.worst_gain()),
        um(fb.damped.mean_width_m),
        gain(fb.mean_gain()),
        rank(s.forced_best),
        s.forced_mean_reduction_pct[best.point.index],
        frank(best.point.index)
    )?;
    // Where worse.
    let worse_worst = s
        .rows
        .iter()
        .filter(|r| r.damped.worst_width_m < r.solid.worst_width_m)
        .count();
    let worse_mean = s
        .rows
        .iter()
        .filter(|r| r.damped.mean_width_m < r.solid.mean_width_m)
        .count();
    writeln!(
        d,
        "- **Where the damper makes things worse**: {worse_worst} of {n} designs have a worst \
         case below the solid bar's, {worse_mean} of {n} a mean below it. Per speed, the designs \
         cutting less than the solid bar:"
    )?;
    writeln!(d)?;
    writeln!(
        d,
        "| spindle (rpm) | b_lim linear (µm) | solid bar (µm) | best design (µm) | forced-response optimum (µm) | designs below the solid bar |"
    )?;
    writeln!(d, "|---|---|---|---|---|---|")?;
    for (k, &r) in rpms.iter().enumerate() {
        let sw = s.solid.searches[k].width_m;
        let below = s.searches.iter().filter(|v| v[k].width_m < sw).count();
        writeln!(
            d,
            "| {} | {} | {} | {} | {} | {below} of {n} |",
            fmt_coord(r),
            um(lin[k].b_lim_solid_m),
            um(sw),
            um(s.searches[best.point.index][k].width_m),
            um(s.searches[s.forced_best][k].width_m),
        )?;
    }
    writeln!(d)?;
    bistable_section(d, s, best, doc)?;
    let nonmono: u32 = s.rows.iter().map(|r| r.non_monotonic).sum();
    let capped: u32 = s.rows.iter().map(|r| r.capped).sum();
    let ev: u32 = s.rows.iter().map(|r| r.event_limit_runs).sum();
    let runs: u32 = s.rows.iter().map(|r| r.runs).sum();
    writeln!(
        d,
        "Every design ({}, the counts are the damped searches': `non_monotonic` speeds where a \
         width below the bisection result failed, `capped` speeds acceptable at the doubling cap, \
         runs at the event limit; {runs} damped runs, {nonmono} non-monotonic speeds, {capped} \
         capped, {ev} at the event limit):\n",
        rel(&s.csv, doc)
    )?;
    let second = match axis {
        DesignAxis::BallMass => "ball (g)",
        DesignAxis::Position => "cavity from the clamp (mm)",
    };
    writeln!(
        d,
        "| gap (mm) | {second} | worst (µm) | at (rpm) | mean (µm) | worst gain | mean gain | forced mean reduction (%) | non-monotonic | regime at the worst case | spread if chaotic (µm) |"
    )?;
    writeln!(d, "|---|---|---|---|---|---|---|---|---|---|---|")?;
    for (i, r) in s.rows.iter().enumerate() {
        let regime = r
            .worst_regime
            .map_or("—".into(), |g| g.as_str().into_owned());
        let spread = r.spread.map_or("—".into(), |w| {
            format!(
                "{}–{} (mean {})",
                um(w.min_width_m),
                um(w.max_width_m),
                um(w.mean_width_m)
            )
        });
        writeln!(
            d,
            "| {} | {} | {} | {} | {} | {} | {} | {:.1} | {} | `{regime}` | {spread} |",
            fmt_coord(r.point.gap_m * 1e3),
            fmt_coord(r.point.value * 1e3),
            um(r.damped.worst_width_m),
            fmt_coord(r.damped.worst_rpm),
            um(r.damped.mean_width_m),
            gain(r.worst_gain()),
            gain(r.mean_gain()),
            s.forced_mean_reduction_pct[i],
            r.non_monotonic
        )?;
    }
    writeln!(d)?;
    Ok(())
}

/// The bistable band of the best design: per speed, the widths from the small and the large
/// disturbance for both bars. The band is the widths acceptable from the small disturbance but
/// not from the large one, `[b_large, b_small)`: its width is `max(0, b_small − b_large)`.
fn bistable_section(d: &mut String, s: &Study, best: &DesignRow, doc: &Path) -> Result<()> {
    let b = &s.bistable;
    let band = |small: f64, large: f64| (small - large).max(0.0);
    let w = |r: &TdLobeRow, k: usize| r.searches[k].width_m;
    writeln!(
        d,
        "**The bistable band** of the best design ({}): at each speed, the largest acceptable \
         width from the small disturbance (A = {} µm) and from the large one, for the solid and \
         the damped bar (the search above, run from both disturbances; `{}`, the schema of \
         `vibrobar lobes --time-domain`). The band is the widths that pass from the small \
         disturbance and fail from the large one, [b_large, b_small); its width is \
         max(0, b_small − b_large).\n",
        describe(s.grid.axis(), best.point.gap_m, best.point.value),
        um(s.problem
            .settings
            .disturbance_m(Disturbance::Small, s.problem.cutting.feed_m)),
        rel(&b.csv, doc)
    )?;
    writeln!(
        d,
        "| spindle (rpm) | b_lim linear (µm) | solid, small (µm) | solid, large (µm) | solid band (µm) | damped, small (µm) | damped, large (µm) | damped band (µm) |"
    )?;
    writeln!(d, "|---|---|---|---|---|---|---|---|")?;
    let (mut sum_solid, mut sum_damped) = (0.0, 0.0);
    let (mut max_solid, mut max_damped) = (0.0_f64, 0.0_f64);
    for r in &b.rows {
        let bs = band(w(r, 0), w(r, 1));
        let bd = band(w(r, 2), w(r, 3));
        sum_solid += bs;
        sum_damped += bd;
        max_solid = max_solid.max(bs);
        max_damped = max_damped.max(bd);
        writeln!(
            d,
            "| {} | {} | {} | {} | {} | {} | {} | {} |",
            fmt_coord(r.spindle_rpm),
            um(r.linear.b_lim_solid_m),
            um(w(r, 0)),
            um(w(r, 1)),
            um(bs),
            um(w(r, 2)),
            um(w(r, 3)),
            um(bd)
        )?;
    }
    let n = b.rows.len().max(1) as f64;
    writeln!(
        d,
        "\nOver the band the bistable band is on average {} µm wide without the ball (at most {} \
         µm) and {} µm with it (at most {} µm).\n",
        um(sum_solid / n),
        um(max_solid),
        um(sum_damped / n),
        um(max_damped)
    )?;
    writeln!(
        d,
        "**How firm the best design's widths are.** Near its threshold a damped run's verdict \
         turns on details far below any tolerance (a change of the gap by one unit in the last \
         place moves some designs' widths by tens of percent at single speeds): the widths above are samples of a scattered quantity. At every speed the \
         large-disturbance width was searched again over {SPREAD_SEEDS} seeded perturbations of \
         the disturbance's amplitude (±{} %), for both bars:\n",
        SPREAD_REL * 100.0
    )?;
    writeln!(
        d,
        "| spindle (rpm) | solid, nominal (µm) | solid over seeds: min–max (mean) | damped, nominal (µm) | damped over seeds: min–max (mean) |"
    )?;
    writeln!(d, "|---|---|---|---|---|")?;
    let (mut ws, mut wd) = (f64::INFINITY, f64::INFINITY);
    let (mut ms, mut md) = (0.0, 0.0);
    for (r, [sp_s, sp_d]) in b.rows.iter().zip(&b.spread) {
        let lo_s = w(r, 1).min(sp_s.0);
        let lo_d = w(r, 3).min(sp_d.0);
        ws = ws.min(lo_s);
        wd = wd.min(lo_d);
        ms += lo_s;
        md += lo_d;
        writeln!(
            d,
            "| {} | {} | {}–{} ({}) | {} | {}–{} ({}) |",
            fmt_coord(r.spindle_rpm),
            um(w(r, 1)),
            um(sp_s.0),
            um(sp_s.2),
            um(sp_s.1),
            um(w(r, 3)),
            um(sp_d.0),
            um(sp_d.2),
            um(sp_d.1)
        )?;
    }
    writeln!(
        d,
        "\nTaking at each speed the least of the nominal and the seeded widths, the best design \
         cuts at worst {} µm against the solid bar's {} µm (**{}×**), on average {} against {} \
         µm (**{}×**): the gain that holds whichever sample the disturbance draws.\n",
        um(wd),
        um(ws),
        gain((ws > 0.0).then(|| wd / ws)),
        um(md / n),
        um(ms / n),
        gain((ms > 0.0).then(|| md / ms))
    )?;
    writeln!(
        d,
        "![time-domain lobes of the best {} design from both disturbances]({})\n",
        s.name,
        rel(&b.figure, doc)
    )?;
    if let Some((rpm, rows, csv, png)) = &b.diagram {
        writeln!(
            d,
            "Its width diagram at {} rpm (the solid bar's worst speed; {} widths over 0.5–1.5 \
             times the solid bar's linear boundary; `{}`): the settled peak-to-peak vibration \
             from both disturbances; where the small- and large-disturbance curves part is the \
             bistable band.\n",
            fmt_coord(*rpm),
            rows.len() / 4,
            rel(csv, doc)
        )?;
        writeln!(
            d,
            "![width diagram of the best {} design at {} rpm]({})\n",
            s.name,
            fmt_coord(*rpm),
            rel(png, doc)
        )?;
    }
    Ok(())
}

#[allow(clippy::too_many_arguments)]
fn render(
    args: &CuttingDeeperArgs,
    law: CuttingForceLaw,
    td: &TimeDomainSettings,
    ratios: &[f64],
    forced: &RunSettings,
    lumped: &Study,
    beam: Option<&Study>,
    t0: Instant,
) -> Result<String> {
    let mut d = String::new();
    let mut cmd = format!(
        "vibrobar cutting-deeper --rpm {} --gaps-mm {} --ball-masses-g {} --beam-rpm {} \
         --beam-gaps-mm {} --positions-mm {} --ratios {} --forced-duration {} --force-law {}",
        args.rpm,
        args.gaps_mm,
        args.ball_masses_g,
        args.beam_rpm,
        args.beam_gaps_mm,
        args.positions_mm,
        args.ratios,
        args.forced_duration,
        law_word(law)
    );
    for (flag, v) in [
        ("--settle-revs", args.settle_revs.map(|x| x.to_string())),
        ("--judge-revs", args.judge_revs.map(|x| x.to_string())),
        (
            "--monotonic-checks",
            args.monotonic_checks.map(|x| x.to_string()),
        ),
    ] {
        if let Some(v) = v {
            write!(cmd, " {flag} {v}")?;
        }
    }
    if args.lumped_only {
        cmd += " --lumped-only";
    }
    let p = &lumped.problem;
    let (m, k, z) = tip_referred_bar(&Beam::default())?;
    let kc = kienzle_kc_n_m2(FEED_M);
    let kf = p.cutting.coefficient_n_m2;
    let ball = p.damped.damper.context("a ball")?;
    writeln!(
        d,
        "# Cutting deeper with the damper: the paper's bar (issue #14)\n"
    )?;
    writeln!(
        d,
        "Generated by `{cmd} --out {}` (vibrobar {}) in {} s; do not edit by hand. Rerun the \
         command to regenerate every number, table and figure (data and figures in `{}/`).\n",
        args.out.display(),
        env!("CARGO_PKG_VERSION"),
        t0.elapsed().as_secs_f64().round(),
        rel(&args.out.with_extension(""), &args.out)
    )?;
    writeln!(d, "## What the numbers rest on\n")?;
    writeln!(
        d,
        "- **Bars.** The paper's steel bar, L = {} mm, D = {} mm, as a clamped–free beam ({} \
         modes by the default rule of issue #8, ζ = {} per mode, the cavity centre {} mm from \
         the clamp, 38 mm from the free end); and the same bar **referred to the tool tip** as \
         the lumped bar: M = m₁ = {:.4} kg (the first mode's modal mass at the tip, ρAL/4; not \
         the paper's M = ρAL), K = m₁ω₁² = {:.4} MN/m (f₁ = {:.2} Hz), ζ = {z}. The beam has no \
         cavity section, so the solid reference is the same bar without the ball.",
        fmt_coord(Beam::default().length_m * 1e3),
        fmt_coord(Beam::default().diameter_m * 1e3),
        n_modes(&Beam::default())?,
        z,
        fmt_coord(Beam::default().cavity_position_m * 1e3),
        m,
        k / 1e6,
        (k / m).sqrt() / (2.0 * std::f64::consts::PI),
    )?;
    writeln!(
        d,
        "- **Ball.** The paper's: {} g, e = {}, frictionless; gap and mass (lumped) or gap and \
         position (beam) are the design variables.",
        fmt_coord(ball.ball_mass_kg * 1e3),
        ball.restitution
    )?;
    writeln!(
        d,
        "- **Cut.** Feed h0 = {} mm, the **{}** force law. Medium-carbon steel (C45 / AISI \
         1045, annealed, material group 2 of VDI 3323): Kienzle k_c1.1 = {KC11_N_MM2} N/mm², m_c \
         = {KIENZLE_MC} (ISCAR turning catalogue 2017, \"Material groups\" table), so k_c(h0) = \
         k_c1.1·(h0/1 mm)^(−m_c) = {:.0} N/mm²; K_f = (3/4)·k_c(h0) = {:.0} N/mm² makes the \
         three-quarter law's force at h0, (4/3)K_f b h0, the catalogue's (the slope at h0 is \
         K_f, the Kienzle law's own slope is (1 − m_c)·k_c(h0) = {:.0} N/mm²). Altintas \
         (*Manufacturing Automation*, 2nd ed., 2012) tabulates tangential coefficients of the \
         same order for plain carbon steels; this value was checked against the catalogue \
         table, not against that book. c_force = c_chip = 1.",
        fmt_coord(FEED_M * 1e3),
        law_word(law),
        kc / 1e6,
        kf / 1e6,
        (1.0 - KIENZLE_MC) * kc / 1e6
    )?;
    writeln!(
        d,
        "- **Disturbance and start.** Each design is judged from the **large** disturbance A = {} \
         µm (the static equilibrium of the cut, the ball at rest at the cavity centre, a tool \
         velocity ω_c·A in the mode nearest the linear chatter frequency ω_c).",
        um(td.disturbance_m(
            vibrobar_core::analysis::time_domain::Disturbance::Large,
            FEED_M
        ))
    )?;
    writeln!(
        d,
        "- **Windows and limit.** Settle {} revolutions, judge {}; acceptable: peak-to-peak tip \
         vibration below {} µm, never out of the cut, envelope growth below {} per revolution. \
         Width search: double from the solid bar's linear b_lim, bisect to {} %, check {} \
         widths below.",
        td.settle_revs,
        td.judge_revs,
        um(td.vibration_limit_for(FEED_M)),
        td.growth_tolerance_per_rev,
        td.bisection_tolerance * 100.0,
        td.monotonic_checks
    )?;
    writeln!(
        d,
        "- **Score.** The worst-case acceptable width over the band of speeds (and the mean), as \
         `vibrobar lobe-design`; a finer band can only lower a worst case. The gains are damped \
         over solid. Where the damped run at a design's worst case is `chaotic`, its width at \
         that speed is searched again over {SPREAD_SEEDS} seeded perturbations of the \
         disturbance's amplitude (±{} %): the spread column.",
        SPREAD_REL * 100.0
    )?;
    writeln!(
        d,
        "- **Forced response.** The same designs under the paper's 15 N harmonic force at the \
         tip, Ω/ω₁ = {} ({} ratios), {} s from rest, RMS over the last {} %, exact solver \
         (`vibrobar map` on the lumped bar, `vibrobar placement` on the beam); score: the mean \
         RMS reduction over the ratios.\n",
        ratios
            .iter()
            .map(|r| fmt_coord(*r))
            .collect::<Vec<_>>()
            .join(", "),
        ratios.len(),
        forced.duration_s,
        forced.rms_fraction * 100.0
    )?;
    writeln!(d, "## The lumped bar: gap × ball mass\n")?;
    study_section(&mut d, lumped, &args.out)?;
    writeln!(d, "## The beam: gap × cavity position\n")?;
    match beam {
        Some(b) => study_section(&mut d, b, &args.out)?,
        None => writeln!(
            d,
            "Not computed in this run (`--lumped-only`). Regenerate without the flag to add it.\n"
        )?,
    }
    Ok(d)
}
