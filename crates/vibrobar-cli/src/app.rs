//! The application root: the subcommand table (clap) and the function each command runs.
//! Arrows point one way: this module uses [`crate::cli`] (shared argument types) and
//! [`crate::commands`]; neither imports it.

use anyhow::Result;
use clap::{CommandFactory, FromArgMatches, Parser, Subcommand};
use std::path::{Path, PathBuf};

use crate::commands::{
    beam, bench, contact_convergence, contact_laws, contact_test, explore, frf, lobes,
    lumped_vs_beam, map, merge, modes, orbit, paper, placement, run, sweep,
};

/// Vibro-impact boring-bar simulator: a bar with a free ball in a cavity, after the paper
/// "The effect of rolling friction on vibro-impact damped boring bars".
#[derive(Debug, Parser)]
#[command(name = "vibrobar", version)]
pub struct Cli {
    /// What to do.
    #[command(subcommand)]
    pub command: Command,
}

/// Parse the process arguments (see [`try_parse_from`]).
pub fn parse() -> Cli {
    try_parse_from(std::env::args_os()).unwrap_or_else(|e| e.exit())
}

/// Parse `args` (the first is the program name). A numeric flag followed by a negative number,
/// `--dt -1e-6`, is read as `--dt=-1e-6` ([`join_negative_numbers`]).
pub fn try_parse_from<I, T>(args: I) -> Result<Cli, clap::Error>
where
    I: IntoIterator<Item = T>,
    T: Into<std::ffi::OsString> + Clone,
{
    let cmd = Cli::command();
    let args = join_negative_numbers(&cmd, args.into_iter().map(Into::into).collect());
    Cli::from_arg_matches(&cmd.try_get_matches_from(args)?)
}

/// Rewrite `--flag -1e-6` as `--flag=-1e-6` when `--flag` is a numeric option of the
/// subcommand and the next word is a negative number.
///
/// clap's `allow_negative_numbers` only recognises digits with an exponent of digits, so
/// `--dt -1e-6` (a minus in the exponent) was "unexpected argument '-1' found" while
/// `--dt=-1e-6` gave the range error. `allow_hyphen_values` would fix that but also swallow the
/// next flag when a value is forgotten (`--gap-mm --out x`). Joining only a word that parses as
/// a number keeps clap's behaviour for everything else; the value's own parser and range check
/// then report it. Numeric options are found by their value type, wherever they are declared.
pub fn join_negative_numbers(
    cmd: &clap::Command,
    args: Vec<std::ffi::OsString>,
) -> Vec<std::ffi::OsString> {
    let mut out = Vec::with_capacity(args.len());
    let mut sub: Option<&clap::Command> = None;
    let mut it = args.into_iter().peekable();
    out.extend(it.next());
    while let Some(word) = it.next() {
        let Some(w) = word.to_str() else {
            out.push(word);
            continue;
        };
        if w == "--" {
            out.push(word);
            out.extend(it);
            break;
        }
        if sub.is_none() && !w.starts_with('-') {
            sub = cmd.find_subcommand(w);
        }
        let numeric_flag = w
            .strip_prefix("--")
            .filter(|name| !name.contains('='))
            .and_then(|name| sub?.get_arguments().find(|a| a.get_long() == Some(name)))
            .is_some_and(is_numeric);
        let negative_next = it.peek().and_then(|n| n.to_str()).is_some_and(|n| {
            n.starts_with('-') && n.split(',').all(|x| x.trim().parse::<f64>().is_ok())
        });
        if numeric_flag && negative_next {
            let value = it.next().expect("peeked");
            let mut joined = word;
            joined.push("=");
            joined.push(value);
            out.push(joined);
        } else {
            out.push(word);
        }
    }
    out
}

fn is_numeric(a: &clap::Arg) -> bool {
    use std::any::TypeId;
    let t = a.get_value_parser().type_id();
    a.get_action().takes_values()
        && [
            TypeId::of::<f64>(),
            TypeId::of::<u64>(),
            TypeId::of::<usize>(),
            TypeId::of::<u32>(),
            TypeId::of::<i64>(),
        ]
        .iter()
        .any(|n| t == *n)
}

