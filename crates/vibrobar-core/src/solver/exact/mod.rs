//! The exact event-driven solver.
//!
//! Between events every bar is linear with constant coefficients, so its motion is known in
//! closed form, and events are the zeros of exponential sums, found by a search that cannot miss
//! a root. The solver is written once over the bar; the folders say where each piece lives:
//!
//! | piece | where |
//! |---|---|
//! | the one event loop: the ball's modes and every transition (impact, chatter limit, stick, wall contact, release), the event limit | [`driver`] |
//! | the one compliant (`hertz`) contact phase, and under a cut | [`hertz_phase`], [`hertz_cut`] |
//! | the cutting run's drive: pieces to the breakpoints, the delayed surface's windows, cut events and their count, the surface history's start and end | `cut_loop` |
//! | the lumped bar's kernel: closed forms, event functions, root search, the cut | [`lumped`] ([`expsum`], [`roots`], [`hertz`], [`cutting`]) |
//! | the N-mode bar's kernel: the same on N modes, the ball held by the constrained modes | [`modal`] ([`expsum_n`], [`roots_n`], [`constrained`], [`modal::cutting`]) |
//!
//! A new bar is one more kernel: its run constants implement the loop's `Cavity` (what the
//! transitions read at the cavity), its run the loop's `Kernel` (build, search and close a
//! segment, the impact law, the chatter hold, an event), and its contact phase the phase's
//! `CompliantBar`. The laws are [`crate::damper`]'s.
//!
//! Accuracy: the closed forms are exact up to rounding (`sin`/`cos` of `Ωt` with `t ~ 1 s`
//! carry ~1e-12 relative phase error); event times are resolved to ~1e-15 s, positions to
//! `1e-15 l_g`; the energy audit (forcing work − viscous loss + friction work − impact losses =
//! ΔE) closes to ~1e-12 relative on the paper cases. In chaotic runs the RMS over the window
//! is only defined statistically: rounding-level changes of an event time change it by a few %.

mod cut_loop;
mod driver;
mod hertz_cut;
pub mod hertz_phase;
pub mod lumped;
pub mod modal;

pub use lumped::{cutting, expsum, hertz, roots, ExactSegment};
pub use modal::{constrained, expsum_n, roots_n};

use super::{Observer, RunSummary, Solver};
use crate::error::SimError;
use crate::params::{BarModel, State, System};

/// The exact event-driven solver.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Exact {
    /// Bound on the number of events; beyond it the run stops with [`SimError::TooManyEvents`].
    pub max_events: u64,
    /// Check confinement (`|w| ≤ l_g + 1e-12 m`) and finiteness at every event and segment end,
    /// returning [`SimError::Confinement`] / [`SimError::NonFinite`] instead of continuing.
    pub check_invariants: bool,
}

impl Default for Exact {
    fn default() -> Self {
        Exact {
            max_events: 10_000_000,
            check_invariants: false,
        }
    }
}

/// Confinement tolerance of the invariant check.
pub const CONFINEMENT_TOL_M: f64 = 1e-12;

impl Solver for Exact {
    fn name(&self) -> &'static str {
        "exact"
    }

    fn run(
        &self,
        sys: &System,
        init: &State,
        t_end_s: f64,
        obs: &mut dyn Observer,
    ) -> Result<RunSummary, SimError> {
        match &sys.bar {
            BarModel::Lumped(bar) => lumped::run(self, sys, bar, init, t_end_s, obs),
            // The same loop on the N-mode kernel.
            BarModel::Modal(model) => {
                let msys = crate::structure::ModalSystem::from_system(sys)?;
                let minit = crate::structure::ModalState::from_public(model, init)?;
                Ok(modal::ModalExact {
                    max_events: self.max_events,
                    check_invariants: self.check_invariants,
                }
                .run(&msys, &minit, t_end_s, obs)?
                .summary)
            }
        }
    }
}
