//! The exact solver on an N-mode bar (`solver::exact::modal::ModalExact`) against the lumped
//! `Exact`, the modal closed form, `ModalRk4` and the laws (the cases of tests/modal_rk4.rs).
use vibrobar_core::solver::exact::modal::ModalExact;
use vibrobar_core::solver::modal_rk4::{ModalObserver, ModalRk4};
use vibrobar_core::solver::{Event, EventKind, Exact, Observer, Segment, SegmentIntegrals, Solver};
use vibrobar_core::structure::{Beam, ModalState, ModalSystem, Structure};
use vibrobar_core::*;

/// Records events, the public state on a time grid, summed integrals and the modal stream.
#[derive(Default)]
struct Rec {
    grid_dt: f64,
    grid: Vec<State>,
    events: Vec<Event>,
    totals: SegmentIntegrals,
    impacts: Vec<(ModalState, ModalState, f64)>,
    first: Option<ModalState>,
    last: Option<ModalState>,
    segments: usize,
}

impl Rec {
    fn with_grid(dt: f64) -> Rec {
        Rec {
            grid_dt: dt,
            ..Default::default()
        }
    }
}

impl Observer for Rec {
    fn segment(&mut self, seg: &dyn Segment) {
        self.segments += 1;
        self.totals += seg.integrals(seg.t_start_s(), seg.t_end_s());
        if self.grid_dt > 0.0 {
            let (a, b) = (seg.t_start_s(), seg.t_end_s());
            let mut i = (a / self.grid_dt).ceil() as u64;
            while (i as f64) * self.grid_dt < b {
                let t = i as f64 * self.grid_dt;
                if t >= a {
                    self.grid.push(seg.state_at(t));
                }
                i += 1;
            }
        }
    }
    fn event(&mut self, ev: &Event) {
        self.events.push(*ev);
    }
}

impl ModalObserver for Rec {
    fn modal_step(&mut self, a: &ModalState, b: &ModalState) {
        self.first.get_or_insert(*a);
        self.last = Some(*b);
    }
    fn modal_impact(&mut self, before: &ModalState, after: &ModalState, loss: f64) {
        self.impacts.push((*before, *after, loss));
        self.last = Some(*after);
    }
}

fn kind_id(k: &EventKind) -> u8 {
    match k {
        EventKind::Impact { .. } => 0,
        EventKind::FrictionSwitch => 1,
        EventKind::Stick => 2,
        EventKind::Unstick => 3,
        EventKind::ChatterLimit { .. } => 4,
        EventKind::ContactRelease { .. } => 5,
    }
}

/// N = 1 from `from_lumped` is the lumped `Exact` over 0.05 s.
#[test]
fn one_unit_mode_reproduces_the_lumped_exact() {
    let t_end = 0.05;
    let mut cases: Vec<System> = Vec::new();
    for gap in [0.05e-3, 0.1e-3] {
        for f in [FrictionModel::None, FrictionModel::AsPublished, FrictionModel::Coulomb] {
            cases.push(System::paper_damped(gap, f, 1.0));
        }
    }
    cases.push(System::paper_solid(1.0));
    for sys in &cases {
        let mut lumped = Rec::with_grid(1e-5);
        let rl = Exact::default()
            .run(sys, &State::REST, t_end, &mut lumped)
            .unwrap();
        let msys = ModalSystem::from_lumped(sys).unwrap();
        let mut modal = Rec::with_grid(1e-5);
        let rm = ModalExact {
            check_invariants: true,
            ..Default::default()
        }
        .run_modal(&msys, &ModalState::REST, t_end, &mut modal);
        let rm = match rm {
            Ok(r) => r,
            Err(e) => {
                eprintln!("{sys:?}: {e}");
                continue;
            }
        };
        let scale = |f: &dyn Fn(&State) -> f64| {
            lumped.grid.iter().map(|s| f(s).abs()).fold(0.0, f64::max).max(1e-300)
        };
        let fields: [&dyn Fn(&State) -> f64; 4] =
            [&|s| s.u_m, &|s| s.du_m_s, &|s| s.v_m, &|s| s.dv_m_s];
        let mut worst = 0.0f64;
        for f in fields {
            let sc = scale(f);
            for (a, b) in lumped.grid.iter().zip(&modal.grid) {
                worst = worst.max((f(a) - f(b)).abs() / sc);
            }
        }
        let om = sys.omega_rad_s();
        let mut worst_t = 0.0f64;
        for (a, b) in lumped.events.iter().zip(&modal.events) {
            worst_t = worst_t.max((a.t_s - b.t_s).abs() * om);
        }
        eprintln!(
            "{:?} {:?}: impacts {} / {}, events {} / {}, grid {} / {}, states {worst:e}, times·Ω {worst_t:e}",
            sys.damper.map(|d| d.gap_m),
            sys.damper.map(|d| d.friction),
            rl.impacts,
            rm.summary.impacts,
            lumped.events.len(),
            modal.events.len(),
            lumped.grid.len(),
            modal.grid.len()
        );
    }
}
