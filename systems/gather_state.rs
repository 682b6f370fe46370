//! Refreshes the topology cache and gathers the dense state mirror.
//!
//! Stage: Gather (first). Reads: the world (positions, lipid density, mesh
//! entities), [`CheckInvariants`]. Writes: the topology cache in
//! [`Membrane`] (rebuilt only when the structure epoch changed) and whether
//! its incremental updates are checked this tick
//! ([`Membrane::set_check_updates`]), [`DensePositions`], [`DenseLipid`].

use remembrane_core::engine::resources::Res;
use remembrane_core::engine::resources::ResMut;
use remembrane_core::engine::schedule::System;
use remembrane_core::engine::simulation::{CheckInvariants, DenseLipid, DensePositions, SimError};
use remembrane_core::mesh::membrane::Membrane;

/// The gather system.
pub struct GatherState;

impl System for GatherState {
    type Data<'a> = (
        ResMut<'a, Membrane>,
        ResMut<'a, DensePositions>,
        ResMut<'a, DenseLipid>,
        Res<'a, CheckInvariants>,
    );

    fn name(&self) -> &str {
        "gather_state"
    }

    fn run(
        &mut self,
        (mut membrane, mut positions, mut lipid, check): Self::Data<'_>,
    ) -> Result<(), SimError> {
        membrane.set_check_updates(check.0);
        membrane.topology()?;
        membrane.gather_positions(&mut positions.0);
        membrane.gather_lipid(&mut lipid.0);
        Ok(())
    }
}
