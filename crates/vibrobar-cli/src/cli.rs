//! Command-line definitions (clap derive). Units are in every flag name or help text.

use clap::{Args, CommandFactory, FromArgMatches, Parser, Subcommand, ValueEnum};
use std::path::PathBuf;
use vibrobar_core::FrictionModel;

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
    Sweep(SweepArgs),
    /// One run: time history as CSV and a one-screen summary.
    Run(RunArgs),
    /// Reproduce the paper: Figs. 2–5 (PNG + SVG), their CSVs and REPORT.md.
    Paper(PaperArgs),
    /// Time one paper run and the whole paper sweep set for every solver, in one process.
    Bench(BenchArgs),
    /// Lumped M, K of a round cantilever bar (optionally with a transverse cavity) from
    /// Euler–Bernoulli theory, for each reduction to one degree of freedom.
    Beam(crate::commands::beam::BeamArgs),
    /// Design map over frequency ratio × gap: RMS reduction, impacts per cycle, regime, optimum
    /// and heat maps; resumable (--resume) and shardable (--shard K/N).
    Map(crate::commands::map::MapArgs),
    /// Merge map shards written with --shard K/N into the whole map (checks completeness).
    Merge(crate::commands::merge::MergeArgs),
    /// Stroboscopic Poincaré section of one run (CSV, NPY, figure).
    Poincare(crate::commands::explore::PoincareArgs),
    /// Bifurcation diagram over the frequency ratio or the gap (CSV, NPY, figure).
    Bifurcation(crate::commands::explore::BifurcationArgs),
    /// Maximal Lyapunov exponent at one point (two-trajectory divergence with renormalisation).
    Lyapunov(crate::commands::explore::LyapunovArgs),
    /// Seeded initial-condition ensemble: spread of RMS and regime counts per point.
    Ensemble(crate::commands::explore::EnsembleArgs),
    /// Time a 200 × 100 ratio × gap map (from a subsample) for each solver.
    BenchMap(crate::commands::map::BenchMapArgs),
}

/// Built-in parameter sets.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Preset {
    /// Every value of the paper (M = 0.644 kg, K = 9.22 MN/m, 26 g ball, e = 0.5, F0 = 15 N, …).
    Paper,
}

/// Friction law between ball and bar.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum FrictionArg {
    /// Frictionless.
    None,
    /// The paper's Eqs. 1–3 as printed: F_ball = +F sgn(ẇ); this sign injects energy.
    AsPublished,
    /// Dissipative dry friction: F_ball = −F sgn(ẇ), with sticking.
    Coulomb,
}

impl From<FrictionArg> for FrictionModel {
    fn from(f: FrictionArg) -> Self {
        match f {
            FrictionArg::None => FrictionModel::None,
            FrictionArg::AsPublished => FrictionModel::AsPublished,
            FrictionArg::Coulomb => FrictionModel::Coulomb,
        }
    }
}

/// Where the parameters come from, and the overrides shared by `sweep` and `run`.
#[derive(Debug, Clone, Args)]
pub struct ModelArgs {
    /// Built-in parameter set (the default when no --scenario is given).
    #[arg(long, value_enum, conflicts_with = "scenario")]
    pub preset: Option<Preset>,
    /// Scenario file (TOML, SI units; fields not given keep the paper's values). Flags override it.
    #[arg(long, value_name = "FILE.toml")]
    pub scenario: Option<PathBuf>,
    /// Friction law [default: from the scenario; the paper preset uses none].
    #[arg(long, value_enum)]
    pub friction: Option<FrictionArg>,
    /// Friction force level in N, overriding η/r·m_d·g (= 0.0204 N for the paper's ball).
    #[arg(long, value_name = "F_N", allow_negative_numbers = true)]
    pub friction_force_n: Option<f64>,
    /// Solver by name (help text below carries the default).
    #[arg(long, help = concat!(
        "Solver by name; an unknown name prints the available ones [default: ",
        crate::default_solver!(),
        "]"
    ))]
    pub solver: Option<String>,
    /// Time step in s (fixed step of rk4, output grid unit of event-driven solvers) [default: 1e-6].
    #[arg(long, value_name = "S", allow_negative_numbers = true)]
    pub dt: Option<f64>,
    /// Simulated time per run in s; RMS is taken over the last 80 % [default: 2].
    #[arg(long, value_name = "S", allow_negative_numbers = true)]
    pub duration: Option<f64>,
}

/// `vibrobar sweep`.
#[derive(Debug, Args)]
pub struct SweepArgs {
    /// Model and run settings.
    #[command(flatten)]
    pub model: ModelArgs,
    /// Total clearance(s) in mm, comma-separated (the ball moves ±gap/2) [default: from the scenario: 0.1,1.0].
    #[arg(
        long,
        value_name = "G[,G...]",
        allow_negative_numbers = true,
        value_delimiter = ','
    )]
    pub gap_mm: Vec<f64>,
    /// Frequency ratios Ω/√(K/M) as START:STOP:STEP, STOP included (0.95:1.05:0.01 is 11 points) [default: from the scenario].
    #[arg(long, value_name = "START:STOP:STEP", allow_hyphen_values = true)]
    pub ratios: Option<String>,
    /// Continue an interrupted sweep from FILE.csv.journal (same parameters only).
    #[arg(long)]
    pub resume: bool,
    /// Output CSV: rows go to FILE.csv.journal as they finish; FILE.csv (sorted, gap-major) and
    /// FILE.csv.meta.json appear only when every row is in.
    #[arg(long, value_name = "FILE.csv")]
    pub out: PathBuf,
}

