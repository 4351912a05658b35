//! vibrobar command-line front end.
pub mod store;
