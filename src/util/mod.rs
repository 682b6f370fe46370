//! The ground floor: deterministic parallel loops, the seeded random
//! streams, and serde field validators. Nothing here knows a membrane.

pub mod parallel;
pub mod rng;
pub mod validate;
