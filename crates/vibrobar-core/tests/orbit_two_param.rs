//! Two-parameter curves (`analysis::orbit::two_param`) against independent computations: the
//! one-parameter continuation's located points at the curve's ratios, Newton at fixed (ratio,
//! gap) on each side of a curve point, the test function at the curve's orbits, and the same
//! codimension-two point reached along two different curves.
use vibrobar_core::analysis::grid::Axis;
use vibrobar_core::analysis::orbit::continuation::*;
use vibrobar_core::analysis::orbit::two_param::*;
use vibrobar_core::analysis::orbit::*;
use vibrobar_core::solver::Solver as _;
use vibrobar_core::*;

#[path = "common/modal_beam.rs"]
mod modal_beam;

fn paper(gap_m: f64, f: FrictionModel, r: f64) -> System {
    System::paper_damped(gap_m, f, r)
}

fn orbit_at(sys: &System) -> PeriodicOrbit {
    let (sec, x0) = starting_guess(sys, 1, &Start::Symmetric(0)).unwrap();
    find_orbit(&sec, &x0, &ExactJacobian, &NewtonSettings::default()).unwrap()
}

/// The one-parameter continuation in the gap at `ratio` from the stable symmetric orbit at
/// `seed_m` toward `to_m`: the located point of `event`.
fn one_param(
    f: FrictionModel,
    ratio: f64,
    seed_m: f64,
    to_m: f64,
    event: BranchEvent,
) -> PeriodicOrbit {
    let start = orbit_at(&paper(seed_m, f, ratio));
    assert!(start.stable());
    let s = ContinuationSettings {
        switch_branches: false,
        ..Default::default()
    };
    let b = continue_orbit(&start, Axis::GapM, seed_m, to_m, &ExactJacobian, &s).unwrap();
    let hits: Vec<&BranchPoint> = b.points.iter().filter(|p| p.event == Some(event)).collect();
    // The first one met from the stable seed: the end of the stability interval.
    assert!(!hits.is_empty(), "{:?} {:?}", event, b.stop_reasons);
    hits[0].orbit.clone()
}

fn settings() -> Curve2Settings {
    Curve2Settings {
        ratios: (0.97, 1.04),
        ..Default::default()
    }
}

fn nearest(c: &Curve, ratio: f64) -> &CurvePoint {
    c.points
        .iter()
        .min_by(|a, b| (a.ratio - ratio).abs().total_cmp(&(b.ratio - ratio).abs()))
        .unwrap()
}

