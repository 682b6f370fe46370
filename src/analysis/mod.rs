//! Measuring a run: shape classes and dimensions, tube radii at probe
//! planes, and flicker spectra of fluctuating vesicles.

pub mod shape;
pub mod spectrum;
pub mod tube_radius;