/// `vibrobar run`.
#[derive(Debug, Args)]
pub struct RunArgs {
    /// Model and run settings.
    #[command(flatten)]
    pub model: ModelArgs,
    /// Total clearance in mm (the ball moves ±gap/2) [default: from the scenario].
    #[arg(long, value_name = "G", allow_negative_numbers = true)]
    pub gap_mm: Option<f64>,
    /// Frequency ratio Ω/√(K/M) [default: from the scenario].
    #[arg(long, value_name = "R", allow_negative_numbers = true)]
    pub ratio: Option<f64>,
    /// Write one row every N time steps (every N·dt s).
    #[arg(long, value_name = "N", default_value_t = 10)]
    pub sample_every: u64,
    /// Initial bar displacement u(0) in m [default: 0].
    #[arg(long, value_name = "M", allow_negative_numbers = true)]
    pub u0_m: Option<f64>,
    /// Initial ball position relative to the cavity centre w(0) = v − u in m, within ±gap/2 [default: 0].
    #[arg(long, value_name = "M", allow_negative_numbers = true)]
    pub w0_m: Option<f64>,
    /// Initial relative velocity ẇ(0) in m/s [default: 0].
    #[arg(long, value_name = "M_S", allow_negative_numbers = true)]
    pub dw0_m_s: Option<f64>,
    /// Initial bar velocity u̇(0) in m/s [default: 0].
    #[arg(long, value_name = "M_S", allow_negative_numbers = true)]
    pub du0_m_s: Option<f64>,
    /// Output time history: columns t_s,u_m,du_m_s,v_m,dv_m_s,w_m,dw_m_s; a name ending in `.npy`
    /// writes an n × 7 float64 NumPy array in that column order instead of CSV. Parameters go to
    /// FILE.meta.json beside it.
    #[arg(long, value_name = "FILE.csv|FILE.npy")]
    pub out: PathBuf,
    /// Print the energy audit of the whole run as JSON on stdout (fields work_input_j,
    /// viscous_loss_j, impact_loss_j, friction_work_j, delta_mechanical_j, residual_j; friction
    /// work > 0 means friction put energy in). The human summary then goes to stderr.
    #[arg(long)]
    pub energy: bool,
}

/// `vibrobar paper`.
#[derive(Debug, Args)]
pub struct PaperArgs {
    /// Output directory.
    #[arg(long, value_name = "DIR", default_value = "paper-out")]
    pub out: PathBuf,
    /// Solver(s), comma-separated; the report gets one column group per solver, figures use the
    /// first. The default draws the figures with the paper's own scheme (rk4) and reports the
    /// exact event-driven solver beside it.
    #[arg(
        long = "solvers",
        alias = "solver",
        value_name = "NAME[,NAME...]",
        value_delimiter = ',',
        default_value = "rk4,exact"
    )]
    pub solvers: Vec<String>,
    /// Smoke-test settings: 0.1 s per run at dt = 2e-6 s (numbers are NOT the paper's).
    #[arg(long)]
    pub quick: bool,
    /// Simulated time per run in s (overrides --quick) [default: 2, the paper's].
    #[arg(long, value_name = "S", allow_negative_numbers = true)]
    pub duration: Option<f64>,
    /// Time step in s (overrides --quick) [default: 1e-6, the paper's].
    #[arg(long, value_name = "S", allow_negative_numbers = true)]
    pub dt: Option<f64>,
    /// Friction force in N at which the as-published model reproduces the paper's Figs. 4–5.
    #[arg(long, value_name = "F_N", allow_negative_numbers = true, default_value_t = crate::commands::paper::REPRODUCING_FRICTION_N)]
    pub reproducing_friction_n: f64,
    /// Sampling interval of the time histories (Figs. 2 and 4 and their CSVs) in s.
    #[arg(
        long,
        value_name = "S",
        allow_negative_numbers = true,
        default_value_t = 2e-5
    )]
    pub sample_interval_s: f64,
    /// Members of the initial-condition ensemble per point (run with `exact` whatever --solvers;
    /// 0 skips it) [default: 16; 4 with --quick].
    #[arg(long, value_name = "N")]
    pub ensemble_members: Option<usize>,
}

/// `vibrobar bench`.
#[derive(Debug, Args)]
pub struct BenchArgs {
    /// Solver(s) to time, comma-separated [default: every solver the library provides].
    #[arg(
        long = "solvers",
        alias = "solver",
        value_name = "NAME[,NAME...]",
        value_delimiter = ','
    )]
    pub solvers: Vec<String>,
    /// Simulated time per run in s [default: 2].
    #[arg(long, value_name = "S", allow_negative_numbers = true)]
    pub duration: Option<f64>,
    /// Time step in s [default: 1e-6].
    #[arg(long, value_name = "S", allow_negative_numbers = true)]
    pub dt: Option<f64>,
    /// Time only the single run, not the sweep set.
    #[arg(long)]
    pub single_only: bool,
}
