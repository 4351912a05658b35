//! Command-line argument types shared by the commands (clap derive). Units are in every flag
//! name or help text. This module imports nothing from the commands: the subcommand table that
//! ties each command's arguments to its function is [`crate::app`].

use clap::{Args, ValueEnum};
use std::path::PathBuf;
use vibrobar_core::{ContactLaw, FrictionModel};

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

/// Ball–wall contact law.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum ContactArg {
    /// Instantaneous impact with restitution e (the paper's Eqs. 4–5).
    Restitution,
    /// Compliant Hertz contact with Hunt–Crossley damping calibrated to e (`[contact]`
    /// constants; exact solver, lumped bar or beam).
    Hertz,
}

impl From<ContactArg> for ContactLaw {
    fn from(c: ContactArg) -> Self {
        match c {
            ContactArg::Restitution => ContactLaw::Restitution,
            ContactArg::Hertz => ContactLaw::Hertz,
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
    /// Ball–wall contact law [default: the scenario's `[contact] law`, else restitution].
    #[arg(long, value_enum)]
    pub contact: Option<ContactArg>,
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
    /// Number of modes N of a `[beam]` scenario, overriding `[beam] modes`, in [1, 32]
    /// [default: the fewest (at least 3) capturing 99.5 % of the static tip compliance].
    #[arg(long, value_name = "N")]
    pub beam_modes: Option<usize>,
    /// Cavity centre (the ball) of a `[beam]` scenario in mm from the clamp, in [0, L],
    /// overriding `[beam] cavity_position_m`.
    #[arg(long, value_name = "X", allow_negative_numbers = true)]
    pub cavity_position_mm: Option<f64>,
    /// Width of cut b in mm of a `[cutting]` scenario, overriding `[cutting] width_m`.
    #[arg(long, value_name = "B", allow_negative_numbers = true)]
    pub width_mm: Option<f64>,
    /// Spindle speed in rpm of a `[cutting]` scenario, in [1, 200000], overriding
    /// `[cutting] spindle_rpm`.
    #[arg(long, value_name = "N", allow_negative_numbers = true)]
    pub spindle_rpm: Option<f64>,
}

/// `vibrobar sweep`.
#[derive(Debug, Args)]
pub struct SweepArgs {
    /// Model and run settings.
    #[command(flatten)]
    pub model: ModelArgs,
    /// Total clearance(s) in mm, comma-separated (the ball moves ±gap/2) [default: the scenario's
    /// [sweep] gaps_m; a file without them sweeps its [damper] gap_m; the paper preset: 0.1,1.0].
    #[arg(
        long,
        value_name = "G[,G...]",
        allow_negative_numbers = true,
        value_delimiter = ','
    )]
    pub gap_mm: Vec<f64>,
    /// Frequency ratios Ω/ω₁ (ω₁ = √(K/M) of a lumped bar, the first mode's of a beam; the
    /// solid reference at Ω/ω₁ of its own) as START:STOP:STEP, STOP included (0.95:1.05:0.01 is 11 points) [default: from the scenario].
    #[arg(long, value_name = "START:STOP:STEP", allow_hyphen_values = true)]
    pub ratios: Option<String>,
    /// Absolute forcing frequencies in Hz as START:STOP:STEP, STOP included, instead of
    /// --ratios: the damped and the solid bar both run at the same Ω (the `ratio` column is then
    /// Ω/ω₁ of the damped bar; the frequencies go to the metadata).
    #[arg(
        long,
        value_name = "START:STOP:STEP",
        allow_hyphen_values = true,
        conflicts_with = "ratios"
    )]
    pub freqs_hz: Option<String>,
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
    /// Frequency ratio Ω/ω₁ (ω₁ = √(K/M) of a lumped bar, the first mode's of a beam)
    /// [default: from the scenario].
    #[arg(long, value_name = "R", allow_negative_numbers = true)]
    pub ratio: Option<f64>,
    /// Write one row every N time steps (every N·dt s).
    #[arg(long, value_name = "N", default_value_t = 10)]
    pub sample_every: u64,
    /// Initial bar displacement u(0) in m, at the response point (a beam: put into mode 1)
    /// [default: 0].
    #[arg(long, value_name = "M", allow_negative_numbers = true)]
    pub u0_m: Option<f64>,
    /// Initial ball position relative to the cavity centre w(0) = v − u(x_d) in m, within ±gap/2 [default: 0].
    #[arg(long, value_name = "M", allow_negative_numbers = true)]
    pub w0_m: Option<f64>,
    /// Initial relative velocity ẇ(0) in m/s [default: 0].
    #[arg(long, value_name = "M_S", allow_negative_numbers = true)]
    pub dw0_m_s: Option<f64>,
    /// Initial bar velocity u̇(0) in m/s, at the response point (a beam: put into mode 1)
    /// [default: 0].
    #[arg(long, value_name = "M_S", allow_negative_numbers = true)]
    pub du0_m_s: Option<f64>,
    /// Output time history: columns t_s,u_m,du_m_s,v_m,dv_m_s,w_m,dw_m_s; a name ending in `.npy`
    /// writes an n × 7 float64 NumPy array in that column order instead of CSV. Parameters go to
    /// FILE.meta.json beside it.
    #[arg(long, value_name = "FILE.csv|FILE.npy")]
    pub out: PathBuf,
    /// A scenario with `[two_plane]`: start from member K of its ensemble of starts (0: the bar
    /// at rest, the ball resting where gravity presses it; the others as `sweep` draws them)
    /// [default: 0].
    #[arg(long, value_name = "K")]
    pub member: Option<usize>,
    /// Print the energy audit of the whole run as JSON on stdout (fields work_input_j,
    /// viscous_loss_j, impact_loss_j, friction_work_j, delta_mechanical_j, residual_j; friction
    /// work > 0 means friction put energy in). The human summary then goes to stderr.
    #[arg(long)]
    pub energy: bool,
}

/// Friction force at which the as-published model reproduces the paper's friction figures.
pub const REPRODUCING_FRICTION_N: f64 = 20.0;

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
    #[arg(long, value_name = "F_N", allow_negative_numbers = true, default_value_t = REPRODUCING_FRICTION_N)]
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
    /// Scenario file (TOML, as for `run`): time its damped run (gap, ratio, friction, initial
    /// state as given) and its `[sweep]` (ratios × gaps) instead of the paper's run and sweep
    /// set. --duration and --dt override the file.
    #[arg(long, value_name = "FILE.toml")]
    pub scenario: Option<PathBuf>,
    /// Number of modes N of a `[beam]` scenario, overriding `[beam] modes`, in [1, 32].
    #[arg(long, value_name = "N")]
    pub beam_modes: Option<usize>,
    /// Cavity centre (the ball) of a `[beam]` scenario in mm from the clamp, in [0, L].
    #[arg(long, value_name = "X", allow_negative_numbers = true)]
    pub cavity_position_mm: Option<f64>,
}
