//! The application root: the subcommand table (clap) and the function each command runs.
//! Arrows point one way: this module uses [`crate::cli`] (shared argument types) and
//! [`crate::commands`]; neither imports it.

use anyhow::Result;
use clap::{Parser, Subcommand};

use crate::commands::{beam, bench, explore, map, merge, paper, run, sweep};

/// Vibro-impact boring-bar simulator: a bar with a free ball in a cavity, after the paper
/// "The effect of rolling friction on vibro-impact damped boring bars".
#[derive(Debug, Parser)]
#[command(name = "vibrobar", version)]
pub struct Cli {
    /// What to do.
    #[command(subcommand)]
    pub command: Command,
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

/// Run the parsed command line.
pub fn dispatch(cli: Cli) -> Result<()> {
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
        Command::Ensemble(a) => explore::run_ensemble_cmd(&a),
        Command::BenchMap(a) => map::run_bench(&a),
        Command::Bench(a) => bench::bench(&a),
    }
}
