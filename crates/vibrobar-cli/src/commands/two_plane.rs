//! `vibrobar two-plane`: the generated document (`docs/two-plane.md`) that compares the
//! one-plane model with the bar that bends in two planes, at the paper's bar and ball.
//!
//! For holes of 15.1 mm and 17 mm around the 15 mm ball, axial gaps of 0.1 and 1.0 mm and
//! frequency ratios 0.97, 1 and 1.03 it runs seeded ensembles of the two-plane solvers (the
//! exact one on frictionless walls, the reference one with friction) at force directions from 0° to 90° from the hole, on frictionless walls and on walls with
//! friction and rolling resistance, beside the one-plane model from the same starts; then the
//! maps of hole angle × axial gap and of radial clearance × axial gap at the force of a
//! tangential/radial ratio of 2. The reductions
//! are of the RMS displacement along the force against the solid bar's. Every number is computed
//! by this run; the table of every point is written beside the document, the document last.

use super::check_value;
use crate::progress::Progress;
use anyhow::{bail, Context, Result};
use std::fmt::Write as _;
use std::path::PathBuf;
use std::time::Instant;
use vibrobar_core::analysis::two_plane::{
    one_plane_rms_m, one_plane_start, one_plane_system, starts, Spread, TwoPlaneEnsemble,
    TwoPlaneMethod,
};
use vibrobar_core::analysis::Runner;
use vibrobar_core::params::two_plane::{
    Gravity, Hole, PlanarBall, PlanarBar, PlanarForcing, TwoPlaneBar, TwoPlaneSystem,
};
use vibrobar_core::solver::two_plane_rk4::TwoPlaneStart;
use vibrobar_core::structure::{Beam, ModalModel};
use vibrobar_core::{Bar, Frequency, FrictionModel, RunSettings, State, System};

/// `vibrobar two-plane`.
#[derive(Debug, Clone, clap::Args)]
pub struct TwoPlaneArgs {
    /// The Markdown document to write (e.g. docs/two-plane.md); the table of every point goes
    /// to the directory of the same name without `.md`.
    #[arg(long, value_name = "FILE.md")]
    pub out: PathBuf,
    /// Simulated time of each run, s (RMS over its last 80 %).
    #[arg(long, default_value_t = 2.0, allow_negative_numbers = true)]
    pub duration: f64,
    /// Members of each design point's ensemble of starts.
    #[arg(long, default_value_t = 8)]
    pub members: usize,
    /// Seed of the ensembles' starts.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Short runs for tests: 0.1 s, 2 members, resonance only, two force directions.
    #[arg(long)]
    pub quick: bool,
}

/// Hole diameters around the 15 mm ball, mm.
const HOLES_MM: [f64; 2] = [15.1, 17.0];
/// Axial gaps, mm.
const GAPS_MM: [f64; 2] = [0.1, 1.0];
/// Frequency ratios.
const RATIOS: [f64; 3] = [0.97, 1.0, 1.03];
/// Force directions from the hole, degrees: along it, three round angles, the force ratios 2
/// and 3, across it.
const FORCE_DEG: [f64; 6] = [0.0, 30.0, 60.0, 63.4, 71.6, 90.0];
/// The map's hole angles and gaps (force at ratio 2, the 15.1 mm hole, resonance).
const MAP_HOLE_DEG: [f64; 7] = [0.0, 15.0, 30.0, 45.0, 60.0, 75.0, 90.0];
const MAP_GAPS_MM: [f64; 5] = [0.05, 0.1, 0.2, 0.5, 1.0];
/// The clearance map's hole diameters, mm (radial clearances 0.025–1 mm around the 15 mm ball;
/// a radial hole, the same force, resonance).
const MAP_DIAMETERS_MM: [f64; 6] = [15.05, 15.1, 15.3, 15.6, 16.0, 17.0];
/// Friction of the walls in the frictional runs.
const MU_S: f64 = 0.3;
const MU_K: f64 = 0.2;
const ETA_M: f64 = 0.6e-3;

/// One design point.
#[derive(Debug, Clone, Copy)]
struct Point {
    hole_mm: f64,
    gap_mm: f64,
    ratio: f64,
    /// Force angle from the radial direction; the hole is at `hole_deg`.
    force_deg: f64,
    hole_deg: f64,
    friction: bool,
    /// The paper's bar as a round beam of its modes instead of its lumped model.
    beam: bool,
}

/// The paper's bar as a beam (175 mm, 25 mm, the cavity 38 mm from the free end, force and
/// response at the tip), its modes by the default rule.
fn beam_model() -> Result<ModalModel> {
    static MODEL: std::sync::OnceLock<Result<ModalModel, String>> = std::sync::OnceLock::new();
    MODEL
        .get_or_init(|| Beam::default().modal_model().map_err(|e| e.to_string()))
        .clone()
        .map_err(|e| anyhow::anyhow!("the paper's beam: {e}"))
}

impl Point {
    fn system(&self) -> TwoPlaneSystem {
        let mut ball = PlanarBall::paper_frictionless();
        if self.friction {
            ball.friction_static = MU_S;
            ball.friction_kinetic = MU_K;
            ball.rolling_friction_m = ETA_M;
        }
        TwoPlaneSystem {
            bar: match (self.beam, beam_model()) {
                (true, Ok(m)) => TwoPlaneBar::Round(m),
                _ => PlanarBar::isotropic(&Bar::PAPER_CAVITY).into(),
            },
            ball,
            hole: Hole {
                angle_deg: self.hole_deg,
                axial_gap_m: self.gap_mm / 1e3,
                diameter_m: self.hole_mm / 1e3,
            },
            forcing: PlanarForcing {
                amplitude_n: 15.0,
                frequency: Frequency::Ratio(self.ratio),
                angle_deg: self.force_deg,
            },
            // Gravity along the tangential force, 90° from the radial direction.
            gravity: Gravity::default(),
            bar_diameter_m: None,
        }
    }

