//! Confinement on the paper sweep over the full 2 s, every friction model, with the exact
//! solver's invariant checks on (a run that broke them would stop with an error).
use vibrobar_core::analysis::{linspace_inclusive, run_case};
use vibrobar_core::solver::Exact;
use vibrobar_core::*;

fn main() {
    let solver = Exact {
        check_invariants: true,
        ..Default::default()
    };
    let st = RunSettings::default();
    let t = std::time::Instant::now();
    let mut worst = f64::NEG_INFINITY;
    let mut runs = 0;
    for (fr, f) in [
        (FrictionModel::None, None),
        (FrictionModel::AsPublished, None),
        (FrictionModel::AsPublished, Some(20.0)),
        (FrictionModel::Coulomb, None),
    ] {
        for gap in [0.1e-3, 1e-3] {
            let mut line = format!("{fr:>12} f={f:?} gap={:.1} mm:", gap * 1e3);
            for r in linspace_inclusive(0.95, 1.05, 0.01) {
                let mut sys = System::paper_damped(gap, fr, r);
                sys.damper.as_mut().unwrap().friction_force_n = f;
                match run_case(&sys, &State::REST, &st, &solver, &mut ()) {
                    Ok(res) => {
                        worst = worst.max(res.summary.max_penetration_m);
                        line += &format!(" {:.2e}/{}", res.rms_m, res.impacts);
                    }
                    Err(e) => line += &format!(" ERR({e})"),
                }
                runs += 1;
            }
            println!("{line}");
        }
    }
    println!(
        "{runs} runs of 2 s, worst max_penetration_m = {worst:e}, total {:.2} s",
        t.elapsed().as_secs_f64()
    );
}
