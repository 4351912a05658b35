//! Newton's method on the stroboscopic map against the analytic symmetric orbit, and its
//! Floquet multipliers against finite differences and simulated perturbation growth.
use vibrobar_core::analysis::orbit::*;
use vibrobar_core::*;

fn paper(gap_m: f64, ratio: f64) -> System {
    System::paper_damped(gap_m, FrictionModel::None, ratio)
}

#[test]
fn explore() {
    for gap in [0.06e-3, 0.07e-3, 0.08e-3, 0.09e-3, 0.1e-3, 0.12e-3] {
        let sys = paper(gap, 1.0);
        let os = symmetric_orbits(&sys).unwrap();
        for (i, o) in os.iter().enumerate() {
            let (sec, x0) = starting_guess(&sys, 1, &Start::Symmetric(i)).unwrap();
            let orb = find_orbit(
                &sec,
                &x0,
                &FiniteDifference::default(),
                &NewtonSettings::default(),
            );
            match orb {
                Ok(orb) => println!(
                    "gap {gap:e} #{i} rms {:e} (analytic {:e}) it {} res {:e} seq {} mult {:?} phys {:?} sym {:?}",
                    orb.rms_m, o.rms_m(&sys), orb.iterations, orb.residual, orb.sequence,
                    orb.multipliers.iter().map(|l| (l.re, l.im, l.norm())).collect::<Vec<_>>(), orb.physicality, orb.symmetry_defect()
                ),
                Err(e) => println!("gap {gap:e} #{i} err {e}"),
            }
        }
    }
}

#[test]
fn explore_cont() {
    use vibrobar_core::analysis::grid::Axis;
    use vibrobar_core::analysis::orbit::continuation::*;
    let sys = paper(0.06e-3, 1.0);
    let (sec, x0) = starting_guess(&sys, 1, &Start::Symmetric(0)).unwrap();
    let orb = find_orbit(
        &sec,
        &x0,
        &FiniteDifference::default(),
        &NewtonSettings::default(),
    )
    .unwrap();
    let t = std::time::Instant::now();
    let b = continue_orbit(
        &orb,
        Axis::GapM,
        0.06e-3,
        0.002e-3,
        &FiniteDifference::default(),
        &ContinuationSettings::default(),
    )
    .unwrap();
    println!(
        "{} points in {:?}; {:?}",
        b.points.len(),
        t.elapsed(),
        b.stop_reasons
    );
    for p in &b.points {
        if p.branch == 0 && p.event.is_some() || p.branch > 0 {
            println!(
                "{} {:e} {:e} {} {} {:?} {:?} {:?}",
                p.branch,
                p.param,
                p.orbit.rms_m,
                p.orbit.sequence,
                p.orbit.section.periods,
                p.event,
                p.orbit
                    .multipliers
                    .iter()
                    .map(|l| format!("{:.7}{:+.7}i", l.re, l.im))
                    .collect::<Vec<_>>(),
                p.orbit.physicality
            );
        }
    }
}

#[test]
fn explore_touch() {
    for i in 0..21 {
        let gap = 0.05374e-3 + i as f64 * 0.00001e-3;
        let sys = paper(gap, 1.0);
        let os = symmetric_orbits(&sys).unwrap();
        for (k, _) in os.iter().enumerate() {
            let (sec, x0) = starting_guess(&sys, 1, &Start::Symmetric(k)).unwrap();
            let orb = find_orbit(
                &sec,
                &x0,
                &FiniteDifference::default(),
                &NewtonSettings::default(),
            )
            .unwrap();
            println!(
                "{gap:e} {k}/{} {:?} sym {:?}",
                os.len(),
                orb.multipliers
                    .iter()
                    .map(|l| format!("{:.7}{:+.7}i", l.re, l.im))
                    .collect::<Vec<_>>(),
                orb.symmetry_defect().unwrap()
            );
        }
    }
}

#[test]
fn explore_exact() {
    let sys = paper(0.08e-3, 1.0);
    let (sec, x0) = starting_guess(&sys, 1, &Start::Symmetric(0)).unwrap();
    let a = find_orbit(
        &sec,
        &x0,
        &FiniteDifference::default(),
        &NewtonSettings::default(),
    )
    .unwrap();
    let b = find_orbit(&sec, &x0, &ExactJacobian, &NewtonSettings::default()).unwrap();
    println!("{}\n{}", a.jacobian, b.jacobian);
    println!("{:?}\n{:?}", a.multipliers, b.multipliers);
}
