use vibrobar_core::analysis::run_case;
use vibrobar_core::solver::Rk4;
use vibrobar_core::*;
fn main() {
    let st = RunSettings::default();
    let args: Vec<String> = std::env::args().collect();
    let fr = FrictionModel::parse(args.get(1).map(|s| s.as_str()).unwrap_or("none")).unwrap();
    let gap: f64 = args.get(2).map(|s| s.parse().unwrap()).unwrap_or(0.1e-3);
    let ff: Option<f64> = args.get(3).map(|s| s.parse().unwrap());
    for r in [0.95, 0.98, 0.99, 1.0, 1.01, 1.02, 1.05] {
        let t = std::time::Instant::now();
        let solid = run_case(
            &System::paper_solid(r),
            &State::REST,
            &st,
            &Rk4::default(),
            &mut (),
        )
        .unwrap();
        let mut sys = System::paper_damped(gap, fr, r);
        sys.damper.as_mut().unwrap().friction_force_n = ff;
        let d = run_case(&sys, &State::REST, &st, &Rk4::default(), &mut ()).unwrap();
        println!(
            "r={r} solid={:.4e} damped={:.4e} red={:.1}% imp={} ipc={:.2} pen={:.2e} {:?}",
            solid.rms_m,
            d.rms_m,
            100.0 * (1.0 - d.rms_m / solid.rms_m),
            d.impacts,
            d.impacts_per_cycle,
            d.summary.max_penetration_m,
            t.elapsed()
        );
    }
}