/// The commands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Frequency sweep: RMS of the damped and the solid bar for each ratio and gap, as CSV.
    Sweep(crate::cli::SweepArgs),
    /// One run: time history as CSV and a one-screen summary.
    Run(crate::cli::RunArgs),
    /// Reproduce the paper: Figs. 2–5 (PNG + SVG), their CSVs and REPORT.md.
    Paper(crate::cli::PaperArgs),
    /// Time one paper run and the whole paper sweep set for every solver, in one process.
    Bench(crate::cli::BenchArgs),
    /// Lumped M, K of a round cantilever bar (optionally with a transverse cavity) from
    /// Euler–Bernoulli theory, for each reduction to one degree of freedom.
    Beam(crate::commands::beam::BeamArgs),
    /// Design map over frequency ratio × gap: RMS reduction, impacts per cycle, regime, optimum
    /// and heat maps; resumable (--resume) and shardable (--shard K/N). A [two_plane] scenario:
    /// ratio × axial gap × hole angle × hole diameter, each cell an ensemble of starts.
    Map(crate::commands::map::MapArgs),
    /// Merge map shards written with --shard K/N into the whole map (checks completeness).
    Merge(crate::commands::merge::MergeArgs),
    /// Stroboscopic Poincaré section of one run (CSV, NPY, figure); of one member's run for a
    /// [two_plane] scenario.
    Poincare(crate::commands::explore::PoincareArgs),
    /// Bifurcation diagram over the frequency ratio or the gap (CSV, NPY, figure).
    Bifurcation(crate::commands::explore::BifurcationArgs),
    /// Maximal Lyapunov exponent at one point (two-trajectory divergence with renormalisation);
    /// of one member's run for a [two_plane] scenario.
    Lyapunov(crate::commands::explore::LyapunovArgs),
    /// A periodic orbit of period k forcing cycles by Newton's method on the stroboscopic map:
    /// RMS, impacts, Floquet multipliers, stability and physicality checks (JSON); for a
    /// [two_plane] scenario whose planes decouple, the orbit one member settles on.
    Orbit(crate::commands::orbit::OrbitArgs),
    /// Pseudo-arclength continuation of a periodic orbit in one parameter, with folds, period
    /// doublings, torus and branch points, grazing and stick onset (CSV and figure); each
    /// plane's branch for a [two_plane] scenario whose planes decouple.
    Continue(crate::commands::orbit::ContinueArgs),
    /// Two-parameter continuation in (ratio, gap) of a fold, period-doubling, torus, branch-point
    /// or grazing point of a periodic orbit, with codimension-two points (CSV and figure).
    Continue2(crate::commands::continue2::Continue2Args),
    /// Write the generated Markdown document with the stability region of the symmetric
    /// two-impact orbit over ratio × gap (frictionless and Coulomb), its ends and their types.
    OrbitStability(crate::commands::orbit_docs::OrbitStabilityArgs),
    /// Seeded initial-condition ensemble: spread of RMS and regime counts per point.
    Ensemble(crate::commands::explore::EnsembleArgs),
    /// Time a 200 × 100 ratio × gap map (from a subsample) for each solver.
    BenchMap(crate::commands::map::BenchMapArgs),
    /// Modes of the bar at the cavity, force and response points (a [beam] scenario: the
    /// Euler–Bernoulli beam; otherwise the lumped bar's one mode), as CSV.
    Modes(crate::commands::modes::ModesArgs),
    /// Modes from a measured FRF (a tap test at the tool tip): LSCF poles with a stabilisation
    /// chart, residues, refinement; writes [[modes]] TOML with the chart and the fit beside it.
    FitModes(crate::commands::fit_modes::FitModesArgs),
    /// Write the worked example from a tap test to a design (a generated Markdown document):
    /// a known bar's tip and cross FRFs with 1 % noise as universal files, the modal fit, the
    /// lobes from the measurement and from the fit, the cavity placement and the lobe design
    /// on the fitted bar.
    TapTest(crate::commands::tap_test::TapTestArgs),
    /// Write the generated Markdown document comparing the one-plane model with the bar that
    /// bends in two planes (the ball in a hole across it, gravity, friction on its walls):
    /// seeded ensembles over force direction, hole, gap and ratio, and the hole-angle × gap map.
    TwoPlane(crate::commands::two_plane::TwoPlaneArgs),
    /// Cavity placement on a beam: position × gap over a band of ratios (mean reduction, worst
    /// RMS, regime), the optimum and a heat map with the nodes of modes 2 and 3; resumable
    /// (--resume) and shardable (--shard K/N). A [two_plane] scenario: each cell an ensemble of
    /// starts of the round beam with the ball in its hole.
    Placement(crate::commands::placement::PlacementArgs),
    /// Write the generated Markdown document comparing the paper's lumped bar with the N-mode
    /// beam at the paper's geometry, with the convergence study in the number of modes.
    LumpedVsBeam(crate::commands::lumped_vs_beam::LumpedVsBeamArgs),
    /// Write the generated Markdown document on what the ball damper buys against chatter at
    /// the paper's bar: lobe design of the tip-referred lumped bar and of the beam,
    /// against the solid bar and the forced-response optimum.
    CuttingDeeper(crate::commands::cutting_deeper::CuttingDeeperArgs),
    /// Single-impact laboratory of the hertz contact law: one impact on a rigid fixed wall per
    /// approach speed (contact time, restitution, peak force and penetration), as CSV.
    ContactTest(crate::commands::contact_test::ContactTestArgs),
    /// Write the generated Markdown document comparing the restitution and hertz contact laws
    /// on the lumped paper cases (sweeps, best gap, chaotic points by ensembles).
    ContactLaws(crate::commands::contact_laws::ContactLawsArgs),
    /// Write the generated study of the beam's answers against the number of modes under the
    /// restitution and hertz contact laws (Markdown, CSV and figure).
    ContactConvergence(crate::commands::contact_convergence::ContactConvergenceArgs),
    /// Exact linear stability lobes of regenerative chatter of a [cutting] scenario: the
    /// limiting width of cut over spindle speed for the damped bar (ball free, ball stuck) and
    /// the solid reference, as CSV and a figure.
    Lobes(crate::commands::lobes::LobesArgs),
    /// Width–amplitude diagram of a [cutting] scenario at one spindle speed: the
    /// settled vibration of the solid and the damped bar from the small and the large
    /// disturbance over a range of widths; resumable (--resume) and shardable (--shard K/N).
    WidthDiagram(crate::commands::time_domain::WidthDiagramArgs),
    /// Design by time-domain lobes of a [cutting] scenario: each gap × ball mass
    /// (lumped bar) or gap × cavity position (beam) scored by its worst-case acceptable width
    /// over a band of spindle speeds from the large disturbance, beside the solid bar; the
    /// optimum and a heat map; resumable (--resume) and shardable (--shard K/N).
    LobeDesign(crate::commands::lobe_design::LobeDesignArgs),
    /// Frequency response functions over a band in Hz: linear receptances of the solid bar and
    /// of the damped bar (ball free, ball stuck) between any two of the force, cavity and
    /// response points, the stepped sine of the nonlinear damped bar at a force level, and a
    /// simulated tap test (H1, coherence); CSV and a magnitude/phase figure.
    Frf(crate::commands::frf::FrfArgs),
}

