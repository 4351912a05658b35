//! vibrobar command-line front end.
pub mod commands;
pub mod figures;
pub mod progress;
pub mod store;
