//! The built-in energy terms, one file each: its parameters (with units),
//! its kernel on dense arrays (the energy and, given a force buffer, −∇E
//! added to it), its [`ForceTerm`](crate::engine::force::ForceTerm) with
//! its flip pricing, and its plugin (`plugin`), shaped like a user's term
//! (the BAR-domain example). V_in's plugin also adds the Gather system that
//! measures its edges ([`vin_edge_samples`]). [`builtin`] says what makes a
//! term built in, and the list below generates the scene's [`EnergyTerm`].
//! The line tension of free boundary loops ([`line_tension`]) is added by
//! the boundary conditions, not listed here. Shared kernels: the penalty machinery
//! ([`penalty`]: volume, area and local-tension kernels, 1-ring
//! smoothing), the dihedral form of bending ([`bending_dihedral`]), the
//! bending's measure of a surface in either form, which a system may
//! publish for the tick's positions ([`bending_measure`]); and the in-plane
//! elasticity V_in gives a fixed mesh ([`vin_elasticity`], a measurement,
//! not a term).

pub mod builtin;

pub mod bending_dihedral;
pub mod bending_measure;
pub mod line_tension;
pub mod penalty;
pub mod vin_edge_samples;
pub mod vin_elasticity;

// The built-in terms: each one's file, then its entry in the list below,
// named as scenes write it. The list generates the scene's `EnergyTerm`
// enum and its dispatch (`builtin::builtin_terms`).
pub mod adhesion;
pub mod area;
pub mod bending;
pub mod local_tension;
pub mod self_avoidance;
pub mod springs;
pub mod tension;
pub mod vin;
pub mod volume;
pub mod wall;

builtin::builtin_terms! {
    /// Double-barrier edge potential V_in.
    #[serde(deserialize_with = "crate::util::validate::checked")]
    Vin(vin::VinParams),
    /// Helfrich bending.
    Bending(bending::BendingParams),
    /// Volume penalty.
    Volume(volume::VolumeParams),
    /// Area penalty.
    Area(area::AreaParams),
    /// Density-dependent local tension (needs `lipid_density: true`).
    LocalTension(local_tension::LocalTensionParams),
    /// Constant surface tension σA.
    Tension(tension::TensionParams),
    /// Springs from the control points.
    Springs(springs::SpringParams),
    /// Repulsion between non-neighbouring vertices closer than a range.
    SelfAvoidance(self_avoidance::SelfAvoidanceParams),
    /// A rigid wall (a plane, or a sphere or cylinder from inside) that
    /// repels the vertices within a short range.
    Wall(wall::WallParams),
    /// An adhesive substrate: −W per area of membrane within a short range.
    Adhesion(adhesion::AdhesionParams),
}
