//! Measuring a run: shape classes and dimensions, tube radii at probe
//! planes, flicker spectra of fluctuating vesicles, and the contact
//! curvature of an adhered vesicle.

pub mod contact_curvature;
pub mod shape;
pub mod spectrum;
pub mod tube_radius;
