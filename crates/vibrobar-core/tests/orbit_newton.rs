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
            let orb = find_orbit(&sec, &x0, &FiniteDifference::default(), &NewtonSettings::default());
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
