//! Exact vs RK4 on the paper sweep (11 ratios × gaps {0.1, 1} mm × friction {none,
//! as-published 0.0204 N, as-published 20 N, coulomb 0.0204 N}, 2 s each, + 11 solid bars),
//! single-threaded, in one process so that both see the same load. RK4 runs only every
//! `rk4_stride`-th point (0: exact per case only) and is scaled to the whole sweep.
//! `cargo run --release -p vibrobar-core --example exact_paper_bench [rk4_stride]`
use std::time::Instant;
use vibrobar_core::analysis::{linspace_inclusive, run_case, sweep, SweepBase, SweepPoint};
use vibrobar_core::solver::{Exact, Rk4, Solver};
use vibrobar_core::*;

fn cases() -> Vec<(&'static str, FrictionModel, Option<f64>)> {
    vec![
        ("none", FrictionModel::None, None),
        ("as-pub 0.0204N", FrictionModel::AsPublished, None),
        ("as-pub 20N", FrictionModel::AsPublished, Some(20.0)),
        ("coulomb 0.0204N", FrictionModel::Coulomb, None),
    ]
}

fn points() -> Vec<SweepPoint> {
    let mut v = Vec::new();
    for (_, friction, friction_force_n) in cases() {
        for gap_m in [0.1e-3, 1e-3] {
            for ratio in linspace_inclusive(0.95, 1.05, 0.01) {
                v.push(SweepPoint {
                    ratio,
                    gap_m,
                    friction,
                    friction_force_n,
                });
            }
        }
    }
    v
}

fn main() {
    let stride: usize = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(11);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    let base = SweepBase::paper();
    let st = RunSettings::default();
    let pts = points();
    let ex = Exact::default();
    pool.install(|| {
        // Per case: exact time per point, events per run.
        let mut total_ex = 0.0;
        for (name, fr, f) in cases() {
            for gap in [0.1e-3, 1e-3] {
                let mut tt = 0.0;
                let mut ev = 0u64;
                let mut worst = 0.0f64;
                let mut n = 0;
                for p in pts
                    .iter()
                    .filter(|p| p.friction == fr && p.friction_force_n == f && p.gap_m == gap)
                {
                    let sys = base.damped_system(p);
                    let t = Instant::now();
                    let r = run_case(&sys, &State::REST, &st, &ex, &mut ()).unwrap();
                    let dt = t.elapsed().as_secs_f64();
                    tt += dt;
                    worst = worst.max(dt);
                    ev += r.summary.events;
                    n += 1;
                }
                total_ex += tt;
                println!(
                    "exact {name:>16} gap {:.1} mm: {:7.3} ms/pt (max {:7.3}), {:7.0} events/run, {:6.2} µs/event",
                    gap * 1e3,
                    tt / n as f64 * 1e3,
                    worst * 1e3,
                    ev as f64 / n as f64,
                    tt / ev.max(1) as f64 * 1e6
                );
            }
        }
        let t = Instant::now();
        for r in linspace_inclusive(0.95, 1.05, 0.01) {
            run_case(&base.solid_system(r), &State::REST, &st, &ex, &mut ()).unwrap();
        }
        let solid = t.elapsed().as_secs_f64();
        println!("exact solid: {:.3} ms/pt", solid / 11.0 * 1e3);
        if stride == 0 {
            return;
        }
        let t = Instant::now();
        sweep(&pts, &base, &st, &ex, &|_, _| {}).unwrap();
        let sw_ex = t.elapsed().as_secs_f64();
        println!(
            "exact sum of cases {:.3} s; sweep() {:.3} s for {} runs",
            total_ex + solid,
            sw_ex,
            pts.len() + 11
        );
        // RK4 on a subset, scaled.
        let rk = Rk4::default();
        let sub: Vec<&SweepPoint> = pts.iter().step_by(stride).collect();
        let t = Instant::now();
        for p in &sub {
            run_case(&base.damped_system(p), &State::REST, &st, &rk as &dyn Solver, &mut ()).unwrap();
        }
        let rk_run = t.elapsed().as_secs_f64() / sub.len() as f64;
        let rk_sweep = rk_run * (pts.len() + 11) as f64;
        println!(
            "rk4: {:.1} ms/run ({} runs), sweep estimate {:.2} s",
            rk_run * 1e3,
            sub.len(),
            rk_sweep
        );
        println!(
            "ratio rk4/exact over the sweep: {:.1}x (sweep()), {:.1}x (per-case sum)",
            rk_sweep / sw_ex,
            rk_sweep / (total_ex + solid)
        );
    });
}
