//! Excitations of the bar besides the harmonic [`crate::Forcing`]: the cutting process of a
//! continuous orthogonal cut ([`Cutting`]), whose force depends on the chip thickness and so on
//! the surface left one revolution earlier (a delay differential equation).

mod cutting;

pub use cutting::{one_mode_limit_width_m, Cutting, CuttingForceLaw};
