//! `vibrobar run`: one run, its time history and a summary.
//!
//! The history is streamed to disk as the solver produces it (constant memory, whatever the
//! duration), through the atomic writer: `FILE.partial` until the run is complete. SIGINT and
//! SIGTERM remove the partial file and say what was interrupted ([`crate::app::install_interrupt_cleanup`]).

use anyhow::{Context, Result};
use std::path::Path;
use vibrobar_core::analysis::energy::EnergyAudit;
use vibrobar_core::analysis::{run_case, RunResult, Sampler};
use vibrobar_core::limits;
use vibrobar_core::solver::{Fanout, Segment};
use vibrobar_core::{Observer, RunSettings, Solver};
use vibrobar_io::history::{is_npy, sample_count, HistoryWriter};

use super::{fmt_secs, solver, Case};
use crate::cli::RunArgs;
use crate::scenario::{check_positive, Scenario, ScenarioArgs};

/// Feeds the core's [`Sampler`] and hands each sample to the writer as soon as it exists.
struct Stream<'a> {
    sampler: Sampler,
    writer: &'a mut HistoryWriter,
}

impl Observer for Stream<'_> {
    fn segment(&mut self, seg: &dyn Segment) {
        self.sampler.segment(seg);
        if self.sampler.cuts.is_empty() {
            for s in self.sampler.samples.drain(..) {
                self.writer.push(&s);
            }
        } else {
            // A cutting run: every sample has its cut.
            for (s, c) in self
                .sampler
                .samples
                .drain(..)
                .zip(self.sampler.cuts.drain(..))
            {
                self.writer.push_cut(&s, &c);
            }
        }
    }
}

/// What the streamed run gave.
struct Streamed {
    result: RunResult,
    energy: Option<vibrobar_core::analysis::energy::EnergyBalance>,
    rows: u64,
}

/// Run `case` and stream its history to `out`; on failure nothing is left at `out`.
fn run_streamed(
    case: &Case,
    settings: &RunSettings,
    solver: &dyn Solver,
    out: &Path,
    interval_s: f64,
    cutting: bool,
) -> Result<Streamed> {
    let t_end = case.init.t_s + settings.duration_s;
    let mut writer =
        HistoryWriter::create_with(out, sample_count(case.init.t_s, interval_s, t_end), cutting)?;
    let mut audit = case.energy_audit.then(|| EnergyAudit::new(&case.system));
    let res = {
        let mut stream = Stream {
            sampler: Sampler::new(case.init.t_s, interval_s),
            writer: &mut writer,
        };
        let mut obs: Vec<&mut dyn Observer> = Vec::with_capacity(2);
        if let Some(a) = audit.as_mut() {
            obs.push(a);
        }
        obs.push(&mut stream);
        run_case(
            &case.system,
            &case.init,
            settings,
            solver,
            &mut Fanout(&mut obs),
        )
    };
    let result = match res {
        Ok(r) => r,
        Err(e) => {
            writer.discard();
            return Err(e.into());
        }
    };
    let rows = writer.finish()?;
    Ok(Streamed {
        result,
        energy: audit.and_then(|a| a.balance()),
        rows,
    })
}

