//! The symmetric two-impacts-per-cycle orbit of the frictionless bar: one definition, in the core
//! (`analysis::orbit::symmetric`, derived there independently of the solver); the tests use it
//! under their old names.

pub use vibrobar_core::analysis::orbit::symmetric::SymmetricOrbit as Orbit;
use vibrobar_core::System;

/// Every admissible symmetric orbit of `sys`.
pub fn orbits(sys: &System) -> Vec<Orbit> {
    vibrobar_core::analysis::orbit::symmetric_orbits(sys).expect("a frictionless lumped system")
}
