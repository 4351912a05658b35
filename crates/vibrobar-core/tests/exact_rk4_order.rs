//! RK4 converges to the exact solver as dt → 0: order 4 without impacts, about 1 with the
//! paper's after-step impact detection.
use vibrobar_core::solver::{Exact, Rk4, Solver};
use vibrobar_core::*;

#[path = "common/fit.rs"]
mod fit;
use fit::log_log_slope;

/// State error in metres (velocity scaled by 1/Ω).
fn error(sys: &System, t_end: f64, dt: f64, reference: &State) -> (f64, u64) {
    let r = Rk4 { dt_s: dt }
        .run(sys, &State::REST, t_end, &mut ())
        .unwrap();
    let s = r.final_state;
    let e = (s.u_m - reference.u_m).hypot((s.du_m_s - reference.du_m_s) / sys.omega_rad_s());
    (e, r.impacts)
}

#[test]
fn rk4_is_fourth_order_without_impacts() {
    let sys = System::paper_solid(1.0);
    let t_end = 0.02;
    let ex = Exact::default()
        .run(&sys, &State::REST, t_end, &mut ())
        .unwrap();
    let pts: Vec<(f64, f64)> = [1.6e-5, 8e-6, 4e-6, 2e-6]
        .iter()
        .map(|&dt| (dt, error(&sys, t_end, dt, &ex.final_state).0))
        .collect();
    let p = log_log_slope(&pts);
    eprintln!("rk4 order without impacts: {p:.3} ({pts:?})");
    assert!((p - 4.0).abs() < 0.1, "order {p}");
}

#[test]
fn rk4_is_about_first_order_with_impacts() {
    let sys = System::paper_damped(0.1e-3, FrictionModel::None, 1.0);
    let t_end = 0.05;
    let ex = Exact::default()
        .run(&sys, &State::REST, t_end, &mut ())
        .unwrap();
    assert!(ex.impacts >= 20);
    let mut pts = Vec::new();
    for dt in [2e-6, 1e-6, 5e-7, 2.5e-7] {
        let (e, imp) = error(&sys, t_end, dt, &ex.final_state);
        // Same impact sequence: the comparison is meaningful.
        assert_eq!(imp, ex.impacts, "dt = {dt}");
        pts.push((dt, e));
    }
    let p = log_log_slope(&pts);
    eprintln!("rk4 order with impacts: {p:.3} ({pts:?})");
    assert!(p > 0.6 && p < 1.6, "order {p}");
}