impl Command {
    /// The command's name, as typed.
    pub fn name(&self) -> &'static str {
        match self {
            Command::Sweep(_) => "sweep",
            Command::Run(_) => "run",
            Command::Paper(_) => "paper",
            Command::Bench(_) => "bench",
            Command::Beam(_) => "beam",
            Command::Map(_) => "map",
            Command::Merge(_) => "merge",
            Command::Poincare(_) => "poincare",
            Command::Bifurcation(_) => "bifurcation",
            Command::Lyapunov(_) => "lyapunov",
            Command::Orbit(_) => "orbit",
            Command::Continue(_) => "continue",
            Command::Continue2(_) => "continue2",
            Command::OrbitStability(_) => "orbit-stability",
            Command::Ensemble(_) => "ensemble",
            Command::BenchMap(_) => "bench-map",
            Command::Modes(_) => "modes",
            Command::FitModes(_) => "fit-modes",
            Command::TapTest(_) => "tap-test",
            Command::TwoPlane(_) => "two-plane",
            Command::Placement(_) => "placement",
            Command::LumpedVsBeam(_) => "lumped-vs-beam",
            Command::CuttingDeeper(_) => "cutting-deeper",
            Command::ContactTest(_) => "contact-test",
            Command::ContactLaws(_) => "contact-laws",
            Command::ContactConvergence(_) => "contact-convergence",
            Command::Lobes(_) => "lobes",
            Command::WidthDiagram(_) => "width-diagram",
            Command::LobeDesign(_) => "lobe-design",
            Command::Frf(_) => "frf",
        }
    }

    /// The files the command reads (scenario, shards) and the output it is asked for.
    pub fn files(&self) -> (Vec<&Path>, Option<&Path>) {
        fn one(p: &Option<PathBuf>) -> Vec<&Path> {
            p.iter().map(PathBuf::as_path).collect()
        }
        match self {
            Command::Sweep(a) => (one(&a.model.scenario), Some(a.out.as_path())),
            Command::Run(a) => (one(&a.model.scenario), Some(a.out.as_path())),
            Command::Paper(a) => (vec![], Some(a.out.as_path())),
            Command::Bench(a) => (one(&a.scenario), None),
            Command::Beam(_) => (vec![], None),
            Command::Map(a) => (one(&a.system.scenario), Some(a.out.as_path())),
            Command::Merge(a) => (
                a.shards.iter().map(PathBuf::as_path).collect(),
                Some(a.out.as_path()),
            ),
            Command::Poincare(a) => (one(&a.point.system.scenario), Some(a.out.as_path())),
            Command::Bifurcation(a) => (one(&a.system.scenario), Some(a.out.as_path())),
            Command::Lyapunov(a) => (one(&a.point.system.scenario), None),
            Command::Orbit(a) => (one(&a.point.system.scenario), Some(a.out.as_path())),
            Command::Continue(a) => (one(&a.system.scenario), Some(a.out.as_path())),
            Command::Continue2(a) => (one(&a.system.scenario), Some(a.out.as_path())),
            Command::OrbitStability(a) => (vec![], Some(a.out.as_path())),
            Command::Ensemble(a) => (one(&a.system.scenario), Some(a.out.as_path())),
            Command::BenchMap(a) => (one(&a.scenario), None),
            Command::Modes(a) => (one(&a.scenario), Some(a.out.as_path())),
            Command::FitModes(a) => (crate::commands::fit_modes::inputs(a), Some(a.out.as_path())),
            Command::TapTest(a) => (vec![], Some(a.out.as_path())),
            Command::TwoPlane(a) => (vec![], Some(a.out.as_path())),
            Command::Placement(a) => (one(&a.system.scenario), Some(a.out.as_path())),
            Command::LumpedVsBeam(a) => (vec![], Some(a.out.as_path())),
            Command::CuttingDeeper(a) => (vec![], Some(a.out.as_path())),
            Command::ContactTest(a) => (one(&a.scenario), Some(a.out.as_path())),
            Command::ContactLaws(a) => (vec![], Some(a.out.as_path())),
            Command::ContactConvergence(a) => (vec![], Some(a.out.as_path())),
            Command::Lobes(a) => {
                let mut inputs = vec![a.scenario.as_path()];
                inputs.extend(a.frf.as_deref());
                (inputs, Some(a.out.as_path()))
            }
            Command::WidthDiagram(a) => (vec![a.scenario.as_path()], Some(a.out.as_path())),
            Command::LobeDesign(a) => (vec![a.scenario.as_path()], Some(a.out.as_path())),
            Command::Frf(a) => (one(&a.scenario), Some(a.out.as_path())),
        }
    }

    /// What an interrupt stops, for its message: `the map to m.csv`.
    pub fn describe(&self) -> String {
        match self.files().1 {
            Some(out) => format!("the {} to {}", self.name(), out.display()),
            None => format!("the {}", self.name()),
        }
    }
}