    /// The force's angle from the hole.
    fn relative_deg(&self) -> f64 {
        self.force_deg - self.hole_deg
    }
}

/// The design points of a radial hole: every hole × gap × ratio × force, in that order.
fn radial_grid(ratios: &[f64], forces: &[f64], friction: bool, beam: bool) -> Vec<Point> {
    let mut points = Vec::new();
    for hole_mm in HOLES_MM {
        for gap_mm in GAPS_MM {
            for &ratio in ratios {
                for &force_deg in forces {
                    points.push(Point {
                        hole_mm,
                        gap_mm,
                        ratio,
                        force_deg,
                        hole_deg: 0.0,
                        friction,
                        beam,
                    });
                }
            }
        }
    }
    points
}

/// One run's outcome.
#[derive(Debug, Clone, Copy)]
struct Outcome {
    rms_m: f64,
    impacts: u64,
    flight: f64,
}

/// A design point's answer: the members' reductions and their means.
#[derive(Debug, Clone, Copy)]
struct Answer {
    reduction: Spread,
    impacts: f64,
    flight: f64,
}

fn answer(outcomes: &[Outcome], solid_rms_m: f64) -> Answer {
    let red: Vec<f64> = outcomes
        .iter()
        .map(|o| 100.0 * (1.0 - o.rms_m / solid_rms_m))
        .collect();
    let n = outcomes.len() as f64;
    Answer {
        reduction: Spread::of(&red),
        impacts: outcomes.iter().map(|o| o.impacts as f64).sum::<f64>() / n,
        flight: outcomes.iter().map(|o| o.flight).sum::<f64>() / n,
    }
}

fn cell(a: &Answer) -> String {
    // Whole percent, without a "-0".
    let whole = |x: f64| {
        let r = x.round();
        if r == 0.0 {
            0.0
        } else {
            r
        }
    };
    format!(
        "{} ± {}",
        whole(a.reduction.mean),
        whole(a.reduction.std_err)
    )
}

/// What a run computes: duration, members, ratios, force directions, the maps' hole angles,
/// gaps and hole diameters.
type Plan = (f64, usize, Vec<f64>, Vec<f64>, Vec<f64>, Vec<f64>, Vec<f64>);