/// The torus (upper) and branch-point (lower) curves of the symmetric orbit, started from the
/// one-parameter detections at r = 1, pass through the one-parameter detections at other ratios.
fn curves_through_detections(f: FrictionModel) {
    let t = std::time::Instant::now();
    let torus0 = one_param(f, 1.0, 0.07e-3, 0.12e-3, BranchEvent::Torus);
    let torus = continue_curve(&torus0, CurveKind::Torus, &settings()).unwrap();
    let bp0 = one_param(f, 1.0, 0.07e-3, 0.03e-3, BranchEvent::BranchPoint);
    let bp = continue_curve(&bp0, CurveKind::BranchPoint, &settings()).unwrap();
    eprintln!(
        "two curves and their starts: {:.2} s",
        t.elapsed().as_secs_f64()
    );
    assert!(torus.symmetric && bp.symmetric);
    assert!(torus.points.len() > 20 && bp.points.len() > 20);
    // The branch-point curve spans the whole box; the torus curve reaches r = 1.04.
    assert!(
        (bp.points[0].ratio - 0.97).abs() < 1e-12,
        "{:?}",
        bp.stop_reasons
    );
    assert!((bp.points.last().unwrap().ratio - 1.04).abs() < 1e-12);
    assert!((torus.points.last().unwrap().ratio - 1.04).abs() < 1e-12);
    for target in [0.99, 1.013, 1.035] {
        for (curve, to_m, ev) in [
            (&torus, 0.14e-3, BranchEvent::Torus),
            (&bp, 0.015e-3, BranchEvent::BranchPoint),
        ] {
            let p = nearest(curve, target);
            let o = one_param(f, p.ratio, 0.075e-3, to_m, ev);
            let g1 = o.section.system.damper.unwrap().gap_m;
            assert!(
                (g1 - p.gap_m).abs() < 1e-9,
                "{:?} at r = {}: curve {} mm, one-parameter {} mm",
                ev,
                p.ratio,
                p.gap_m * 1e3,
                g1 * 1e3
            );
        }
    }
    // At a curve point: a true orbit, the test function zero, and stability changes across it
    // (Newton at fixed gaps 1e-8 m on each side, from the analytic orbit).
    for (curve, kind) in [(&torus, CurveKind::Torus), (&bp, CurveKind::BranchPoint)] {
        for p in curve.points.iter().step_by(7) {
            assert!(p.residual < 1e-9, "{}", p.residual);
            assert!(p.orbit.physicality.confined && p.orbit.impacts_per_period == 2);
            let tf = test_function(&p.orbit, kind).unwrap().unwrap();
            assert!(tf.abs() < 1e-8, "{kind:?} test {tf}");
            let sc = scales(&p.orbit.section.system);
            let again = p.orbit.section.flow(&to_vector(&p.orbit.state)).unwrap();
            let b = to_vector(&p.orbit.state);
            for i in 0..4 {
                assert!(((again[i] - b[i]) / sc[i]).abs() < 1e-9);
            }
            if p.ratio > 0.985 {
                // Newton from the curve's orbit at the shifted gap.
                let side = |dg: f64| {
                    let sec =
                        Section::new(paper(p.gap_m + dg, f, p.ratio), p.orbit.section.t0_s, 1)
                            .unwrap();
                    let x = to_vector(&p.orbit.state);
                    find_orbit(&sec, &x, &ExactJacobian, &NewtonSettings::default()).unwrap()
                };
                let (lo, hi) = (side(-1e-8), side(1e-8));
                // Stable inside the region: below the torus curve, above the branch-point curve.
                let (inside, outside) = if kind == CurveKind::Torus {
                    (lo, hi)
                } else {
                    (hi, lo)
                };
                assert!(
                    inside.stable() && !outside.stable(),
                    "{kind:?} at r = {} gap {} mm",
                    p.ratio,
                    p.gap_m * 1e3
                );
            }
        }
    }
}

#[test]
fn frictionless_curves_pass_through_the_one_parameter_detections() {
    curves_through_detections(FrictionModel::None);
}

#[test]
fn coulomb_curves_pass_through_the_one_parameter_detections() {
    curves_through_detections(FrictionModel::Coulomb);
}

/// The fold curve of the symmetric orbit (the upper stability end below r ≈ 0.98) and the torus
/// curve meet at one zero–Hopf point (multipliers +1 and a pair on the unit circle), found
/// independently along each.
#[test]
fn fold_and_torus_curves_meet_at_the_same_codimension_two_point() {
    let f = FrictionModel::None;
    let fold0 = one_param(f, 0.96, 0.085e-3, 0.12e-3, BranchEvent::Fold);
    let s = Curve2Settings {
        ratios: (0.95, 1.0),
        ..Default::default()
    };
    let fold = continue_curve(&fold0, CurveKind::Fold, &s).unwrap();
    let torus0 = one_param(f, 1.0, 0.07e-3, 0.12e-3, BranchEvent::Torus);
    let torus = continue_curve(&torus0, CurveKind::Torus, &s).unwrap();
    let on = |c: &Curve, e: Codim2| -> Vec<(f64, f64)> {
        c.points
            .iter()
            .filter(|p| p.event == Some(e))
            .map(|p| (p.ratio, p.gap_m))
            .collect()
    };
    let a = on(&fold, Codim2::MeetsTorus);
    let b = on(&torus, Codim2::MeetsFold);
    assert_eq!((a.len(), b.len()), (1, 1), "{a:?} {b:?}");
    assert!((a[0].0 - b[0].0).abs() < 1e-8, "{a:?} {b:?}");
    assert!((a[0].1 - b[0].1).abs() < 1e-11, "{a:?} {b:?}");
    assert!((0.975..0.985).contains(&a[0].0));
    // Further on, the fold curve passes a 1:1 resonance (two multipliers +1 of the half map).
    let res = on(&fold, Codim2::StrongResonance);
    assert!(!res.is_empty(), "{:?}", fold.stop_reasons);
    assert!(res.iter().all(|r| r.0 > a[0].0));
    // Every fold-curve point: a multiplier +1 of the half map (the test function), a true orbit.
    for p in &fold.points {
        // The full period's residual: the half map's 1e-9, amplified by multipliers up to ~9.
        assert!(p.residual < 1e-7, "{}", p.residual);
        assert!(
            test_function(&p.orbit, CurveKind::Fold)
                .unwrap()
                .unwrap()
                .abs()
                < 1e-8
        );
    }
}

