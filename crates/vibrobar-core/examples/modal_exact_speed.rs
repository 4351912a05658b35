//! ModalExact against the lumped Exact on the paper-like 2 s run (ratio 1, gap 0.1 mm, every
//! friction law): wall time and the ratio to the lumped run (each repetition times the lumped
//! run and the modal one back to back, so both see the same machine load; the median of the
//! per-repetition ratios, and the ratio of the fastest runs, the least disturbed on a shared
//! machine), impacts, events and proven root-search steps per event. A measurement, not a
//! test: `cargo run --release -p vibrobar-core --example modal_exact_speed [reps]`.
use vibrobar_core::solver::exact::modal::ModalExact;
use vibrobar_core::solver::{Exact, Solver};
use vibrobar_core::structure::{Beam, ModalState, ModalSystem, Structure};
use vibrobar_core::*;

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() {
    let reps: usize = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(9);
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
    for f in FrictionModel::ALL {
        let sys = System::paper_damped(0.1e-3, f, 1.0);
        let rl = Exact::default()
            .run(&sys, &State::REST, t_end, &mut ())
            .unwrap();
        println!(
            "{f} (friction level {:.4} N): lumped Exact {} impacts, {} events",
            sys.friction_level_n(),
            rl.impacts,
            rl.events
        );
        for (name, msys) in [
            ("N = 1 from_lumped", ModalSystem::from_lumped(&sys).unwrap()),
            ("4-mode beam", beam(4, &sys)),
            ("8-mode beam", beam(8, &sys)),
        ] {
            let (mut tl, mut tm, mut ratio) = (Vec::new(), Vec::new(), Vec::new());
            let mut res = None;
            for _ in 0..reps {
                let t = std::time::Instant::now();
                Exact::default()
                    .run(&sys, &State::REST, t_end, &mut ())
                    .unwrap();
                let a = t.elapsed().as_secs_f64();
                let t = std::time::Instant::now();
                res = Some(
                    ModalExact::default()
                        .run_counted(&msys, &ModalState::REST, t_end, &mut ())
                        .unwrap(),
                );
                let b = t.elapsed().as_secs_f64();
                tl.push(a);
                tm.push(b);
                ratio.push(b / a);
            }
            let (r, steps) = res.unwrap();
            let fastest = |v: &[f64]| v.iter().cloned().fold(f64::INFINITY, f64::min);
            println!(
                "  {name}: {:.3} ms vs lumped {:.3} ms (fastest of {reps}): ratio {:.2}, median ratio {:.2}; {} impacts, {} events, {:.1} search steps per event",
                fastest(&tm) * 1e3,
                fastest(&tl) * 1e3,
                fastest(&tm) / fastest(&tl),
                median(ratio),
                r.summary.impacts,
                r.summary.events,
                steps as f64 / r.summary.events.max(1) as f64
            );
        }
    }
}
