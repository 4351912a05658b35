//! `vibrobar modes`: the structure's modes at the points that matter, as CSV (schema
//! `vibrobar_io::csv::modes_schema`) and a one-screen summary. A `[beam]` scenario gives the
//! Euler–Bernoulli beam's modes; any other scenario the lumped bar's one mode (`φ = 1`).

use anyhow::{Context, Result};
use clap::Args;
use std::f64::consts::PI;
use std::path::PathBuf;
use vibrobar_core::structure::beam::{DEFAULT_CAPTURED_STATIC_FRACTION, MIN_DEFAULT_MODES};
use vibrobar_core::structure::Structure;

use crate::scenario::{Scenario, ScenarioArgs, Source};
use vibrobar_io::csv::fmt_coord;

/// A length in mm for the summary, binary noise removed (`38`, not `37.99999999999998`).
fn mm(x_m: f64) -> String {
    fmt_coord(x_m * 1e3)
}

/// `vibrobar modes`.
#[derive(Debug, Args)]
pub struct ModesArgs {
    /// Scenario file (TOML); its `[beam]` section describes the bar [default: the paper's lumped
    /// bar, one mode].
    #[arg(long, value_name = "FILE.toml")]
    pub scenario: Option<PathBuf>,
    /// Number of modes N, overriding `[beam] modes` [default: the fewest (at least 3) capturing
    /// 99.5 % of the static tip compliance].
    #[arg(long, value_name = "N")]
    pub beam_modes: Option<usize>,
    /// Cavity centre (the ball) in mm from the clamp, overriding `[beam] cavity_position_m`.
    #[arg(long, value_name = "X", allow_negative_numbers = true)]
    pub cavity_position_mm: Option<f64>,
    /// Output CSV: mode,frequency_hz,modal_mass_kg,shape_cavity,shape_force,shape_response
    /// (shapes 1 at the tip, modal mass in that normalisation); parameters go to FILE.meta.json.
    #[arg(long, value_name = "FILE.csv")]
    pub out: PathBuf,
}

/// Run the command.
pub fn modes(args: &ModesArgs) -> Result<()> {
    let mut sc = match &args.scenario {
        Some(p) => Scenario::load_any(p)?,
        None => Scenario::from_source(Source::Preset(crate::cli::Preset::Paper))?,
    };
    sc.apply_beam_flags(args.beam_modes, args.cavity_position_mm)?;
    let structure = sc.structure();
    let model = structure.modal_model()?;
    vibrobar_io::csv::write_modes_csv(&args.out, &model)
        .with_context(|| format!("writing {}", args.out.display()))?;
    vibrobar_io::Metadata::new(
        "modes",
        &vibrobar_io::csv::modes_schema().header(),
        &sc,
        None,
    )
    .write_beside(&args.out)
    .with_context(|| format!("metadata beside {}", args.out.display()))?;

    println!("vibrobar modes ({})", crate::VERSION);
    match &structure {
        Structure::Beam(b) => {
            println!(
                "  structure  : clamped–free Euler–Bernoulli beam, L = {} mm, D = {} mm, E = {} GPa, ρ = {} kg/m³ ({})",
                mm(b.length_m),
                mm(b.diameter_m),
                fmt_coord(b.youngs_modulus_pa * 1e-9),
                b.density_kg_m3,
                if b.is_uniform() {
                    "closed-form modes".to_string()
                } else {
                    format!(
                        "finite elements, {} elements",
                        b.mesh(model.len())?.elements()
                    )
                }
            );
            println!(
                "  points     : cavity {} mm, force {} mm, response {} mm from the clamp (cavity {} mm from the free end)",
                mm(b.cavity_position_m),
                mm(b.force_x_m()),
                mm(b.response_x_m()),
                mm(b.length_m - b.cavity_position_m)
            );
        }
        Structure::Lumped(bar) => println!(
            "  structure  : lumped bar M = {} kg, K = {} N/m (one mode, every shape 1)",
            bar.mass_kg, bar.stiffness_n_per_m
        ),
        Structure::Measured(_) => println!("  structure  : measured modes"),
    }
    println!("  normalise  : shapes 1 at the tip; modal mass in that normalisation (ρAL/4 for a uniform bar)");
    println!(
        "  {:>4} {:>12} {:>14} {:>12} {:>12} {:>12}",
        "mode", "f (Hz)", "m_n (kg)", "φ(cavity)", "φ(force)", "φ(response)"
    );
    for (k, m) in model.modes().iter().enumerate() {
        println!(
            "  {:>4} {:>12.3} {:>14.6} {:>12.6} {:>12.6} {:>12.6}",
            k + 1,
            m.omega_rad_s / (2.0 * PI),
            m.modal_mass_kg,
            m.shape_cavity,
            m.shape_force,
            m.shape_response
        );
    }
    println!(
        "  static tip compliance: {:.6e} m/N exact, {:.4} % captured by the {} mode(s) above{}",
        model.static_tip_compliance_m_per_n,
        100.0 * model.captured_static_fraction(),
        model.len(),
        if matches!(structure, Structure::Beam(_)) {
            format!(
                " (default N: the fewest, at least {MIN_DEFAULT_MODES}, capturing ≥ {} %)",
                100.0 * DEFAULT_CAPTURED_STATIC_FRACTION
            )
        } else {
            String::new()
        }
    );
    println!(
        "  output     : {} rows to {}",
        model.len(),
        args.out.display()
    );
    Ok(())
}