/// Run the command.
pub fn run(args: &TwoPlaneArgs) -> Result<()> {
    let t_start = Instant::now();
    if args.out.extension().and_then(|e| e.to_str()) != Some("md") {
        bail!(
            "--out must name a Markdown file ending in .md, got {}",
            args.out.display()
        );
    }
    let dir = args.out.with_extension("");
    let (duration, members, ratios, forces, map_holes, map_gaps, map_diameters): Plan =
        if args.quick {
            (
                0.1,
                2,
                vec![1.0],
                vec![0.0, 63.4],
                vec![0.0, 45.0],
                vec![0.1, 1.0],
                vec![15.1, 17.0],
            )
        } else {
            (
                check_value("--duration", args.duration, |x| x > 0.0, "(0, ∞) s")?,
                args.members,
                RATIOS.to_vec(),
                FORCE_DEG.to_vec(),
                MAP_HOLE_DEG.to_vec(),
                MAP_GAPS_MM.to_vec(),
                MAP_DIAMETERS_MM.to_vec(),
            )
        };
    let ens = TwoPlaneEnsemble {
        members,
        seed: args.seed,
        ..TwoPlaneEnsemble::default()
    };
    ens.validate()?;
    let settings = RunSettings {
        duration_s: duration,
        ..RunSettings::default()
    };
    settings.validate()?;
    let runner = Runner::default().with_threads(args.threads);

    // The design points: the comparison (hole at 0°, the force turned) and the map (force at
    // the ratio-2 angle, the hole turned).
    let mut points: Vec<Point> = [false, true]
        .iter()
        .flat_map(|&friction| radial_grid(&ratios, &forces, friction, false))
        .collect();
    let n_compare = points.len();
    let map_force = 2f64.atan().to_degrees();
    for &hole_deg in &map_holes {
        for &gap_mm in &map_gaps {
            points.push(Point {
                hole_mm: 15.1,
                gap_mm,
                ratio: 1.0,
                force_deg: map_force,
                hole_deg,
                friction: true,
                beam: false,
            });
        }
    }
    let n_angle = points.len();
    for &hole_mm in &map_diameters {
        for &gap_mm in &map_gaps {
            points.push(Point {
                hole_mm,
                gap_mm,
                ratio: 1.0,
                force_deg: map_force,
                hole_deg: 0.0,
                friction: true,
                beam: false,
            });
        }
    }
    // The beam: frictionless walls (its exact solver), the hole radial.
    let n_clear = points.len();
    beam_model()?;
    let beam_forces: Vec<f64> = forces
        .iter()
        .copied()
        .filter(|f| [0.0, 63.4, 71.6].iter().any(|x| (f - x).abs() < 1e-9))
        .collect();
    points.extend(radial_grid(&ratios, &beam_forces, false, true));
    // Every member of every point, run in parallel.
    let jobs: Vec<(usize, TwoPlaneStart)> = points
        .iter()
        .enumerate()
        .map(|(i, p)| starts(&p.system(), &ens).map(|s| s.into_iter().map(move |m| (i, m))))
        .collect::<Result<Vec<_>, _>>()?
        .into_iter()
        .flatten()
        .collect();
    eprintln!(
        "two-plane: {} design points × {members} members = {} runs of {duration} s",
        points.len(),
        jobs.len()
    );
    let method = TwoPlaneMethod::default();
    // Run times per solver: exact, reference.
    let timing = std::sync::Mutex::new([Vec::new(), Vec::new()]);
    let bar = Progress::new("two-plane runs", jobs.len(), 0);
    let cb = bar.callback();
    let two = runner.with_progress(&cb).each(&jobs, |(i, start)| {
        let sys = points[*i].system();
        let t0 = Instant::now();
        let s = method.run(&sys, start, &settings, &mut |_| {})?;
        let which = usize::from(method.solver_for(&sys) != "exact");
        timing.lock().map_err(|_| anyhow::anyhow!("timing lock"))?[which]
            .push(t0.elapsed().as_secs_f64());
        Ok::<_, anyhow::Error>(Outcome {
            rms_m: s.rms_along_force_m,
            impacts: s.impacts.iter().sum(),
            flight: s.flight_fraction,
        })
    });
    bar.finish();
    let two: Vec<Outcome> = two.map_err(|e| anyhow::anyhow!("two-plane runs: {e}"))?;
    // The check of the exact solver: the reference solver on the same members of the
    // frictionless points at resonance with the force at ratios 2 and 3.
    let checked: Vec<usize> = (0..n_compare)
        .filter(|&i| {
            let p = &points[i];
            !p.friction
                && p.ratio - 1.0 == 0.0
                && [63.4, 71.6].iter().any(|f| (p.force_deg - f).abs() < 1e-9)
        })
        .collect();
    let check_jobs: Vec<(usize, TwoPlaneStart)> = jobs
        .iter()
        .filter(|(i, _)| checked.contains(i))
        .copied()
        .collect();
    let reference = TwoPlaneMethod::Reference { dt_s: 1e-6 };
    let checks: Vec<Outcome> = runner
        .each(&check_jobs, |(i, start)| {
            let s = reference.run(&points[*i].system(), start, &settings, &mut |_| {})?;
            Ok::<_, anyhow::Error>(Outcome {
                rms_m: s.rms_along_force_m,
                impacts: s.impacts.iter().sum(),
                flight: s.flight_fraction,
            })
        })
        .map_err(|e| anyhow::anyhow!("reference runs: {e}"))?;
    // The one-plane model from the same starts (comparison points at force 0° stand for every
    // direction: the one-plane model has none).
    let one: Vec<Outcome> = runner
        .each(&jobs, |(i, start)| {
            let p = &points[*i];
            let sys = one_plane_system(
                &p.system(),
                if p.friction {
                    FrictionModel::Coulomb
                } else {
                    FrictionModel::None
                },
            );
            let rms = one_plane_rms_m(&sys, &one_plane_start(start), &settings)?;
            Ok::<_, anyhow::Error>(Outcome {
                rms_m: rms,
                impacts: 0,
                flight: 0.0,
            })
        })
        .map_err(|e| anyhow::anyhow!("one-plane runs: {e}"))?;
    // The solid bar at each ratio (the paper's: its own mass and stiffness, its own ratio).
    let solid: Vec<f64> = runner
        .each(&ratios, |&r| {
            one_plane_rms_m(&System::paper_solid(r), &State::REST, &settings)
        })
        .map_err(|e| anyhow::anyhow!("solid runs: {e}"))?;
    // The solid beam: the same beam without the ball, at the same frequencies.
    let solid_beam: Vec<f64> = runner
        .each(&ratios, |&r| {
            let p = Point {
                hole_mm: 15.1,
                gap_mm: 0.1,
                ratio: r,
                force_deg: 0.0,
                hole_deg: 0.0,
                friction: false,
                beam: true,
            };
            let mut sys = one_plane_system(&p.system(), FrictionModel::None);
            sys.damper = None;
            one_plane_rms_m(&sys, &State::REST, &settings)
        })
        .map_err(|e| anyhow::anyhow!("solid beam runs: {e}"))?;
    let solid_of = |p: &Point| {
        let i = ratios
            .iter()
            .position(|&x| x.to_bits() == p.ratio.to_bits())
            .unwrap_or(0);
        if p.beam {
            solid_beam[i]
        } else {
            solid[i]
        }
    };
    let group = |outs: &[Outcome], i: usize| -> Vec<Outcome> {
        jobs.iter()
            .zip(outs)
            .filter(|((j, _), _)| *j == i)
            .map(|(_, o)| *o)
            .collect()
    };
    let answers: Vec<(Answer, Answer)> = points
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let s = solid_of(p);
            (answer(&group(&two, i), s), answer(&group(&one, i), s))
        })
        .collect();

    let check_answers: Vec<(usize, Answer)> = checked
        .iter()
        .map(|&i| {
            let outs: Vec<Outcome> = check_jobs
                .iter()
                .zip(&checks)
                .filter(|((j, _), _)| *j == i)
                .map(|(_, o)| *o)
                .collect();
            (i, answer(&outs, solid_of(&points[i])))
        })
        .collect();

    // The table of every point.
    let mut csv = String::from(
        "bar,walls,hole_mm,axial_gap_mm,ratio,hole_deg,force_deg,force_from_hole_deg,model,\
         solver,reduction_mean_pct,reduction_std_err_pct,reduction_min_pct,reduction_max_pct,\
         members,impacts_mean,flight_fraction_mean\n",
    );
    let rows = points
        .iter()
        .zip(&answers)
        .enumerate()
        .flat_map(|(i, (p, (two_a, one_a)))| {
            let check = check_answers.iter().find(|(j, _)| *j == i).map(|(_, a)| a);
            [
                Some(("two-plane", method.solver_for(&p.system()), two_a)),
                check.map(|a| ("two-plane", "reference", a)),
                Some(("one-plane", "exact", one_a)),
            ]
            .into_iter()
            .flatten()
            .map(move |(model, solver, a)| (p, model, solver, a))
        });
    for (p, model, solver, a) in rows {
        {
            let r = a.reduction;
            writeln!(
                csv,
                "{},{},{},{},{},{},{},{},{model},{solver},{:.3},{:.3},{:.3},{:.3},{},{:.1},{:.4}",
                if p.beam { "beam" } else { "lumped" },
                if p.friction {
                    "friction"
                } else {
                    "frictionless"
                },
                p.hole_mm,
                p.gap_mm,
                p.ratio,
                p.hole_deg,
                p.force_deg,
                p.relative_deg(),
                r.mean,
                r.std_err,
                r.min,
                r.max,
                r.n,
                a.impacts,
                a.flight
            )?;
        }
    }
    let csv_path = dir.join("points.csv");
    std::fs::create_dir_all(&dir).with_context(|| format!("creating {}", dir.display()))?;
    vibrobar_io::csv::write_text(&csv_path, &csv)
        .with_context(|| format!("writing {}", csv_path.display()))?;

    let times = timing.into_inner().unwrap_or_default();
    let median = |v: &[f64]| {
        let mut sorted = v.to_vec();
        sorted.sort_by(f64::total_cmp);
        sorted.get(sorted.len() / 2).copied().unwrap_or(0.0)
    };
    let median_run_s = [median(&times[0]), median(&times[1])];
    let doc = document(&Doc {
        points: &points,
        answers: &answers,
        n_compare,
        n_angle,
        n_clear,
        beam_forces: &beam_forces,
        map_diameters: &map_diameters,
        ratios: &ratios,
        forces: &forces,
        map_holes: &map_holes,
        map_gaps: &map_gaps,
        map_force,
        members,
        seed: args.seed,
        duration,
        median_run_s,
        check_answers: &check_answers,
        quick: args.quick,
        csv_name: format!(
            "{}/points.csv",
            dir.file_name()
                .and_then(|n| n.to_str())
                .unwrap_or("two-plane")
        ),
    })?;
    vibrobar_io::csv::write_text(&args.out, &doc)
        .with_context(|| format!("writing {}", args.out.display()))?;
    println!(
        "wrote {} and {} ({:.0} s)",
        args.out.display(),
        csv_path.display(),
        t_start.elapsed().as_secs_f64()
    );
    Ok(())
}

