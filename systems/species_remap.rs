//! Keeps the protein species where they are on the surface while the fluid
//! model's step slides the mesh under them (an ALE remap,
//! [`remembrane_core::species::remap`]), in overdamped dynamics.
//!
//! Stage: BarrierCheck (after every Integrate system, the step and the
//! pins, and before any remesh edit, so the slots are the tick's). Reads:
//! [`SlideAnchors`] (the positions at the tick's start), [`DensePositions`]
//! (after the step), [`SpeciesModel`], the topology in [`Membrane`].
//! Writes: the world's `ProteinAmount` components (in [`Membrane`]).

use remembrane_core::energy::bending_measure::Surface;
use remembrane_core::engine::resources::{Res, ResMut};
use remembrane_core::engine::schedule::System;
use remembrane_core::engine::simulation::{DensePositions, SimError};
use remembrane_core::mesh::geometry::{Corners, face_geometry};
use remembrane_core::mesh::membrane::Membrane;
use remembrane_core::species::model::SpeciesModel;
use remembrane_core::species::remap::{SlideAnchors, remap_slides};
use remembrane_core::species::state::{SpeciesAmounts, write_amounts};

/// Its name in the schedule.
pub const SPECIES_REMAP: &str = "species_remap";

/// The remap system of the species.
#[derive(Default)]
pub struct SpeciesRemap {
    amounts: SpeciesAmounts,
    geometry: Vec<Corners>,
    boundary: Vec<bool>,
    displacement: Vec<glam::DVec3>,
}

impl System for SpeciesRemap {
    type Data<'a> = (
        Res<'a, SlideAnchors>,
        Res<'a, DensePositions>,
        Res<'a, SpeciesModel>,
        ResMut<'a, Membrane>,
    );

    fn name(&self) -> &str {
        SPECIES_REMAP
    }

    fn run(
        &mut self,
        (anchors, positions, model, mut membrane): Self::Data<'_>,
    ) -> Result<(), SimError> {
        let topology = membrane.cached_topology();
        let positions = &positions.0;
        if anchors.epoch != topology.epoch || anchors.positions.len() != positions.len() {
            return Ok(());
        }
        self.displacement.clear();
        self.displacement.extend(
            positions
                .iter()
                .zip(&anchors.positions)
                .map(|(p, a)| *p - *a),
        );
        face_geometry(positions, &topology.faces, &mut self.geometry);
        let shape = Surface::new(positions, topology, &self.geometry, &mut self.boundary);
        let species = model.set.species.len();
        self.amounts.gather(&membrane.world, topology, species);
        remap_slides(
            shape,
            model.base.discretisation,
            &mut self.amounts.0,
            &self.displacement,
        );
        for (k, values) in self.amounts.0.iter().enumerate() {
            write_amounts(&mut membrane, k, values);
        }
        Ok(())
    }
}
