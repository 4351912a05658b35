//! Pseudo-arclength continuation.