struct Doc<'a> {
    points: &'a [Point],
    answers: &'a [(Answer, Answer)],
    n_compare: usize,
    /// The end of the hole-angle map; the clearance map follows.
    n_angle: usize,
    /// The end of the clearance map; the beam's points follow.
    n_clear: usize,
    beam_forces: &'a [f64],
    map_diameters: &'a [f64],
    ratios: &'a [f64],
    forces: &'a [f64],
    map_holes: &'a [f64],
    map_gaps: &'a [f64],
    map_force: f64,
    members: usize,
    seed: u64,
    duration: f64,
    /// Median run time of the exact and the reference solver.
    median_run_s: [f64; 2],
    /// The reference solver's answers at the points that check the exact one.
    check_answers: &'a [(usize, Answer)],
    quick: bool,
    csv_name: String,
}

impl Doc<'_> {
    fn find(
        &self,
        friction: bool,
        hole_mm: f64,
        gap_mm: f64,
        ratio: f64,
        force: f64,
    ) -> Option<&(Answer, Answer)> {
        self.points[..self.n_compare]
            .iter()
            .position(|p| {
                !p.beam
                    && p.friction == friction
                    && p.hole_mm.to_bits() == hole_mm.to_bits()
                    && p.gap_mm.to_bits() == gap_mm.to_bits()
                    && p.ratio.to_bits() == ratio.to_bits()
                    && p.force_deg.to_bits() == force.to_bits()
            })
            .map(|i| &self.answers[i])
    }
}

/// A map's rows (`label` over `values`, each point's row value read by `of`) × the gaps, as a
/// Markdown table of the points `range`; returns its best cell `(row value, gap, mean)`.
type MapRows<'a> = (
    &'a str,
    &'a [f64],
    &'a dyn Fn(f64) -> String,
    &'a dyn Fn(&Point) -> f64,
);

fn map_table(
    s: &mut String,
    d: &Doc,
    range: std::ops::Range<usize>,
    (label, values, name, of): MapRows,
) -> Result<Option<(f64, f64, f64)>> {
    let mut head = format!("| {label} |");
    let mut rule = String::from("|---|");
    for g in d.map_gaps {
        write!(head, " gap {g} mm |")?;
        rule.push_str("---|");
    }
    writeln!(s, "{head}\n{rule}")?;
    let offset = range.start;
    let map = &d.points[range];
    let mut best: Option<(f64, f64, f64)> = None;
    for &h in values {
        let mut row = format!("| {} |", name(h));
        for &g in d.map_gaps {
            let i = map
                .iter()
                .position(|p| of(p).to_bits() == h.to_bits() && p.gap_mm.to_bits() == g.to_bits())
                .map(|i| i + offset)
                .expect("computed");
            let a = d.answers[i].0;
            write!(row, " {} |", cell(&a))?;
            if best.is_none_or(|b| a.reduction.mean > b.2) {
                best = Some((h, g, a.reduction.mean));
            }
        }
        writeln!(s, "{row}")?;
    }
    Ok(best)
}

