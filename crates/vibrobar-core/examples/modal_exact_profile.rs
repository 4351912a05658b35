//! One paper-like 2 s run for a profiler (callgrind, perf): `modal_exact_profile N LAW [reps]`,
//! `N = 0` the lumped `Exact`, `N = 1` the lumped bar as one unit mode in `ModalExact`, else the
//! paper's beam with `N` modes; LAW `none`, `as-published` or `coulomb`; a fourth argument
//! `case` runs the bench's own path instead (`vibrobar bench`'s beam rows: the placement study's
//! case with its RMS and regime observers, `N = 0` the lumped bar, else the 38 mm cavity beam
//! with `N` modes). A measurement, not a test.
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
    if a.get(4).map(String::as_str) == Some("case") {
        bench_case(n, law, reps);
        return;
    }
    let r0: f64 = std::env::var("RATIO")
        .ok()
        .map(|v| v.parse().unwrap())
        .unwrap_or(1.0);
    let sys = System::paper_damped(0.1e-3, law, r0);
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
    let (mut events, mut steps) = (0, 0);
    for _ in 0..reps {
        if n == 0 {
            let r = Exact::default()
                .run(&sys, &State::REST, 2.0, &mut ())
                .unwrap();
            events = r.events;
            std::hint::black_box(r);
        } else {
            let (r, st) = ModalExact::default()
                .run_counted(&msys, &ModalState::REST, 2.0, &mut ())
                .unwrap();
            events = r.summary.events;
            steps = st;
            std::hint::black_box(r);
        }
    }
    println!("{events} events, {steps} search steps");
}

/// The bench's beam-row path (`vibrobar bench`, issue #8 §8): `solver_case` of the placement
/// study with the default settings, on the lumped paper bar (`n = 0`) or the default beam.
fn bench_case(n: usize, law: FrictionModel, reps: usize) {
    use vibrobar_core::analysis::placement::{solver_case, PlacementSpec};
    use vibrobar_core::analysis::regime::Tolerances;
    let spec = PlacementSpec {
        beam: Beam::default().with_modes(n.max(1)),
        ball: Damper::paper(0.1e-3, law),
        forcing: Forcing::paper(1.0),
        gravity_m_s2: params::STANDARD_GRAVITY_M_S2,
        settings: RunSettings::default(),
        tolerances: Tolerances::default(),
    };
    // `RATIOS=0.98,0.99,...` runs those ratios in turn (a cost averaged over several chaotic
    // runs); by default the bench's own r = 1.
    let ratios: Vec<f64> = std::env::var("RATIOS")
        .ok()
        .map(|v| v.split(',').map(|x| x.parse().unwrap()).collect())
        .unwrap_or_else(|| vec![1.0]);
    let solver = Exact::default();
    let run = solver_case(&solver, spec.settings, spec.tolerances, false);
    let system = |r: f64| {
        if n == 0 {
            System::paper_damped(0.1e-3, law, r)
        } else {
            let model = spec.damped_model(spec.beam.cavity_position_m).unwrap();
            spec.system(&model, Some(spec.ball), r)
        }
    };
    let mut rms = 0.0;
    for &r in &ratios {
        let sys = system(r);
        for _ in 0..reps {
            rms = run(&sys).unwrap().rms_m;
        }
    }
    // `EVENTS=1`: the event count of each ratio's run (one more run each, not timed), to
    // compare costs per event between chaotic runs.
    if std::env::var("EVENTS").is_ok() {
        for &r in &ratios {
            let ev = solver
                .run(&system(r), &State::REST, 2.0, &mut ())
                .unwrap()
                .events;
            println!("r {r}: {ev} events");
        }
    }
    println!("rms {rms:.6e} m");
}
