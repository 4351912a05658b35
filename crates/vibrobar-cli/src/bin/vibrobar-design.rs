//! Design analyses as a stand-alone binary (to be folded into `vibrobar`).
use clap::{Parser, Subcommand};
use vibrobar_cli::commands::{explore, map, merge};

#[derive(Parser)]
#[command(
    name = "vibrobar-design",
    version,
    about = "vibrobar design analyses: maps, merge, exploration"
)]
struct Cli {
    #[command(subcommand)]
    cmd: Cmd,
}

#[derive(Subcommand)]
enum Cmd {
    /// RMS reduction map over frequency ratio × gap, with optimum and figures.
    Map(map::MapArgs),
    /// Merge map shards (written with --shard K/N) into the whole map.
    Merge(merge::MergeArgs),
    /// Stroboscopic Poincaré section of one run.
    Poincare(explore::PoincareArgs),
    /// Bifurcation diagram over the ratio or the gap.
    Bifurcation(explore::BifurcationArgs),
    /// Largest Lyapunov exponent at one point.
    Lyapunov(explore::LyapunovArgs),
    /// Initial-condition ensemble: RMS spread and regime counts.
    Ensemble(explore::EnsembleArgs),
    /// Time the 200 × 100 map (subsample) with each solver.
    BenchMap(map::BenchMapArgs),
}

fn main() {
    let cli = Cli::parse();
    let r = match &cli.cmd {
        Cmd::Map(a) => map::run(a),
        Cmd::Merge(a) => merge::run(a),
        Cmd::Poincare(a) => explore::run_poincare(a),
        Cmd::Bifurcation(a) => explore::run_bifurcation(a),
        Cmd::Lyapunov(a) => explore::run_lyapunov(a),
        Cmd::Ensemble(a) => explore::run_ensemble_cmd(a),
        Cmd::BenchMap(a) => map::run_bench(a),
    };
    if let Err(e) = r {
        eprintln!("error: {e:#}");
        std::process::exit(2);
    }
}