#[test]
fn bad_input_names_the_flag() {
    let e = CurveKind::parse("hopf").unwrap_err();
    assert!(e.contains("--kind"), "{e}");
    let o = orbit_at(&paper(0.0949e-3, FrictionModel::None, 1.0));
    for (ratios, gaps_m, flag) in [
        ((1.0, 1.0), (1e-6, 1e-3), "--ratios"),
        ((1.02, 0.98), (1e-6, 1e-3), "--ratios"),
        ((0.95, f64::NAN), (1e-6, 1e-3), "--ratios"),
        ((0.95, 1.05), (2e-4, 1e-4), "--gaps-mm"),
    ] {
        let s = Curve2Settings {
            ratios,
            gaps_m,
            ..Default::default()
        };
        let e = continue_curve(&o, CurveKind::Torus, &s)
            .unwrap_err()
            .to_string();
        assert!(e.contains(flag), "{e}");
    }
    // No torus point near a point far from one: an error, not a curve.
    let far = orbit_at(&paper(0.07e-3, FrictionModel::None, 1.0));
    let e = continue_curve(&far, CurveKind::Fold, &Curve2Settings::default());
    assert!(e.is_err());
}

/// The best gap at r = 1 inside the stability interval: no orbit on a fine independent grid of
/// gaps (Newton from the analytic orbit at each) has a smaller RMS; the solid reference RMS in
/// closed form is the exact solver's settled RMS.
#[test]
fn best_gap_is_the_smallest_rms_and_the_solid_reference_is_the_settled_run() {
    let sys = paper(0.08e-3, FrictionModel::None, 1.0);
    let (lo, hi) = (0.05384e-3, 0.09489e-3);
    let b = best_gap(&sys, lo, hi, 21).unwrap();
    assert!((lo..=hi).contains(&b.gap_m));
    assert!((b.margin_m - (b.gap_m - lo).min(hi - b.gap_m)).abs() < 1e-15);
    for i in 0..=200 {
        let g = lo + (hi - lo) * i as f64 / 200.0;
        let o = orbit_at(&paper(g, FrictionModel::None, 1.0));
        assert!(
            b.rms_m <= o.rms_m * (1.0 + 1e-9),
            "{g}: {} < {}",
            o.rms_m,
            b.rms_m
        );
    }
    let solid = System::paper_solid(1.0);
    let rms = linear_rms_m(&solid).unwrap();
    let init = State::REST;
    let t = solid.forcing_period_s();
    let mut obs = vibrobar_core::analysis::case::RmsObserver::new(400.0 * t, 600.0 * t);
    vibrobar_core::solver::Exact::default()
        .run(&solid, &init, 600.0 * t, &mut obs)
        .unwrap();
    assert!(
        (obs.rms_m() / rms - 1.0).abs() < 1e-3,
        "{} vs {rms}",
        obs.rms_m()
    );
}

