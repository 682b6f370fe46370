//! Measuring a run: shape classes and dimensions, tube radii at probe
//! planes, flicker spectra of fluctuating vesicles, and the contact
//! curvature of an adhered vesicle; and the continuum references they are
//! held against (axisymmetric shapes, the adhered vesicle, curvature
//! sorting into a tube), which a scene may also start from.

pub mod adhesion;
pub mod axisymmetric;
pub mod contact_curvature;
pub mod shape;
pub mod spectrum;
pub mod tube_radius;
pub mod tube_sorting;