/// On SIGINT/SIGTERM, for every command: remove the partial files being written (no new one is
/// started from then on), say what was interrupted and which journals are kept, exit 130.
///
/// The process exits at once rather than raising the batch runner's cancel flag and waiting for
/// the runs in flight (which can each take minutes): every file it writes is either atomic
/// (`NAME.partial`, removed here) or a journal, whose rows are each one `write` (a torn last row
/// is dropped by `--resume`) and whose lock the kernel releases with the process. So an
/// interrupted `map` or `sweep` resumes to the byte-identical result.
pub fn install_interrupt_cleanup(what: String) {
    // A second call in one process (tests) keeps the first handler.
    let _ = ctrlc::set_handler(move || {
        let removed = vibrobar_io::close_for_exit();
        let kept = vibrobar_io::journal::close_for_exit();
        let list = |v: &[PathBuf]| {
            v.iter()
                .map(|p| p.display().to_string())
                .collect::<Vec<_>>()
                .join(", ")
        };
        let mut msg = format!("interrupted: {what} was not completed");
        if !removed.is_empty() {
            msg += &format!("; removed {}", list(&removed));
        }
        if !kept.is_empty() {
            msg += &format!("; kept {} (complete it with --resume)", list(&kept));
        }
        eprintln!("{msg}");
        std::process::exit(130);
    });
}

