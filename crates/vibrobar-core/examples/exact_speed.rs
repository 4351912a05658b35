//! Exact vs RK4 on the paper cases: RMS, impacts and wall time per 2 s run (release build).
use vibrobar_core::analysis::run_case;
use vibrobar_core::solver::{Exact, Rk4, Solver};
use vibrobar_core::*;

/// Result and the fastest of `reps` runs (the machine is shared: the minimum is the least
/// disturbed measurement).
fn time(sys: &System, s: &dyn Solver, reps: u32) -> (analysis::RunResult, f64) {
    let st = RunSettings::default();
    let mut best = f64::INFINITY;
    let mut r = None;
    for _ in 0..reps {
        let t = std::time::Instant::now();
        r = Some(run_case(sys, &State::REST, &st, s, &mut ()).unwrap());
        best = best.min(t.elapsed().as_secs_f64());
    }
    (r.unwrap(), best)
}

fn main() {
    let ex = Exact {
        check_invariants: true,
        ..Default::default()
    };
    let mut asp = System::paper_damped(1e-3, FrictionModel::AsPublished, 1.0);
    asp.damper.as_mut().unwrap().friction_force_n = Some(20.0);
    let cases = [
        (
            "r=1 gap 0.1 mm none",
            System::paper_damped(0.1e-3, FrictionModel::None, 1.0),
        ),
        ("solid r=1", System::paper_solid(1.0)),
        ("as-published 20 N 1 mm r=1", asp),
        (
            "coulomb 0.0204 N 0.1 mm r=1",
            System::paper_damped(0.1e-3, FrictionModel::Coulomb, 1.0),
        ),
    ];
    for (name, sys) in cases {
        let (re, te) = time(&sys, &ex, 50);
        let (rr, tr) = time(&sys, &Rk4::default(), 5);
        println!(
            "{name}: exact rms={:.5e} imp={} ev={} pen={:.1e} {:.3} ms | rk4 rms={:.5e} imp={} {:.1} ms | speedup {:.0}x",
            re.rms_m, re.impacts, re.summary.events, re.summary.max_penetration_m, te * 1e3,
            rr.rms_m, rr.impacts, tr * 1e3, tr / te
        );
    }
}
