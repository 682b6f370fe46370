//! The built-in systems, one per file. Each file's header states its stage,
//! what it reads and what it writes.
//!
//! These files are compiled into the library (mounted with `#[path]`), but
//! use only its public API: a user's system is written the same way.

pub mod adaptive_time_step;
pub mod area_forces;
pub mod barrier_check;
pub mod bending_forces;
pub mod control_point_schedule;
pub mod face_geometry;
pub mod force_term;
pub mod force_total;
pub mod gather_state;
pub mod langevin_integration;
pub mod lipid_diffusion;
pub mod local_tension_forces;
pub mod remesh;
pub mod spring_forces;
pub mod vin_forces;
pub mod volume_forces;

pub use area_forces::AreaForces;
pub use bending_forces::BendingForces;
pub use local_tension_forces::LocalTensionForces;
pub use spring_forces::SpringForces;
pub use vin_forces::VinForces;
pub use volume_forces::VolumeForces;

use crate::schedule::{ScheduleBuilder, Stage};

/// Registers the built-in systems of a tick, with one force system per
/// force term (`terms`, in force-set order):
/// Prepare: `gather_state`, `face_geometry`; Forces: the terms, then
/// `force_total`; TimeStep: `adaptive_time_step`; Integrate:
/// `langevin_integration`; BarrierCheck: `barrier_check`.
pub fn register_builtin(builder: &mut ScheduleBuilder, terms: &[String]) {
    builder.add(Stage::Prepare, Box::new(gather_state::GatherState));
    builder
        .add(Stage::Prepare, Box::new(face_geometry::FaceGeometry))
        .after("gather_state");
    for (index, name) in terms.iter().enumerate() {
        builder.add(
            Stage::Forces,
            Box::new(force_term::ForceTermSystem {
                index,
                name: name.clone(),
            }),
        );
    }
    let mut total = builder.add(Stage::Forces, Box::new(force_total::ForceTotal));
    for name in terms {
        total = total.after(name);
    }
    builder.add(
        Stage::TimeStep,
        Box::new(adaptive_time_step::AdaptiveTimeStep),
    );
    builder.add(
        Stage::Integrate,
        Box::new(langevin_integration::LangevinIntegration::default()),
    );
    builder.add(Stage::BarrierCheck, Box::new(barrier_check::BarrierCheck));
}