/// The period-doubling curve of the asymmetric orbit (below the branch point at r = 1, as in
/// `orbit_continuation.rs`), on the full map: it passes through the one-parameter period
/// doubling at another ratio, and `det(J + I)` vanishes along it.
#[test]
fn period_doubling_curve_passes_through_the_one_parameter_detection() {
    let f = FrictionModel::None;
    let settled = |g: f64, r: f64| {
        let (sec, x0) = starting_guess(
            &paper(g, f, r),
            1,
            &Start::Settled {
                init: State::REST,
                settle_s: 0.4,
            },
        )
        .unwrap();
        find_orbit(&sec, &x0, &ExactJacobian, &NewtonSettings::default()).unwrap()
    };
    let pd_at = |r: f64, from: f64, to: f64| -> PeriodicOrbit {
        let s = ContinuationSettings {
            switch_branches: false,
            ..Default::default()
        };
        let b =
            continue_orbit(&settled(from, r), Axis::GapM, from, to, &ExactJacobian, &s).unwrap();
        b.points
            .iter()
            .find(|p| p.event == Some(BranchEvent::PeriodDoubling))
            .unwrap_or_else(|| panic!("no period doubling at r = {r}: {:?}", b.stop_reasons))
            .orbit
            .clone()
    };
    let start = pd_at(1.0, 0.052e-3, 0.0495e-3);
    let s = Curve2Settings {
        ratios: (0.995, 1.005),
        ..Default::default()
    };
    let c = continue_curve(&start, CurveKind::PeriodDoubling, &s).unwrap();
    assert!(!c.symmetric);
    assert!(c.points.len() > 3, "{:?}", c.stop_reasons);
    for p in &c.points {
        assert!(p.residual < 1e-9);
        let tf = test_function(&p.orbit, CurveKind::PeriodDoubling)
            .unwrap()
            .unwrap();
        assert!(tf.abs() < 1e-8, "{tf}");
        assert!(p
            .orbit
            .multipliers
            .iter()
            .any(|l| (l.re + 1.0).abs() < 1e-6 && l.im.abs() < 1e-6));
    }
    let p = c
        .points
        .iter()
        .filter(|p| (p.ratio - 1.0).abs() > 1e-3)
        .min_by(|a, b| (a.ratio - 1.003).abs().total_cmp(&(b.ratio - 1.003).abs()))
        .unwrap();
    let o = pd_at(p.ratio, p.gap_m + 2e-6, p.gap_m - 2e-6);
    let g1 = o.section.system.damper.unwrap().gap_m;
    assert!(
        (g1 - p.gap_m).abs() < 1e-9,
        "r = {}: curve {} one-parameter {}",
        p.ratio,
        p.gap_m,
        g1
    );
}

/// The lumped bar's one unit mode as a `[[modes]]` table (`frequency_hz = √(K/M)/2π`, `ζ`,
/// `modal_mass_kg = M`, every shape 1), as in `orbit_modal.rs`.
fn measured_one_mode(lumped: &System) -> structure::ModalSystem {
    let bar = lumped.lumped_bar().unwrap();
    let mm = structure::MeasuredMode {
        frequency_hz: bar.natural_freq_rad_s() / (2.0 * std::f64::consts::PI),
        damping_ratio: bar.damping_ratio,
        modal_mass_kg: bar.mass_kg,
        shape_cavity: 1.0,
        direction_deg: None,
    };
    structure::ModalSystem {
        model: structure::Structure::Measured(vec![mm.mode()])
            .modal_model()
            .unwrap(),
        ..structure::ModalSystem::from_lumped(lumped).unwrap()
    }
}

