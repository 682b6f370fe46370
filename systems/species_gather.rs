//! Gathers the protein species' amounts into their dense mirror and, in
//! the fluid model's dynamics, where the vertices start the tick.
//!
//! Stage: Gather, after `gather_state`. Reads: the world's
//! `ProteinAmount` components and the topology cache (in [`Membrane`]),
//! [`SpeciesModel`] (how many species), [`DensePositions`]. Writes: the
//! [`SpeciesAmounts`] in [`TermInputs`], which the species force term
//! reads, the counts in [`SpeciesStatus`], and [`SlideAnchors`] where it exists (the positions from which
//! `species_remap` measures the step's slides).

use remembrane_core::engine::resources::{Res, ResMut};
use remembrane_core::engine::schedule::System;
use remembrane_core::engine::simulation::{DensePositions, SimError};
use remembrane_core::engine::term_inputs::TermInputs;
use remembrane_core::mesh::membrane::Membrane;
use remembrane_core::species::model::{SpeciesModel, SpeciesStatus};
use remembrane_core::species::remap::SlideAnchors;
use remembrane_core::species::state::SpeciesAmounts;

/// Its name in the schedule.
pub const SPECIES_GATHER: &str = "species_gather";

/// The gather system of the species.
pub struct SpeciesGather;

impl System for SpeciesGather {
    type Data<'a> = (
        Res<'a, Membrane>,
        Res<'a, SpeciesModel>,
        Res<'a, DensePositions>,
        ResMut<'a, TermInputs>,
        ResMut<'a, SpeciesStatus>,
        Option<ResMut<'a, SlideAnchors>>,
    );

    fn name(&self) -> &str {
        SPECIES_GATHER
    }

    fn run(
        &mut self,
        (membrane, model, positions, mut inputs, mut status, anchors): Self::Data<'_>,
    ) -> Result<(), SimError> {
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
        if let Some(amounts) = inputs.get::<SpeciesAmounts>() {
            status.counts = amounts.counts();
        }
        if let Some(mut anchors) = anchors {
            anchors.epoch = topology.epoch;
            anchors.positions.clone_from(&positions.0);
        }
        Ok(())
    }
}
