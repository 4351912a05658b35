//! Confinement and finiteness on the paper's sweep points, every friction model: checked at every
//! event and segment end by the solver's invariant mode, and at every output sample here.
use vibrobar_core::analysis::{linspace_inclusive, Sampler};
use vibrobar_core::solver::{Exact, Solver};
use vibrobar_core::*;

#[test]
fn ball_stays_in_the_cavity_on_the_paper_sweep() {
    let solver = Exact {
        check_invariants: true,
        ..Default::default()
    };
    let mut total_impacts = 0;
    assert_eq!(linspace_inclusive(0.95, 1.05, 0.01).len(), 11);
    for r in linspace_inclusive(0.95, 1.05, 0.01) {
        for gap in [0.1e-3, 1e-3] {
            for (fr, f) in [
                (FrictionModel::None, None),
                (FrictionModel::AsPublished, None),
                (FrictionModel::AsPublished, Some(20.0)),
                (FrictionModel::Coulomb, None),
            ] {
                let mut sys = System::paper_damped(gap, fr, r);
                sys.damper.as_mut().unwrap().friction_force_n = f;
                let mut sampler = Sampler::new(0.0, 1e-5);
                let sum = solver
                    .run(&sys, &State::REST, 0.2, &mut sampler)
                    .unwrap_or_else(|e| panic!("r={r} gap={gap} {fr} {f:?}: {e}"));
                let lg = 0.5 * gap;
                assert!(sum.max_penetration_m <= 1e-12);
                for s in &sampler.samples {
                    assert!(
                        s.w_m().abs() <= lg + 1e-12 && s.u_m.is_finite() && s.v_m.is_finite(),
                        "r={r} gap={gap} {fr} {f:?}: w = {} at t = {}",
                        s.w_m(),
                        s.t_s
                    );
                }
                assert_eq!(sampler.samples.len(), 20_001);
                total_impacts += sum.impacts;
            }
        }
    }
    assert!(total_impacts > 1000);
}
