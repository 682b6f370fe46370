//! The ground floor: deterministic parallel loops, the seeded random
//! streams, serde field validators and atomic file writes. Nothing here
//! knows a membrane.

pub mod atomic_write;
pub mod parallel;
pub mod rng;
pub mod validate;
