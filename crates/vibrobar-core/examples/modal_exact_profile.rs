//! One paper-like 2 s run for a profiler (callgrind, perf): `modal_exact_profile N LAW [reps]`,
//! `N = 0` the lumped `Exact`, `N = 1` the lumped bar as one unit mode in `ModalExact`, else the
//! paper's beam with `N` modes; LAW `none`, `as-published` or `coulomb`. A measurement, not a test.
use vibrobar_core::solver::exact::modal::ModalExact;
use vibrobar_core::solver::{Exact, Solver};
use vibrobar_core::structure::{Beam, ModalState, ModalSystem, Structure};
use vibrobar_core::*;

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let n: usize = a.get(1).and_then(|s| s.parse().ok()).unwrap_or(4);
    let law = match a.get(2).map(String::as_str) {
        Some("as-published") => FrictionModel::AsPublished,
        Some("coulomb") => FrictionModel::Coulomb,
        _ => FrictionModel::None,
    };
    let reps: usize = a.get(3).and_then(|s| s.parse().ok()).unwrap_or(1);
    let sys = System::paper_damped(0.1e-3, law, 1.0);
    let msys = if n == 1 {
        ModalSystem::from_lumped(&sys).unwrap()
    } else {
        ModalSystem {
            model: Structure::Beam(Beam {
                modes: Some(n.max(1)),
                ..Beam::default()
            })
            .modal_model()
            .unwrap(),
            damper: sys.damper,
            forcing: sys.forcing,
            gravity_m_s2: sys.gravity_m_s2,
        }
    };
    for _ in 0..reps {
        if n == 0 {
            let r = Exact::default()
                .run(&sys, &State::REST, 2.0, &mut ())
                .unwrap();
            std::hint::black_box(r);
        } else {
            let r = ModalExact::default()
                .run(&msys, &ModalState::REST, 2.0, &mut ())
                .unwrap();
            std::hint::black_box(r);
        }
    }
}
