//! Regression tests, each named after the bug it pins.

use vibrobar_core::solver::Rk4;
use vibrobar_core::{ParamError, SimError, Solver, State, System};

/// Bug: `Rk4::run` accepted a NaN, infinite or backward `t_end_s`, ran zero steps and returned
/// `Ok` with the initial state, so a bad duration looked like a finished run.
#[test]
fn rk4_accepted_nan_or_backward_end_time() {
    let sys = System::paper_solid(1.0);
    let init = State {
        t_s: 0.5,
        ..State::REST
    };
    for t_end in [f64::NAN, f64::INFINITY, 0.25] {
        let r = Rk4 { dt_s: 1e-6 }.run(&sys, &init, t_end, &mut ());
        match r {
            Err(SimError::Param(ParamError::NotFinite { field, .. }))
            | Err(SimError::Param(ParamError::OutOfRange { field, .. })) => {
                assert_eq!(field, "t_end_s", "t_end = {t_end}")
            }
            other => panic!("t_end = {t_end} (start 0.5 s): want a t_end_s error, got {other:?}"),
        }
    }
    // Zero-length runs stay allowed.
    let s = Rk4 { dt_s: 1e-6 }.run(&sys, &init, 0.5, &mut ()).unwrap();
    assert_eq!(s.final_state, init);
}