/// The torus curve of the symmetric orbit (the README's `continue2` example) on a one-mode
/// `[[modes]]` table with the lumped bar's `M`, `K`, `ζ`: the modal continuation (half map of the
/// modal flow, parameter columns by central differences) follows the lumped curve. At a few of
/// its points the lumped curve is corrected onto the torus point at the modal point's ratio
/// (the start's correction at fixed ratio): the gaps agree, and the lumped test function vanishes
/// at the modal point's (ratio, gap).
#[test]
fn one_mode_table_follows_the_lumped_torus_curve() {
    let s = Curve2Settings {
        ratios: (0.99, 1.01),
        max_points: 12,
        ..Default::default()
    };
    let lumped = paper(0.09489e-3, FrictionModel::None, 1.0);
    let lo = orbit_at(&lumped);
    let t = std::time::Instant::now();
    let lc = continue_curve(&lo, CurveKind::Torus, &s).unwrap();
    let tl = t.elapsed().as_secs_f64();
    let ms = modal::ModalSection::new(measured_one_mode(&lumped), lo.section.t0_s, 1).unwrap();
    let mo = modal::find_modal_orbit(&ms, &lo.vector(), &NewtonSettings::default()).unwrap();
    let t = std::time::Instant::now();
    let mc = continue_curve(&mo, CurveKind::Torus, &s).unwrap();
    eprintln!(
        "lumped {} points in {tl:.2} s, one-mode table {} points in {:.2} s; ends {:?}",
        lc.points.len(),
        mc.points.len(),
        t.elapsed().as_secs_f64(),
        mc.stop_reasons
    );
    assert!(mc.symmetric && lc.symmetric);
    assert!(mc.points.len() >= 10);
    // Both reach the box's ends in ratio.
    for c in [mc.points.first().unwrap(), mc.points.last().unwrap()] {
        assert!((c.ratio - 0.99).abs() < 1e-12 || (c.ratio - 1.01).abs() < 1e-12);
    }
    let (mut dg_max, mut tf_max) = (0.0f64, 0.0f64);
    for p in mc.points.iter().step_by(4) {
        assert!(
            p.residual < 1e-9 && p.test.abs() < 1e-8,
            "{} {}",
            p.residual,
            p.test
        );
        // The lumped curve's point at this ratio: its start corrected at fixed ratio.
        let sys = paper(p.gap_m, FrictionModel::None, p.ratio);
        let sec = Section::new(sys, p.orbit.section.t0_s, 1).unwrap();
        let x = p.orbit.vector();
        let o = find_orbit(&sec, &x, &ExactJacobian, &NewtonSettings::default()).unwrap();
        let tf = test_function(&o, CurveKind::Torus).unwrap().unwrap();
        let at =
            continue_curve(&o, CurveKind::Torus, &Curve2Settings { max_points: 2, ..s }).unwrap();
        let q = at
            .points
            .iter()
            .find(|q| (q.ratio - p.ratio).abs() < 1e-14)
            .expect("the corrected start");
        let dg = (q.gap_m - p.gap_m).abs() / p.gap_m;
        eprintln!(
            "  r = {:.6}: gap {:.9} mm (modal) {:.9} mm (lumped), relative {dg:.1e}; lumped test {tf:.1e}",
            p.ratio,
            p.gap_m * 1e3,
            q.gap_m * 1e3
        );
        dg_max = dg_max.max(dg);
        tf_max = tf_max.max(tf.abs());
    }
    assert!(dg_max < 1e-9, "{dg_max:e}");
    assert!(tf_max < 1e-8, "{tf_max:e}");
}

