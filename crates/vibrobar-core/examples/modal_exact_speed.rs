//! ModalExact against the lumped Exact on the paper-like 2 s run (ratio 1, gap 0.1 mm): wall
//! time (median of repeated runs in one process), impacts, events and proven root-search steps
//! per event. A measurement, not a test.
use vibrobar_core::solver::exact::modal::ModalExact;
use vibrobar_core::solver::{Exact, Solver};
use vibrobar_core::structure::{Beam, ModalState, ModalSystem, Structure};
use vibrobar_core::*;

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() {
    let reps = 7;
    let t_end = 2.0;
    let beam = |n: usize, sys: &System| ModalSystem {
        model: Structure::Beam(Beam {
            modes: Some(n),
            ..Beam::default()
        })
        .modal_model()
        .unwrap(),
        damper: sys.damper,
        forcing: sys.forcing,
        gravity_m_s2: sys.gravity_m_s2,
    };
    for f in [
        FrictionModel::None,
        FrictionModel::AsPublished,
        FrictionModel::Coulomb,
    ] {
        let sys = System::paper_damped(0.1e-3, f, 1.0);
        let mut tl = Vec::new();
        let mut rl = None;
        for _ in 0..reps {
            let t = std::time::Instant::now();
            rl = Some(Exact::default().run(&sys, &State::REST, t_end, &mut ()));
            tl.push(t.elapsed().as_secs_f64());
        }
        let rl = rl.unwrap();
        let tl = median(tl);
        match &rl {
            Ok(r) => println!(
                "{f}: lumped Exact {:.3} ms, {} impacts, {} events",
                tl * 1e3,
                r.impacts,
                r.events
            ),
            Err(e) => println!("{f}: lumped Exact error {e}"),
        }
        for (name, msys) in [
            ("N = 1 from_lumped", ModalSystem::from_lumped(&sys).unwrap()),
            ("4-mode beam", beam(4, &sys)),
            ("8-mode beam", beam(8, &sys)),
        ] {
            let mut tm = Vec::new();
            let mut res = None;
            for _ in 0..reps {
                let t = std::time::Instant::now();
                res = Some(ModalExact::default().run_counted(
                    &msys,
                    &ModalState::REST,
                    t_end,
                    &mut (),
                ));
                tm.push(t.elapsed().as_secs_f64());
            }
            let tm = median(tm);
            match res.unwrap() {
                Ok((r, steps)) => println!(
                    "  {name}: {:.3} ms ({:.2}× lumped), {} impacts, {} events, {:.1} search steps per event",
                    tm * 1e3,
                    tm / tl,
                    r.summary.impacts,
                    r.summary.events,
                    steps as f64 / r.summary.events.max(1) as f64
                ),
                Err(e) => println!("  {name}: error after {:.3} ms: {e}", tm * 1e3),
            }
        }
    }
}
