//! Prepares the force accumulators and the shared per-face geometry.
//!
//! Stage: Prepare (after `gather_state`). Reads: positions, topology.
//! Writes: face geometry (edges, unit normals, areas, cotangents; computed
//! only if a force term uses it), zeroed force accumulators.

use crate::schedule::{Access, Data, System};
use crate::simulation::{SimError, SimState};

/// The face-geometry system.
pub struct FaceGeometry;

impl System for FaceGeometry {
    fn name(&self) -> &str {
        "face_geometry"
    }

    fn access(&self) -> Access {
        Access::new(
            &[Data::Positions, Data::Topology],
            &[Data::FaceGeometry, Data::ForceAccumulators],
        )
    }

    fn run(&mut self, state: &mut SimState) -> Result<(), SimError> {
        let s = state;
        s.forces.begin(
            s.membrane.cached_topology(),
            &s.positions,
            &mut s.evaluation,
        );
        Ok(())
    }
}