/// A short period-doubling curve of the asymmetric two-impact orbit of the 4-mode paper beam
/// (r = 1.02, found by the one-parameter continuation in the gap): every point a true orbit of
/// the modal map with its test function `det(J + I)` at zero.
#[test]
fn four_mode_beam_period_doubling_curve_stays_on_its_zero() {
    use structure::ModalState;
    let g0 = 0.06e-3;
    let sys = modal_beam::beam_system(4, Some(Damper::paper(g0, FrictionModel::None)), 1.02);
    let o = modal::modal_orbit_settled(&sys, 1, &ModalState::REST, 0.5).unwrap();
    let fam = modal::ModalFamily {
        base: sys,
        beam: None,
        param: modal::ModalParam::Axis(Axis::GapM),
    };
    let s = ContinuationSettings {
        switch_branches: false,
        max_points: 200,
        ..Default::default()
    };
    let b = modal::continue_modal_orbit(&o, &fam, g0, 0.14e-3, &s).unwrap();
    let pd = b
        .points
        .iter()
        .find(|p| p.event == Some(BranchEvent::PeriodDoubling))
        .expect("a period doubling");
    let t = std::time::Instant::now();
    let c = continue_curve(
        &pd.orbit,
        CurveKind::PeriodDoubling,
        &Curve2Settings {
            ratios: (1.0, 1.04),
            max_points: 6,
            ..Default::default()
        },
    )
    .unwrap();
    eprintln!(
        "4-mode beam: start gap {:.6} mm; {} points in {:.2} s; ends {:?}",
        pd.param * 1e3,
        c.points.len(),
        t.elapsed().as_secs_f64(),
        c.stop_reasons
    );
    assert!(!c.symmetric);
    assert!(c.points.len() >= 5);
    let r = c.points.iter().map(|p| p.ratio);
    let span = r.clone().fold(f64::NEG_INFINITY, f64::max) - r.fold(f64::INFINITY, f64::min);
    assert!(span > 1e-3, "{span}");
    let mut worst = 0.0f64;
    for p in &c.points {
        let tf = test_function(&p.orbit, CurveKind::PeriodDoubling)
            .unwrap()
            .unwrap();
        eprintln!(
            "  r = {:.6}, gap {:.6} mm: test {:.1e} (again {tf:.1e}), residual {:.1e}, |λ| {:.3}",
            p.ratio,
            p.gap_m * 1e3,
            p.test,
            p.residual,
            p.orbit.max_abs_multiplier()
        );
        assert!(p.residual < 1e-9 && p.orbit.physicality.confined);
        assert_eq!(p.orbit.section.dim(), 10);
        worst = worst.max(p.test.abs()).max(tf.abs());
    }
    assert!(worst < 1e-8, "{worst:e}");
}

/// The half map `G(x) = −P_{T/2}(x)` on the N-mode bar: the modal equations are odd in
/// `(q, q̇, w, ẇ)` with the harmonic force shifted by half a period, so the full map is `G∘G`
/// from the same section time, for any state (here the 4-mode beam's asymmetric orbit, which
/// is not a fixed point of `G`, and a state off it).
#[test]
fn four_mode_beam_full_map_is_the_half_map_squared() {
    use structure::ModalState;
    let sys = modal_beam::beam_system(4, Some(Damper::paper(0.06e-3, FrictionModel::None)), 1.02);
    let o = modal::modal_orbit_settled(&sys, 1, &ModalState::REST, 0.5).unwrap();
    let sec = o.section.clone();
    let sc = sec.scales();
    let half = |x: &[f64]| -> Vec<f64> {
        let (s, _) = sec
            .run(&sec.state(x), sec.t0_s + 0.5 * sec.period_s(), &mut ())
            .unwrap();
        sec.vector(&s).iter().map(|v| -v).collect()
    };
    let x0 = o.vector();
    let mut x1 = x0.clone();
    x1[0] *= 1.1;
    x1[5] *= 0.9;
    for x in [x0, sec.clamp(&x1)] {
        let full = sec.flow(&x).unwrap();
        let gg = half(&half(&x));
        let d = (0..x.len())
            .map(|i| ((full[i] - gg[i]) / sc[i]).abs())
            .fold(0.0, f64::max);
        let g = half(&x);
        let moved = (0..x.len())
            .map(|i| ((g[i] - x[i]) / sc[i]).abs())
            .fold(0.0, f64::max);
        eprintln!("P − G∘G: {d:.1e} scaled (G moves x by {moved:.2e})");
        assert!(d < 1e-9, "{d:e}");
        assert!(moved > 1e-3);
    }
    assert!(symmetry_defect(&o).unwrap().unwrap() > 1e-3);
}