fn document(d: &Doc) -> Result<String> {
    let mut s = String::new();
    let regen = if d.quick {
        "vibrobar two-plane --quick --out docs/two-plane.md"
    } else {
        "vibrobar two-plane --out docs/two-plane.md"
    };
    writeln!(
        s,
        "# One plane or two: the ball in a hole across a round bar\n"
    )?;
    writeln!(
        s,
        "Generated by `{regen}` (every number below is computed by that run; the table of every \
         point is [`{}`]({})).\n",
        d.csv_name, d.csv_name
    )?;
    writeln!(
        s,
        "The paper's model is one-plane: the bar bends in one direction, the ball moves along \
         the hole and the force acts along it. A boring bar is round, so it bends alike in \
         both planes of its cross-section; the cutting force points 63–72° away from the radial \
         direction (a tangential/radial force ratio of 2–3); and the ball sits in a cylindrical \
         hole: along it the end plugs leave the axial gap, across it the hole leaves the radial \
         clearance `c_r = (d_hole − d_ball)/2`, and gravity presses the ball on the hole's \
         wall.\n"
    )?;
    writeln!(s, "## The model\n")?;
    writeln!(
        s,
        "- **The bar:** the paper's lumped bar (M = 0.644 kg, K = 9.22 MN/m, ζ = 0.01) in both \
         planes. The reductions are against the paper's solid bar (0.668 kg, 9.26 MN/m) at the \
         same frequency ratio, each of its own natural frequency, as in the paper.\n\
         - **The ball:** 26 g, 15 mm, restitution 0.5 on every wall, in holes of 15.1 mm \
         (c_r = 0.05 mm) and 17 mm (c_r = 1 mm). Its motion along the bar's axis is not modelled.\n\
         - **Angles** are measured in the cross-section plane from the radial direction towards \
         the tangential one. The hole is drilled radially (0°) in the comparison; the force \
         points at 0°–90° from it; gravity (9.80665 m/s²) acts along the tangential force (90°), \
         which is down on a horizontal lathe with the insert at centre height. The feed force \
         (it acts through a moment arm only) and torsion (its first mode lies far above the \
         band) are neglected.\n\
         - **The walls:** frictionless, or with friction μ_s = {MU_S}, μ_k = {MU_K} and the \
         paper's rolling resistance η = {} mm. With friction the ball rolls, slides or sticks on \
         the wall it rests on, and its spin enters every impact (Stronge's law with Coulomb \
         friction). The one-plane model beside it has the same ball in a slot along the hole \
         with the axial gap, the whole force along it, and the physically consistent Coulomb \
         friction `(η/r)·m_d·g` (or none, beside the frictionless walls).\n\
         - **The force:** 15 N, harmonic. **The runs:** {} s, RMS along the force over the last \
         80 %.\n\
         - **The solvers:** on frictionless walls the exact event-driven solver: there the \
         ball's motions along and across the hole are two separate impact dampers and a round \
         bar's planes two separate oscillators, so a run is two one-plane exact runs, their RMS \
         along the force put together with the cross term of the planes (its tests check it \
         against the closed form of the bar alone and against the reference solver). With \
         friction the planes couple through the normal force, and the two-plane reference solver \
         runs: classical RK4 at 1 µs with every impact, lift-off and change between rolling, \
         sliding and sticking located inside its step, and a resting mode per wall. Its tests \
         check it against closed forms (a dropped ball, a carried ball, lift-off where the \
         cavity's acceleration reaches g, rolling at 5/7, the slip threshold (7/2)·μ_s·g, \
         rolling resistance, energy books to 1e-8) and against the one-plane exact solver, which \
         it reproduces to 1e-10 s with the force along the hole. The one-plane runs use the \
         exact solver.\n\
         - **Ensembles:** where the ball starts decides which of coexisting motions a run \
         settles on, so each design point is {} runs: the ball at rest on the wall gravity \
         presses it onto, centred along the hole, and {} starts at seeded random places along \
         the hole with up to 0.01 m/s along it and across it, away from the wall (seed {}); on \
         frictionless walls the motions along and across the hole are independent, so both are \
         varied. Cells give the mean reduction ± its standard error, in %; the CSV has the range. The median run took {:.3} s on the exact \
         solver and {:.2} s on the reference one.\n",
        ETA_M * 1e3,
        d.duration,
        d.members,
        d.members.saturating_sub(1),
        d.seed,
        d.median_run_s[0],
        d.median_run_s[1]
    )?;

    // The exact solver against the reference.
    if !d.check_answers.is_empty() {
        writeln!(
            s,
            "## The exact solver against the reference\n\n\
             The same members on the reference solver, frictionless walls, r = 1: mean reduction \
             ± its standard error, %. The motion is chaotic at most of these points, so single \
             runs differ; the ensemble means agree where they differ by less than two combined \
             standard errors.\n\n\
             | hole | gap | force | exact | reference | agree |\n|---|---|---|---|---|---|"
        )?;
        for (i, r) in d.check_answers {
            let p = &d.points[*i];
            let e = &d.answers[*i].0;
            let diff = (e.reduction.mean - r.reduction.mean).abs();
            let both = e.reduction.std_err.hypot(r.reduction.std_err);
            writeln!(
                s,
                "| {} mm | {} mm | {}° | {} | {} | {} |",
                p.hole_mm,
                p.gap_mm,
                p.force_deg,
                cell(e),
                cell(r),
                if diff <= 2.0 * both { "yes" } else { "no" }
            )?;
        }
        writeln!(s)?;
    }

    for friction in [false, true] {
        writeln!(
            s,
            "## One plane against two planes, {} walls\n",
            if friction {
                "frictional"
            } else {
                "frictionless"
            }
        )?;
        writeln!(
            s,
            "Reduction of the RMS along the force against the solid bar, %. Columns: the \
             one-plane model, then two planes with the force at the angle given from the hole.\n"
        )?;
        let mut head = String::from("| hole | gap | r | one plane |");
        let mut rule = String::from("|---|---|---|---|");
        for f in d.forces {
            write!(head, " {f}° |")?;
            rule.push_str("---|");
        }
        writeln!(s, "{head}\n{rule}")?;
        for hole in HOLES_MM {
            for gap in GAPS_MM {
                for &r in d.ratios {
                    let Some((_, one)) = d.find(friction, hole, gap, r, d.forces[0]) else {
                        continue;
                    };
                    let mut row = format!("| {hole} mm | {gap} mm | {r} | {} |", cell(one));
                    for &f in d.forces {
                        let (two, _) = d.find(friction, hole, gap, r, f).expect("computed");
                        write!(row, " {} |", cell(two))?;
                    }
                    writeln!(s, "{row}")?;
                }
            }
        }
        writeln!(s)?;
    }

    // The beam.
    writeln!(
        s,
        "## The beam referred to the tip\n\n\
         The paper's bar as an Euler–Bernoulli beam (L = 175 mm, D = 25 mm, steel, ζ = 0.01 in \
         every mode, the cavity 38 mm from the free end, the force and the response at the tip) \
         with its first {} modes in each plane, round, on frictionless walls (the exact solver), \
         the hole radial. Reduction of the tip's RMS along the force against the same beam \
         without the ball at the same frequency, %; r refers to the first mode. The one-plane \
         column is the same beam with the ball in a slot along the hole and the whole force \
         along it.\n",
        beam_model()?.len()
    )?;
    let mut head = String::from("| hole | gap | r | one plane |");
    let mut rule = String::from("|---|---|---|---|");
    for f in d.beam_forces {
        write!(head, " {f}° |")?;
        rule.push_str("---|");
    }
    writeln!(s, "{head}\n{rule}")?;
    let beam_points = &d.points[d.n_clear..];
    let beam_at = |hole: f64, gap: f64, r: f64, f: f64| {
        beam_points
            .iter()
            .position(|p| {
                p.hole_mm.to_bits() == hole.to_bits()
                    && p.gap_mm.to_bits() == gap.to_bits()
                    && p.ratio.to_bits() == r.to_bits()
                    && p.force_deg.to_bits() == f.to_bits()
            })
            .map(|i| &d.answers[d.n_clear + i])
    };
    for hole in HOLES_MM {
        for gap in GAPS_MM {
            for &r in d.ratios {
                let Some((_, one)) = d
                    .beam_forces
                    .first()
                    .and_then(|&f| beam_at(hole, gap, r, f))
                else {
                    continue;
                };
                let mut row = format!("| {hole} mm | {gap} mm | {r} | {} |", cell(one));
                for &f in d.beam_forces {
                    let (two, _) = beam_at(hole, gap, r, f).expect("computed");
                    write!(row, " {} |", cell(two))?;
                }
                writeln!(s, "{row}")?;
            }
        }
    }
    writeln!(s)?;

    // The map.
    writeln!(
        s,
        "## Where to drill the hole: hole angle × axial gap\n\n\
         The 15.1 mm hole, frictional walls, r = 1, the force at {:.1}° from the radial \
         direction (a tangential/radial ratio of 2), gravity at 90°. Mean reduction ± its \
         standard error, %.\n",
        d.map_force
    )?;
    let best = map_table(
        &mut s,
        d,
        d.n_compare..d.n_angle,
        ("hole angle", d.map_holes, &|h| format!("{h}°"), &|p| {
            p.hole_deg
        }),
    )?;
    if let Some((h, g, m)) = best {
        writeln!(
            s,
            "\nThe best cell: the hole at {h}° with the {g} mm gap, {m:.0} % on average over the \
             ensemble.\n"
        )?;
    }

    // The clearance map.
    writeln!(
        s,
        "## How tight a hole: radial clearance × axial gap\n\n\
         A radial hole (0°), frictional walls, r = 1, the force at {:.1}°, gravity at 90°, the \
         15 mm ball. Mean reduction ± its standard error, %.\n",
        d.map_force
    )?;
    let best = map_table(
        &mut s,
        d,
        d.n_angle..d.n_clear,
        (
            "hole (c_r)",
            d.map_diameters,
            &|h| format!("{h} mm ({:.3} mm)", (h - 15.0) / 2.0),
            &|p| p.hole_mm,
        ),
    )?;
    if let Some((h, g, m)) = best {
        writeln!(
            s,
            "\nThe best cell: the {h} mm hole with the {g} mm gap, {m:.0} % on average over the \
             ensemble.\n"
        )?;
    }

    // What survives.
    writeln!(s, "## Which of the paper's conclusions survive\n")?;
    let along = d.forces[0];
    let ratio2 = d
        .forces
        .iter()
        .copied()
        .find(|f| (f - 63.4).abs() < 1e-9)
        .unwrap_or(along);
    let ratio3 = d
        .forces
        .iter()
        .copied()
        .find(|f| (f - 71.6).abs() < 1e-9)
        .unwrap_or(ratio2);
    if let (Some((two_big, one_big)), Some((two_big3, _))) = (
        d.find(false, 15.1, 1.0, 1.0, ratio2),
        d.find(false, 15.1, 1.0, 1.0, ratio3),
    ) {
        let verdict = if two_big.reduction.mean - one_big.reduction.mean > 10.0 {
            "does not survive"
        } else {
            "survives"
        };
        writeln!(
            s,
            "- **\"The 1.0 mm gap does little at resonance\"** {verdict}: one plane gives {} %, \
             two planes with the tight 15.1 mm hole {} % and {} % at force ratios 2 and 3. \
             Across the hole the 0.05 mm clearance and gravity make a second impact damper.",
            cell(one_big),
            cell(two_big),
            cell(two_big3)
        )?;
    }
    if let (Some((two_small, one_small)), Some((two_small3, _)), Some((two_tight, _))) = (
        d.find(false, 17.0, 0.1, 1.0, ratio2),
        d.find(false, 17.0, 0.1, 1.0, ratio3),
        d.find(false, 15.1, 0.1, 1.0, ratio2),
    ) {
        let verdict = |two: &Answer| {
            if one_small.reduction.mean - two.reduction.mean > 10.0 {
                "does not survive"
            } else {
                "survives"
            }
        };
        writeln!(
            s,
            "- **\"The 0.1 mm gap damps strongly at resonance\"** {} in a tight 15.1 mm hole \
             ({} % at force ratio 2, against {} % in one plane) and {} in a loose 17 mm hole: \
             {} % and {} % at force ratios 2 and 3. There the force's component along the hole \
             is smaller, and across it the 1 mm clearance is too wide to damp.",
            verdict(two_tight),
            cell(two_tight),
            cell(one_small),
            verdict(two_small),
            cell(two_small),
            cell(two_small3)
        )?;
    }
    if let Some((two_al, one_al)) = d.find(false, 17.0, 0.1, 1.0, along) {
        writeln!(
            s,
            "- **With the force along the hole** the two models agree on frictionless walls (a \
             check, not a result): {} % against {} % (17 mm hole, 0.1 mm gap, r = 1).",
            cell(two_al),
            cell(one_al)
        )?;
    }
    // The beam: the 1 mm gap's reversal.
    let beam_points = &d.points[d.n_clear..];
    let beam_cell = |gap: f64, f: f64| {
        beam_points
            .iter()
            .position(|p| {
                p.hole_mm.to_bits() == 15.1f64.to_bits()
                    && p.gap_mm.to_bits() == gap.to_bits()
                    && p.ratio.to_bits() == 1f64.to_bits()
                    && p.force_deg.to_bits() == f.to_bits()
            })
            .map(|i| &d.answers[d.n_clear + i])
    };
    if let (Some((two2, one)), Some((two3, _))) = (beam_cell(1.0, ratio2), beam_cell(1.0, ratio3)) {
        let verdict = if two2.reduction.mean - one.reduction.mean > 10.0 {
            "does not survive either"
        } else {
            "survives"
        };
        writeln!(
            s,
            "- **On the beam referred to the tip** the same conclusion {verdict}: one plane \
             {} %, two planes {} % and {} % at force ratios 2 and 3 (15.1 mm hole, r = 1).",
            cell(one),
            cell(two2),
            cell(two3)
        )?;
    }
    // Friction on the walls: the largest change of a two-plane mean between the tables.
    let mut largest: Option<(f64, &Point)> = None;
    for (p, (two, _)) in d.points[..d.n_compare].iter().zip(d.answers) {
        if p.friction {
            if let Some((plain, _)) = d.find(false, p.hole_mm, p.gap_mm, p.ratio, p.force_deg) {
                let diff = two.reduction.mean - plain.reduction.mean;
                if largest.is_none_or(|(x, _)| diff.abs() > x.abs()) {
                    largest = Some((diff, p));
                }
            }
        }
    }
    if let Some((diff, p)) = largest {
        writeln!(
            s,
            "- **Friction on the walls** (μ_s = {MU_S}, η = {} mm) changes the two-plane answers \
             by at most {:.0} points in these tables (the {} mm hole, {} mm gap, r = {}, force \
             at {}°). The one-plane model's friction is the paper's rolling friction as a \
             Coulomb force.\n",
            ETA_M * 1e3,
            diff.abs(),
            p.hole_mm,
            p.gap_mm,
            p.ratio,
            p.force_deg
        )?;
    }
    writeln!(
        s,
        "Read these as a model's answers, not a measurement: the walls are rigid (restitution), \
         the beam runs on frictionless walls only, measured modes with their own directions in \
         the cross-section are not covered, and the ensembles are small."
    )?;
    Ok(s)
}

