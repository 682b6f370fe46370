//! Runs one [`ForceTerm`](crate::force::ForceTerm) of the simulation's
//! force set as a system, so each term is ordered and timed on its own.
//!
//! Stage: Forces. Reads: positions, lipid density, topology, face geometry,
//! the term's own components. Writes: the term's force accumulator and energy.

use crate::schedule::{Access, Data, System};
use crate::simulation::{SimError, SimState};

/// The system running force term `index`.
pub struct ForceTermSystem {
    /// Index of the term in the force set.
    pub index: usize,
    /// The term's name.
    pub name: String,
}

impl System for ForceTermSystem {
    fn name(&self) -> &str {
        &self.name
    }

    fn access(&self) -> Access {
        Access::new(
            &[
                Data::Positions,
                Data::LipidDensity,
                Data::Topology,
                Data::FaceGeometry,
                Data::ControlPoints,
            ],
            &[Data::ForceAccumulators],
        )
    }

    fn run(&mut self, state: &mut SimState) -> Result<(), SimError> {
        let s = state;
        s.forces.evaluate_term(
            self.index,
            &s.membrane.world,
            s.membrane.cached_topology(),
            &s.positions,
            &s.lipid,
            &mut s.evaluation,
        );
        Ok(())
    }
}
