//! Gathers the protein species' amounts into their dense mirror.
//!
//! Stage: Gather, after `gather_state`. Reads: the world's
//! `ProteinAmount` components and the topology cache (in [`Membrane`]),
//! [`SpeciesModel`] (how many species). Writes: the [`SpeciesAmounts`] in
//! [`TermInputs`], which the species force term reads.

use remembrane_core::engine::resources::{Res, ResMut};
use remembrane_core::engine::schedule::System;
use remembrane_core::engine::simulation::SimError;
use remembrane_core::engine::term_inputs::TermInputs;
use remembrane_core::mesh::membrane::Membrane;
use remembrane_core::species::model::SpeciesModel;
use remembrane_core::species::state::SpeciesAmounts;

/// Its name in the schedule.
pub const SPECIES_GATHER: &str = "species_gather";

/// The gather system of the species.
pub struct SpeciesGather;

impl System for SpeciesGather {
    type Data<'a> = (
        Res<'a, Membrane>,
        Res<'a, SpeciesModel>,
        ResMut<'a, TermInputs>,
    );

    fn name(&self) -> &str {
        SPECIES_GATHER
    }

    fn run(&mut self, (membrane, model, mut inputs): Self::Data<'_>) -> Result<(), SimError> {
        let species = model.set.species.len();
        let (world, topology) = (&membrane.world, membrane.cached_topology());
        match inputs.get_mut::<SpeciesAmounts>() {
            Some(amounts) => amounts.gather(world, topology, species),
            None => {
                let mut amounts = SpeciesAmounts::default();
                amounts.gather(world, topology, species);
                inputs.insert(amounts);
            }
        }
        Ok(())
    }
}