/// Seconds of CPU the process has used (all its threads); the wall clock where the platform
/// gives no process clock.
fn cpu_seconds() -> f64 {
    #[cfg(unix)]
    {
        let mut ts = libc::timespec {
            tv_sec: 0,
            tv_nsec: 0,
        };
        // SAFETY: `ts` is a valid, writable timespec; the call only writes it.
        if unsafe { libc::clock_gettime(libc::CLOCK_PROCESS_CPUTIME_ID, &mut ts) } == 0 {
            return ts.tv_sec as f64 + 1e-9 * ts.tv_nsec as f64;
        }
    }
    static START: std::sync::OnceLock<Instant> = std::sync::OnceLock::new();
    START.get_or_init(Instant::now).elapsed().as_secs_f64()
}

/// `vibrobar bench`'s two-plane row: a two-plane run on the exact solver against the one-plane
/// run of the same design point (the 15.1 mm hole, the 0.1 mm gap, r = 1, the force at 63.4°,
/// frictionless walls, the ball resting on the floor), both 2 s; the cost per event in CPU time
/// (the two-plane run uses a second thread) and in wall time, medians over alternating pairs;
/// and the reference solver's run of the same point.
pub fn bench_row(pairs: usize) -> Result<()> {
    let sys = Point {
        hole_mm: 15.1,
        gap_mm: 0.1,
        ratio: 1.0,
        force_deg: 63.4,
        hole_deg: 0.0,
        friction: false,
        beam: false,
    }
    .system();
    let start = TwoPlaneStart::resting(&sys, 0.0);
    let settings = RunSettings {
        duration_s: 2.0,
        ..RunSettings::default()
    };
    let one = one_plane_system(&sys, FrictionModel::None);
    let one_start = one_plane_start(&start);
    // (wall s, CPU s, events) of one run.
    let time = |f: &mut dyn FnMut() -> Result<u64>| -> Result<(f64, f64, u64)> {
        let (t, c) = (Instant::now(), cpu_seconds());
        let n = f()?;
        Ok((t.elapsed().as_secs_f64(), cpu_seconds() - c, n.max(1)))
    };
    // The one-plane run with the outputs the two-plane run has: RMS, impacts and the energy
    // book.
    let mut run_one = || -> Result<u64> {
        struct Count(u64);
        impl vibrobar_core::solver::Observer for Count {
            fn event(&mut self, _: &vibrobar_core::solver::Event) {
                self.0 += 1;
            }
        }
        let mut obs = (
            Count(0),
            vibrobar_core::analysis::energy::EnergyAudit::new(&one),
        );
        vibrobar_core::analysis::run_case(
            &one,
            &one_start,
            &settings,
            &vibrobar_core::solver::Exact::default(),
            &mut obs,
        )?;
        Ok(obs.0 .0)
    };
    let run_two = |method: TwoPlaneMethod| -> Result<u64> {
        Ok(method.run(&sys, &start, &settings, &mut |_| {})?.events)
    };
    // Warm-up.
    time(&mut run_one)?;
    time(&mut || run_two(TwoPlaneMethod::Exact))?;
    let (mut cpu_ratio, mut wall_ratio, mut t_one, mut t_two) =
        (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let mut events = (0, 0);
    for _ in 0..pairs.max(1) {
        let a = time(&mut run_one)?;
        let b = time(&mut || run_two(TwoPlaneMethod::Exact))?;
        events = (a.2, b.2);
        cpu_ratio.push((b.1 / b.2 as f64) / (a.1 / a.2 as f64));
        wall_ratio.push((b.0 / b.2 as f64) / (a.0 / a.2 as f64));
        t_one.push(a.0);
        t_two.push(b.0);
    }
    let med = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    let reference = time(&mut || run_two(TwoPlaneMethod::Reference { dt_s: 1e-6 }))?;
    println!(
        "  exact  two-plane run (15.1 mm hole, 0.1 mm gap, r = 1, force at 63.4°, 2 s, {} \
         events): median {} against the one-plane run's {} ({} events; both with their energy \
         books); per event {:.2}× in CPU \
         time, {:.2}× in wall time (medians of {} alternating pairs; target: ≤ 2.5×); the \
         reference solver takes {} ({:.0}× the exact two-plane run)",
        events.1,
        super::fmt_secs(med(&mut t_two)),
        super::fmt_secs(med(&mut t_one)),
        events.0,
        med(&mut cpu_ratio),
        med(&mut wall_ratio),
        pairs.max(1),
        super::fmt_secs(reference.0),
        reference.0 / med(&mut t_two)
    );
    Ok(())
}

/// The paper's gap claims on the bar that bends in two planes, for `vibrobar paper`'s report:
/// the 15.1 mm and 17 mm holes, the 0.1 and 1.0 mm gaps, the force at the ratio-2 and ratio-3
/// directions from a radial hole, frictionless walls, r = 1, ensembles of `members`; reductions
/// against the paper's solid bar.
pub fn paper_check(
    settings: &RunSettings,
    members: usize,
) -> Result<Vec<vibrobar_report::report::TwoPlanePoint>> {
    let ens = TwoPlaneEnsemble {
        members,
        ..TwoPlaneEnsemble::default()
    };
    let points = radial_grid(&[1.0], &[63.4, 71.6], false, false);
    let systems: Vec<TwoPlaneSystem> = points.iter().map(Point::system).collect();
    let method = TwoPlaneMethod::default();
    let answers = vibrobar_core::analysis::two_plane::design_points(
        &systems,
        &ens,
        method,
        settings,
        &Runner::default(),
    )
    .map_err(|e| anyhow::anyhow!("two-plane runs: {e}"))?;
    let solid = one_plane_rms_m(&System::paper_solid(1.0), &State::REST, settings)?;
    let pct = |rms: &mut dyn Iterator<Item = f64>| {
        let red: Vec<f64> = rms.map(|r| 100.0 * (1.0 - r / solid)).collect();
        let s = Spread::of(&red);
        (s.mean, s.std_err)
    };
    Ok(points
        .iter()
        .zip(&answers)
        .map(|(p, a)| vibrobar_report::report::TwoPlanePoint {
            hole_mm: p.hole_mm,
            gap_mm: p.gap_mm,
            force_deg: p.force_deg,
            one_plane_pct: pct(&mut a.one_plane_rms_m.iter().copied()),
            two_plane_pct: pct(&mut a.members.iter().map(|m| m.rms_along_force_m)),
            members,
            solver: a.solver.into(),
        })
        .collect())
}
