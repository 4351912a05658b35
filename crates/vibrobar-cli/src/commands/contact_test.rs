//! `vibrobar contact-test`: the single-impact laboratory of the `hertz` law
//! ([`vibrobar_core::analysis::contact_test`]): the scenario's ball (mass, radius, target
//! restitution, `[contact]` constants) arrives at each speed on a rigid, fixed wall. CSV schema
//! `vibrobar_io::csv::contact_test_schema`; the closed forms and the drift of the published
//! approximate damping laws go to the screen.

use anyhow::{bail, Context, Result};
use clap::Args;
use std::path::PathBuf;
use vibrobar_core::analysis::contact_test::single_impact;
use vibrobar_core::damper::contact::{d_flores, d_lankarani_nikravesh, Hertz};
use vibrobar_core::{ContactLaw, System};

use crate::scenario::{Scenario, ScenarioArgs, Source};

/// Most speeds in one call.
const MAX_SPEEDS: usize = 1000;

/// `vibrobar contact-test`.
#[derive(Debug, Args)]
pub struct ContactTestArgs {
    /// Scenario file (TOML): its `[damper]` ball and `[contact]` constants (the hertz law is
    /// tested whatever `[contact] law` says) [default: the paper's carbide ball on steel].
    #[arg(long, value_name = "FILE.toml")]
    pub scenario: Option<PathBuf>,
    /// Approach speeds in m/s, comma-separated, each in (0, 1000].
    #[arg(long, value_name = "V,V,...", default_value = "0.01,0.1,1")]
    pub speeds_m_s: String,
    /// Output CSV: speed_m_s,contact_time_s,restitution,max_force_n,max_penetration_m.
    #[arg(long, value_name = "FILE.csv")]
    pub out: PathBuf,
}

fn parse_speeds(spec: &str) -> Result<Vec<f64>> {
    let mut v = Vec::new();
    for p in spec.split(',') {
        let x: f64 = p.trim().parse().map_err(|_| {
            anyhow::anyhow!("--speeds-m-s must be comma-separated numbers, got {p:?}")
        })?;
        if !(x > 0.0 && x <= 1000.0) {
            bail!("--speeds-m-s = {x} is outside the allowed range (0, 1000] m/s");
        }
        if v.len() == MAX_SPEEDS {
            bail!("--speeds-m-s: at most {MAX_SPEEDS} speeds");
        }
        v.push(x);
    }
    Ok(v)
}

/// Run the command.
pub fn run(args: &ContactTestArgs) -> Result<()> {
    let speeds = parse_speeds(&args.speeds_m_s)?;
    let mut sc = match &args.scenario {
        Some(p) => Scenario::load_any(p)?,
        None => Scenario::from_source(Source::Preset(crate::cli::Preset::Paper))?,
    };
    sc.contact.law = ContactLaw::Hertz;
    sc.damper.contact = sc.contact;
    let sys = System {
        damper: Some(sc.damper),
        ..sc.damped_system()?
    };
    sys.validate()?;
    let d = sc.damper;
    let law = Hertz::of_damper(&d);
    let mut rows = Vec::with_capacity(speeds.len());
    for &v in &speeds {
        rows.push(single_impact(&law, d.ball_mass_kg, v)?);
    }
    vibrobar_io::csv::write_contact_test_csv(&args.out, &rows)
        .with_context(|| format!("writing {}", args.out.display()))?;
    vibrobar_io::Metadata::new(
        "contact-test",
        &vibrobar_io::csv::contact_test_schema().header(),
        &sc,
        None,
    )
    .write_beside(&args.out)
    .with_context(|| format!("metadata beside {}", args.out.display()))?;

    let e = d.restitution;
    println!("vibrobar contact-test ({})", crate::VERSION);
    println!(
        "  ball {} g, r = {} mm on a rigid wall; E* = {:.4} GPa, R* = {} mm, K_h = {:.4e} N/m^1.5, e = {e}, D(e) = {:.6} (exact Hunt–Crossley)",
        d.ball_mass_kg * 1e3,
        d.ball_radius_m * 1e3,
        law.effective_modulus_pa * 1e-9,
        law.effective_radius_m * 1e3,
        law.stiffness_n_m32,
        law.damping
    );
    println!(
        "  {:>10} {:>14} {:>12} {:>12} {:>14} {:>14} {:>12} {:>12}",
        "v0 m/s", "t_c s", "e_eff", "F_max N", "δ_max m", "t_c Hertz(D=0)", "e Flores", "e L-N"
    );
    for o in &rows {
        let v = o.speed_m_s;
        let fl = single_impact(&law.with_damping(d_flores(e)), d.ball_mass_kg, v)?;
        let ln = single_impact(
            &law.with_damping(d_lankarani_nikravesh(e)),
            d.ball_mass_kg,
            v,
        )?;
        println!(
            "  {:>10} {:>14.6e} {:>12.8} {:>12.5e} {:>14.6e} {:>14.6e} {:>12.6} {:>12.6}",
            v,
            o.contact_time_s,
            o.restitution,
            o.max_force_n,
            o.max_penetration_m,
            law.undamped_contact_time_s(d.ball_mass_kg, v),
            fl.restitution,
            ln.restitution
        );
    }
    println!("  wrote {}", args.out.display());
    Ok(())
}
