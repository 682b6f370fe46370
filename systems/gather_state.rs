//! Refreshes the topology cache and gathers the dense state mirror.
//!
//! Stage: Prepare (first). Reads: the world (positions, lipid density,
//! mesh entities). Writes: topology cache (rebuilt only when the structure
//! epoch changed), dense positions and lipid density.

use crate::schedule::{Access, Data, System};
use crate::simulation::{SimError, SimState};

/// The gather system.
pub struct GatherState;

impl System for GatherState {
    fn name(&self) -> &str {
        "gather_state"
    }

    fn access(&self) -> Access {
        Access::new(
            &[Data::Topology, Data::Positions, Data::LipidDensity],
            &[Data::Topology, Data::Positions],
        )
    }

    fn run(&mut self, state: &mut SimState) -> Result<(), SimError> {
        state.membrane.topology()?;
        state.membrane.gather_positions(&mut state.positions);
        state.membrane.gather_lipid(&mut state.lipid);
        Ok(())
    }
}