/// Before any command runs: its inputs become inputs of the process (no writer may replace them,
/// [`vibrobar_io::register_input`]), and an output that is one of them is refused at once, not
/// after the computation.
fn preflight(cmd: &Command) -> Result<()> {
    let (inputs, out) = cmd.files();
    for p in &inputs {
        vibrobar_io::register_input(p);
    }
    // Every command either runs a [cutting] scenario or refuses it, here, in one place.
    let name = cmd.name();
    if name != "merge" && !vibrobar_scenario::CUTTING_COMMANDS.contains(&name) {
        for p in &inputs {
            if std::fs::read_to_string(p).is_ok_and(|t| vibrobar_scenario::text_has_cutting(&t)) {
                anyhow::bail!(
                    "{} ({})",
                    vibrobar_scenario::cutting_refusal(name),
                    p.display()
                );
            }
        }
    }
    // And every command either runs a [two_plane] scenario or refuses it, here.
    if !vibrobar_scenario::TWO_PLANE_COMMANDS.contains(&name) {
        for p in &inputs {
            if std::fs::read_to_string(p).is_ok_and(|t| vibrobar_scenario::text_has_two_plane(&t)) {
                anyhow::bail!(
                    "{} ({})",
                    vibrobar_scenario::two_plane_refusal(name),
                    p.display()
                );
            }
        }
    }
    if let Some(out) = out {
        vibrobar_io::refuse_input(out)?;
    }
    Ok(())
}

/// Run the parsed command line.
pub fn dispatch(cli: Cli) -> Result<()> {
    preflight(&cli.command)?;
    match cli.command {
        Command::Sweep(a) => sweep::sweep(&a),
        Command::Run(a) => run::run(&a),
        Command::Paper(a) => paper::paper(&a),
        Command::Beam(a) => beam::beam(&a),
        Command::Map(a) => map::run(&a),
        Command::Merge(a) => merge::run(&a),
        Command::Poincare(a) => explore::run_poincare(&a),
        Command::Bifurcation(a) => explore::run_bifurcation(&a),
        Command::Lyapunov(a) => explore::run_lyapunov(&a),
        Command::Orbit(a) => orbit::run_orbit(&a),
        Command::Continue(a) => orbit::run_continue(&a),
        Command::Continue2(a) => crate::commands::continue2::run(&a),
        Command::OrbitStability(a) => crate::commands::orbit_docs::run(&a),
        Command::Ensemble(a) => explore::run_ensemble_cmd(&a),
        Command::BenchMap(a) => map::run_bench(&a),
        Command::Bench(a) => bench::bench(&a),
        Command::Modes(a) => modes::modes(&a),
        Command::FitModes(a) => crate::commands::fit_modes::run(&a),
        Command::TapTest(a) => crate::commands::tap_test::run(&a),
        Command::TwoPlane(a) => crate::commands::two_plane::run(&a),
        Command::Placement(a) => placement::run(&a),
        Command::LumpedVsBeam(a) => lumped_vs_beam::run(&a),
        Command::CuttingDeeper(a) => crate::commands::cutting_deeper::run(&a),
        Command::ContactTest(a) => contact_test::run(&a),
        Command::Lobes(a) => lobes::run(&a),
        Command::WidthDiagram(a) => crate::commands::time_domain::width_diagram(&a),
        Command::LobeDesign(a) => crate::commands::lobe_design::run(&a),
        Command::ContactLaws(a) => contact_laws::run(&a),
        Command::ContactConvergence(a) => contact_convergence::run(&a),
        Command::Frf(a) => frf::run(&a),
    }
}
