//! The 2 s lumped paper run (r = 1, gap 0.1 mm, frictionless) with `hertz` against
//! `restitution`, exact solver, timed in alternating pairs; the median of the pairs' ratios
//! (issue #9 §6; the machine is shared, single timings drift).
use vibrobar_core::analysis::run_case;
use vibrobar_core::solver::Exact;
use vibrobar_core::*;

fn main() {
    let rest = System::paper_damped(0.1e-3, FrictionModel::None, 1.0);
    let mut hz = rest;
    hz.damper.as_mut().unwrap().contact = Contact::hertz();
    let st = RunSettings::default();
    let ex = Exact::default();
    let time = |s: &System| {
        let t = std::time::Instant::now();
        let r = run_case(s, &State::REST, &st, &ex, &mut ()).unwrap();
        (t.elapsed().as_secs_f64(), r)
    };
    let pairs: usize = std::env::args()
        .nth(1)
        .and_then(|a| a.parse().ok())
        .unwrap_or(9);
    let mut ratios = Vec::new();
    let (mut tr, mut th) = (Vec::new(), Vec::new());
    let mut contacts = 0;
    for _ in 0..pairs {
        let (a, _) = time(&rest);
        let (b, r) = time(&hz);
        contacts = r.impacts;
        ratios.push(b / a);
        tr.push(a);
        th.push(b);
    }
    // Accepted integrator steps per contact: the contact segments per release.
    struct Steps(u64);
    impl vibrobar_core::solver::Observer for Steps {
        fn segment(&mut self, seg: &dyn vibrobar_core::solver::Segment) {
            if matches!(seg.mode(), vibrobar_core::solver::Mode::Contact(_)) {
                self.0 += 1;
            }
        }
    }
    let mut steps = Steps(0);
    run_case(&hz, &State::REST, &st, &ex, &mut steps).unwrap();
    println!(
        "{:.1} accepted steps per contact",
        steps.0 as f64 / contacts as f64
    );
    let med = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    let (mr, mh, mq) = (med(&mut tr), med(&mut th), med(&mut ratios));
    println!(
        "restitution {:.2} ms, hertz {:.2} ms ({contacts} contacts, {:.1} µs per contact extra): median ratio {mq:.1}×",
        mr * 1e3,
        mh * 1e3,
        (mh - mr) / contacts as f64 * 1e6
    );
}
