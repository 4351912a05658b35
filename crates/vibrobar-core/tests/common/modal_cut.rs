//! The cutting setup of the modal cutting tests (`modal_cutting.rs`,
//! `modal_cutting_three_quarter.rs`, which include it with `#[path]`): the cut, the bars
//! without harmonic forcing, and the observers that sample a run and count its events.
#![allow(dead_code)]

use vibrobar_core::excitation::{Cutting, CuttingForceLaw};
use vibrobar_core::params::{BarModel, Damper, Forcing, Frequency, System};
use vibrobar_core::solver::{Event, EventKind, Observer, Segment};
use vibrobar_core::structure::{Mode, Structure};

pub const KF: f64 = 2e9;
pub const H0: f64 = 1e-4;

/// The cut at `width_m` and `rpm` with `force_law`.
pub fn cut_law(width_m: f64, rpm: f64, force_law: CuttingForceLaw) -> Cutting {
    Cutting {
        coefficient_n_m2: KF,
        width_m,
        feed_m: H0,
        spindle_rpm: rpm,
        force_direction_factor: 1.0,
        chip_direction_factor: 1.0,
        force_law,
    }
}

pub fn no_force() -> Forcing {
    Forcing {
        amplitude_n: 0.0,
        frequency: Frequency::Ratio(1.0),
        static_force_n: 0.0,
    }
}

pub fn modal_system(modes: Vec<Mode>, damper: Option<Damper>) -> System {
    System {
        bar: BarModel::Modal(Structure::Measured(modes).modal_model().unwrap()),
        damper,
        forcing: no_force(),
        gravity_m_s2: 9.81,
    }
}

/// Samples the public state and the cut on a uniform grid; counts events.
pub struct Sampler {
    pub dt: f64,
    pub next: f64,
    pub t: Vec<f64>,
    pub u: Vec<f64>,
    pub max_abs_w: f64,
    pub min_chip: f64,
    pub out_of_cut: bool,
    pub impacts: u64,
    pub events: u64,
    pub stick: u64,
}

impl Sampler {
    pub fn new(dt: f64) -> Self {
        Sampler {
            dt,
            next: 0.0,
            t: vec![],
            u: vec![],
            max_abs_w: 0.0,
            min_chip: f64::INFINITY,
            out_of_cut: false,
            impacts: 0,
            events: 0,
            stick: 0,
        }
    }
}

impl Observer for Sampler {
    fn segment(&mut self, seg: &dyn Segment) {
        let st = seg.state_at(seg.t_end_s());
        self.max_abs_w = self.max_abs_w.max(st.w_m().abs());
        while self.next <= seg.t_end_s() {
            if self.next >= seg.t_start_s() {
                let st = seg.state_at(self.next);
                self.t.push(self.next);
                self.u.push(st.u_m);
                self.max_abs_w = self.max_abs_w.max(st.w_m().abs());
                let c = seg.cutting_at(self.next).unwrap();
                self.min_chip = self.min_chip.min(c.chip_thickness_m);
                self.out_of_cut |= !c.in_cut;
            }
            self.next += self.dt;
        }
    }
    fn event(&mut self, ev: &Event) {
        self.events += 1;
        match ev.kind {
            EventKind::Impact { .. } => self.impacts += 1,
            EventKind::Stick => self.stick += 1,
            _ => {}
        }
        self.max_abs_w = self.max_abs_w.max(ev.after.w_m().abs());
    }
}

/// Counts sticks and chatter limits.
#[derive(Default)]
pub struct Kinds {
    pub stick: u64,
    pub chatter: u64,
}

impl Observer for Kinds {
    fn event(&mut self, ev: &Event) {
        match ev.kind {
            EventKind::Stick => self.stick += 1,
            EventKind::ChatterLimit { .. } => self.chatter += 1,
            _ => {}
        }
    }
}