/// Run the command.
pub fn run(args: &RunArgs) -> Result<()> {
    let t0 = std::time::Instant::now();
    let mut sc = Scenario::from_args(&args.model)?;
    if let Some(g) = args.gap_mm {
        check_positive("--gap-mm", g, "mm")?;
        sc.damper.gap_m = g * 1e-3;
    }
    if let Some(r) = args.ratio {
        check_positive("--ratio", r, "")?;
        sc.forcing.frequency = vibrobar_core::Frequency::Ratio(r);
    }
    if sc.two_plane.is_some() {
        return super::run_two_plane::run(args, &sc);
    }
    if args.member.is_some() {
        anyhow::bail!(
            "--member: only a scenario with [two_plane] has an ensemble of starts to choose from; \
             give the start with --u0-m, --du0-m-s, --w0-m and --dw0-m-s"
        );
    }
    sc.override_initial(args.u0_m, args.du0_m_s, args.w0_m, args.dw0_m_s)?;
    if args.sample_every == 0 {
        anyhow::bail!("--sample-every = 0 is outside the allowed range [1, ∞) steps");
    }
    sc.validate()?;
    let settings = sc.settings();
    limits::check_samples(
        "rows = --duration / (--sample-every · --dt)",
        settings.duration_s,
        args.sample_every as f64 * settings.dt_s,
    )?;
    // A [cutting] scenario runs the exact solver's delay stepping, from offsets of the cut's
    // static equilibrium ([initial]).
    let solver = match sc.cutting_solver()? {
        Some(s) => s,
        None => solver(&sc.run.solver, &settings)?,
    };
    let cutting = sc.cutting.is_some();
    let sys = sc.damped_system()?;
    let case = Case {
        system: sys,
        init: sc.initial_state(),
        sample_interval_s: Some(args.sample_every as f64 * settings.dt_s),
        energy_audit: true,
    };
    let interval_s = args.sample_every as f64 * settings.dt_s;
    let out = run_streamed(
        &case,
        &settings,
        solver.as_ref(),
        &args.out,
        interval_s,
        cutting,
    )?;
    // Under the hertz law the penetration is the contact's own compression, not an error.
    let gap_m = sys
        .damper
        .filter(|d| d.contact.law == vibrobar_core::ContactLaw::Restitution)
        .map_or(f64::INFINITY, |d| d.gap_m);
    let pen_m = out.result.summary.max_penetration_m;
    if let Some(f) = limits::excessive_penetration(pen_m, gap_m) {
        eprintln!(
            "{}",
            super::penetration_warning(pen_m, f, solver.name(), None)
        );
    }
    let is_npy = is_npy(&args.out);
    let params = vibrobar_io::params::RunParams {
        scenario: &sc,
        system: sys,
        initial: case.init,
        settings,
        solver: solver.name().to_string(),
        sample_interval_s: case.sample_interval_s,
    };
    vibrobar_io::Metadata::new(
        "run",
        &if is_npy {
            String::new()
        } else if cutting {
            vibrobar_io::csv::cutting_history_schema().header()
        } else {
            vibrobar_io::csv::history_schema().header()
        },
        params,
        None,
    )
    .write_beside(&args.out)
    .with_context(|| format!("metadata beside {}", args.out.display()))?;
    if args.energy {
        let e = out.energy.expect("energy audit requested");
        println!("{}", serde_json::to_string_pretty(&e)?);
    }
    // With --energy, stdout carries only the JSON; the summary goes to stderr.
    let say = |line: String| {
        if args.energy {
            eprintln!("{line}");
        } else {
            println!("{line}");
        }
    };
    print_summary(&say, &sc, &sys, &settings, solver.name(), &out, args)?;
    say(format!(
        "  wall time  : {}",
        fmt_secs(t0.elapsed().as_secs_f64())
    ));
    Ok(())
}

fn print_summary(
    say: &dyn Fn(String),
    sc: &Scenario,
    sys: &vibrobar_core::System,
    settings: &vibrobar_core::RunSettings,
    solver_name: &str,
    out: &Streamed,
    args: &RunArgs,
) -> Result<()> {
    let d = sys.damper.expect("damped system");
    let r = &out.result;
    say(format!("vibrobar run ({})", crate::VERSION));
    say(format!(
        "  model      : gap {} mm, ratio {}, friction {} ({:.4} N), e = {}, F0 = {} N",
        d.gap_m * 1e3,
        sc.frequency_ratio()?,
        d.friction,
        sys.friction_level_n(),
        d.restitution,
        sys.forcing.amplitude_n
    ));
    say(format!(
        "  run        : solver {}, {} s at dt {:e} s, RMS over the last {:.0} %",
        solver_name,
        settings.duration_s,
        settings.dt_s,
        settings.rms_fraction * 100.0
    ));
    if let Some(c) = &sc.cutting {
        say(format!(
            "  cut        : {} law, K_f = {:e} N/m², b = {} mm, h0 = {} mm, {} rpm (delay {:.4e} s), c_force {}, c_chip {}",
            c.force_law,
            c.coefficient_n_m2,
            c.width_m * 1e3,
            c.feed_m * 1e3,
            c.spindle_rpm,
            c.delay_s(),
            c.force_direction_factor,
            c.chip_direction_factor
        ));
    }
    say(format!("  RMS u      : {:.4e} m", r.rms_m));
    say(format!(
        "  impacts    : {} total, {} in the RMS window, {:.3} per forcing cycle",
        r.impacts, r.impacts_in_window, r.impacts_per_cycle
    ));
    say(format!(
        "  penetration: max |w| − l_g = {:.3e} m",
        r.summary.max_penetration_m.max(0.0)
    ));
    if let Some(e) = out.energy {
        say(format!(
            "  energy (J) : forcing {:+.4e}, viscous −{:.4e}, impacts −{:.4e}, friction {:+.4e} ({}), ΔE_mech {:+.4e}, residual {:+.2e}",
            e.work_input_j,
            e.viscous_loss_j,
            e.impact_loss_j,
            e.friction_work_j,
            if e.friction_work_j > 0.0 {
                "put in"
            } else if e.friction_work_j < 0.0 {
                "taken out"
            } else {
                "none"
            },
            e.delta_mechanical_j,
            e.residual_j
        ));
        if sc.cutting.is_some() {
            say(format!("  cutting    : work {:+.4e} J", e.cutting_work_j));
        }
    }
    let sidecar = match vibrobar_io::resolve_output(&args.out) {
        Ok(o) if !o.is_regular() => "no .meta.json beside a special file",
        _ => "+ .meta.json",
    };
    say(format!(
        "  output     : {} rows to {} ({sidecar})",
        out.rows,
        args.out.display()
    ));
    Ok(())
}
