//! The sign of the friction power along whole rk4 runs: `as-published` (paper Eq. 2) puts energy
//! in (`F_ball·ẇ ≥ 0`), `coulomb` takes it out (`≤ 0`), step by step and over the run.

use vibrobar_core::damper::friction::sliding_friction_on_ball_n;
use vibrobar_core::solver::{Observer, Rk4, Segment};
use vibrobar_core::{FrictionModel, Solver, State, System};

/// Per-step friction work from the segment integrals, and the friction power on the step-start
/// states from the model's friction law.
struct FrictionProbe {
    model: FrictionModel,
    level_n: f64,
    steps: u64,
    min_step_work_j: f64,
    max_step_work_j: f64,
    total_work_j: f64,
    min_power_w: f64,
    max_power_w: f64,
}

impl FrictionProbe {
    fn new(model: FrictionModel, level_n: f64) -> Self {
        FrictionProbe {
            model,
            level_n,
            steps: 0,
            min_step_work_j: f64::INFINITY,
            max_step_work_j: f64::NEG_INFINITY,
            total_work_j: 0.0,
            min_power_w: f64::INFINITY,
            max_power_w: f64::NEG_INFINITY,
        }
    }
}

impl Observer for FrictionProbe {
    fn segment(&mut self, seg: &dyn Segment) {
        let (a, b) = (seg.t_start_s(), seg.t_end_s());
        let w = seg.integrals(a, b).friction_work_j;
        self.steps += 1;
        self.min_step_work_j = self.min_step_work_j.min(w);
        self.max_step_work_j = self.max_step_work_j.max(w);
        self.total_work_j += w;
        for t in [a, 0.5 * (a + b)] {
            let s = seg.state_at(t);
            let p = sliding_friction_on_ball_n(self.model, self.level_n, s.dw_m_s()) * s.dw_m_s();
            self.min_power_w = self.min_power_w.min(p);
            self.max_power_w = self.max_power_w.max(p);
        }
    }
}

fn probe(gap_m: f64, model: FrictionModel, force_n: Option<f64>) -> FrictionProbe {
    let mut sys = System::paper_damped(gap_m, model, 1.0);
    sys.damper.as_mut().unwrap().friction_force_n = force_n;
    let mut p = FrictionProbe::new(model, sys.friction_level_n());
    Rk4 { dt_s: 1e-6 }
        .run(&sys, &State::REST, 0.05, &mut p)
        .unwrap();
    assert_eq!(p.steps, 50_000);
    p
}

const CASES: [(f64, Option<f64>); 4] = [
    (1e-3, None),
    (0.1e-3, None),
    (1e-3, Some(20.0)),
    (0.1e-3, Some(20.0)),
];

#[test]
fn as_published_friction_injects_energy_at_every_step() {
    for (gap, force) in CASES {
        let p = probe(gap, FrictionModel::AsPublished, force);
        let tag = format!("as-published, gap {gap} m, F = {force:?}");
        assert!(
            p.min_step_work_j >= 0.0,
            "{tag}: a step with friction work {} J < 0",
            p.min_step_work_j
        );
        assert!(p.min_power_w >= 0.0, "{tag}: power {} W < 0", p.min_power_w);
        assert!(
            p.total_work_j > 0.0 && p.max_power_w > 0.0,
            "{tag}: total friction work {} J, max power {} W: want > 0",
            p.total_work_j,
            p.max_power_w
        );
    }
}

#[test]
fn coulomb_friction_dissipates_at_every_step() {
    for (gap, force) in CASES {
        let p = probe(gap, FrictionModel::Coulomb, force);
        let tag = format!("coulomb, gap {gap} m, F = {force:?}");
        assert!(
            p.max_step_work_j <= 0.0,
            "{tag}: a step with friction work {} J > 0",
            p.max_step_work_j
        );
        assert!(p.max_power_w <= 0.0, "{tag}: power {} W > 0", p.max_power_w);
        assert!(
            p.total_work_j < 0.0 && p.min_power_w < 0.0,
            "{tag}: total friction work {} J, min power {} W: want < 0",
            p.total_work_j,
            p.min_power_w
        );
    }
}

#[test]
fn no_friction_does_no_work() {
    let p = probe(1e-3, FrictionModel::None, Some(20.0));
    assert!(
        p.min_step_work_j == 0.0 && p.max_step_work_j == 0.0,
        "friction none: step work in [{}, {}] J",
        p.min_step_work_j,
        p.max_step_work_j
    );
}
