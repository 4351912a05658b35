//! The bench's cutting row alone (issue #13 speed): the damped paper bar at 5000 rpm and
//! 1.5 b_lim against its harmonic run, exact solver, 2 s each; `ARG1` = `cut` or `harm` runs
//! only that one once (for callgrind), else alternating pairs and medians.
use vibrobar_core::analysis::run_case;
use vibrobar_core::excitation::{one_mode_limit_width_m, Cutting, CuttingForceLaw};
use vibrobar_core::solver::exact::cutting::ExactCutting;
use vibrobar_core::solver::Exact;
use vibrobar_core::*;

fn main() {
    let st = RunSettings::default();
    let harmonic = System::paper_damped(0.1e-3, FrictionModel::None, 1.0);
    let bar = Bar::PAPER_CAVITY;
    let mut cut = Cutting {
        coefficient_n_m2: 2e9,
        width_m: 1.0,
        feed_m: 1e-4,
        spindle_rpm: 5000.0,
        force_direction_factor: 1.0,
        chip_direction_factor: 1.0,
        force_law: CuttingForceLaw::Linear,
    };
    let (b_lim, _) =
        one_mode_limit_width_m(&cut, bar.mass_kg, bar.stiffness_n_per_m, bar.damping_ratio);
    cut.width_m = 1.5 * b_lim;
    let mut csys = harmonic;
    csys.forcing.amplitude_n = 0.0;
    let mut cutting = ExactCutting::new(cut);
    if let Some(s) = std::env::var("STEPS").ok().and_then(|s| s.parse().ok()) {
        cutting.steps_per_period = s;
    }
    let exact = Exact::default();
    let kick = State {
        u_m: 0.1 * cut.feed_m,
        v_m: 0.1 * cut.feed_m,
        ..State::REST
    };
    let arg = std::env::args().nth(1).unwrap_or_default();
    if arg == "cut" {
        let r = run_case(&csys, &kick, &st, &cutting, &mut ()).unwrap();
        println!(
            "cut rms {:.15e} impacts {} events {}",
            r.rms_m, r.impacts, r.summary.events
        );
        return;
    }
    if arg == "harm" {
        let r = run_case(&harmonic, &State::REST, &st, &exact, &mut ()).unwrap();
        println!("harm rms {:.15e} impacts {}", r.rms_m, r.impacts);
        return;
    }
    let mut ratios = Vec::new();
    let (mut th, mut tc) = (Vec::new(), Vec::new());
    let mut last = None;
    for _ in 0..21 {
        let t = std::time::Instant::now();
        run_case(&harmonic, &State::REST, &st, &exact, &mut ()).unwrap();
        let h = t.elapsed().as_secs_f64();
        let t = std::time::Instant::now();
        last = Some(run_case(&csys, &kick, &st, &cutting, &mut ()).unwrap());
        let c = t.elapsed().as_secs_f64();
        th.push(h);
        tc.push(c);
        ratios.push(c / h);
    }
    for v in [&mut th, &mut tc, &mut ratios] {
        v.sort_by(f64::total_cmp);
    }
    let r = last.unwrap();
    println!(
        "medians: harm {:.2} ms cut {:.2} ms ratio {:.2}; minima: harm {:.2} ms cut {:.2} ms \
         ratio {:.2} (rms {:.15e}, {} impacts)",
        th[10] * 1e3,
        tc[10] * 1e3,
        ratios[10],
        th[0] * 1e3,
        tc[0] * 1e3,
        tc[0] / th[0],
        r.rms_m,
        r.impacts
    );
}
