//! One case: run a system from a state and take its RMS and impact statistics, through the
//! observers every analysis builds on (RMS integral, impact counter, output-grid sampler).

use super::energy::{EnergyAudit, EnergyBalance};
use crate::error::SimError;
use crate::params::{RunSettings, State, System};
use crate::solver::{Event, EventKind, Fanout, Observer, RunSummary, Segment, Solver};

/// RMS of the bar displacement over `[window_start, window_end]`, from `∫ u² dt` of each segment.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RmsObserver {
    /// Window start.
    pub window_start_s: f64,
    /// Window end.
    pub window_end_s: f64,
    integral_u2: f64,
    covered_s: f64,
}

impl RmsObserver {
    /// RMS over `[window_start, window_end]`.
    pub fn new(window_start_s: f64, window_end_s: f64) -> Self {
        RmsObserver {
            window_start_s,
            window_end_s,
            integral_u2: 0.0,
            covered_s: 0.0,
        }
    }

    /// `√(∫u² / T)` over the part of the window seen so far (NaN if none).
    pub fn rms_m(&self) -> f64 {
        (self.integral_u2 / self.covered_s).sqrt()
    }
}

impl Observer for RmsObserver {
    fn segment(&mut self, seg: &dyn Segment) {
        let a = seg.t_start_s().max(self.window_start_s);
        let b = seg.t_end_s().min(self.window_end_s);
        if b > a {
            self.integral_u2 += seg.integral_u2(a, b);
            self.covered_s += b - a;
        }
    }
}

/// Counts impacts, over the whole run and inside a window.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ImpactCounter {
    /// Window start.
    pub window_start_s: f64,
    /// All impacts.
    pub total: u64,
    /// Impacts at `t ≥ window_start`.
    pub in_window: u64,
}

impl Observer for ImpactCounter {
    fn event(&mut self, ev: &Event) {
        if let EventKind::Impact { .. } = ev.kind {
            self.total += 1;
            if ev.t_s >= self.window_start_s {
                self.in_window += 1;
            }
        }
    }
}

/// Samples the state on a fixed output grid `t0 + k·interval`, evaluating each segment only at
/// the requested times.
#[derive(Debug, Clone, PartialEq)]
pub struct Sampler {
    interval_s: f64,
    t0_s: f64,
    next_k: u64,
    /// Samples, in time order.
    pub samples: Vec<State>,
    /// The cut at each sample of a cutting run (empty otherwise), alongside
    /// [`Sampler::samples`].
    pub cuts: Vec<crate::solver::CutSample>,
}

impl Sampler {
    /// Sample every `interval_s` from `t0_s` (inclusive).
    pub fn new(t0_s: f64, interval_s: f64) -> Self {
        Sampler {
            interval_s,
            t0_s,
            next_k: 0,
            samples: Vec::new(),
            cuts: Vec::new(),
        }
    }

    fn next_t(&self) -> f64 {
        self.t0_s + self.next_k as f64 * self.interval_s
    }
}

impl Observer for Sampler {
    fn segment(&mut self, seg: &dyn Segment) {
        // A sample exactly at an event time belongs to the segment that ends there (pre-event).
        while self.next_t() <= seg.t_end_s() {
            let t = self.next_t();
            if t >= seg.t_start_s() {
                self.samples.push(seg.state_at(t));
                if let Some(c) = seg.cutting_at(t) {
                    self.cuts.push(c);
                }
            }
            self.next_k += 1;
        }
    }
}

/// Everything a single run reports.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RunResult {
    /// RMS of `u` over the window.
    pub rms_m: f64,
    /// Impacts over the whole run.
    pub impacts: u64,
    /// Impacts inside the RMS window.
    pub impacts_in_window: u64,
    /// Impacts per forcing cycle inside the window.
    pub impacts_per_cycle: f64,
    /// What the solver said.
    pub summary: RunSummary,
}

/// Run one case from `init` over `settings.duration_s` and take RMS and impact statistics over
/// the last `rms_fraction` of it. `extra` sees the run too (pass `&mut ()` for nothing).
pub fn run_case(
    sys: &System,
    init: &State,
    settings: &RunSettings,
    solver: &dyn Solver,
    extra: &mut dyn Observer,
) -> Result<RunResult, SimError> {
    settings.validate()?;
    let t_end = init.t_s + settings.duration_s;
    let w0 = init.t_s + settings.window_start_s();
    let mut rms = RmsObserver::new(w0, t_end);
    let mut imp = ImpactCounter {
        window_start_s: w0,
        ..Default::default()
    };
    let summary = {
        let mut obs: [&mut dyn Observer; 3] = [&mut rms, &mut imp, extra];
        solver.run(sys, init, t_end, &mut Fanout(&mut obs))?
    };
    let cycles = (t_end - w0) / sys.forcing_period_s();
    // Last line of defence: a NaN or inf never reaches a result table.
    let cause = "parameters far outside the model's range (forces, masses or stiffness)";
    Ok(RunResult {
        rms_m: crate::limits::finite_result("RMS of u", rms.rms_m(), cause)?,
        impacts: imp.total,
        impacts_in_window: imp.in_window,
        impacts_per_cycle: crate::limits::finite_result(
            "impacts per cycle",
            imp.in_window as f64 / cycles,
            "an RMS window shorter than a forcing period's rounding",
        )?,
        summary,
    })
}

/// One simulation to do.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Case {
    /// The system.
    pub system: System,
    /// Initial state.
    pub init: State,
    /// Sample the history every this many seconds.
    pub sample_interval_s: Option<f64>,
    /// Audit the energy (core `EnergyAudit`: forcing, viscous, impact and friction work); costs
    /// the full segment integrals per step.
    pub energy_audit: bool,
}

/// What a case gave.
#[derive(Debug, Clone, PartialEq)]
pub struct CaseOutcome {
    /// RMS and impact statistics.
    pub result: RunResult,
    /// Friction work in J (0 without friction or without audit).
    pub friction_work_j: f64,
    /// Energy books of the whole run, when audited.
    pub energy: Option<EnergyBalance>,
    /// Sampled history (empty unless asked for).
    pub samples: Vec<State>,
    /// Wall time of this run in s.
    pub wall_s: f64,
}

/// Run one case.
pub fn run_one(
    case: &Case,
    settings: &RunSettings,
    solver: &dyn Solver,
) -> Result<CaseOutcome, SimError> {
    let t0 = std::time::Instant::now();
    let mut audit = case.energy_audit.then(|| EnergyAudit::new(&case.system));
    let mut sampler = case
        .sample_interval_s
        .map(|dt| Sampler::new(case.init.t_s, dt));
    let result = {
        let mut obs: Vec<&mut dyn Observer> = Vec::with_capacity(2);
        if let Some(a) = audit.as_mut() {
            obs.push(a);
        }
        if let Some(s) = sampler.as_mut() {
            obs.push(s);
        }
        run_case(
            &case.system,
            &case.init,
            settings,
            solver,
            &mut Fanout(&mut obs),
        )?
    };
    let energy = audit.and_then(|a| a.balance());
    Ok(CaseOutcome {
        result,
        friction_work_j: energy.map_or(0.0, |e| e.friction_work_j),
        energy,
        samples: sampler.map(|s| s.samples).unwrap_or_default(),
        wall_s: t0.elapsed().as_secs_f64(),
    })
}
