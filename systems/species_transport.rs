//! Moves the protein species' fields in overdamped dynamics: transport
//! along the membrane and binding from a bulk over the tick's Δt, on the
//! tick's final mesh, with the thermal noise where the dynamics has a
//! temperature ([`remembrane_core::species::transport`]).
//!
//! Stage: Diffuse (after the remeshing). Reads: [`TimeStepChoice`] (Δt),
//! [`DynamicsParams`] (k_BT: noise or not), [`Seed`], [`SpeciesModel`], the
//! positions and topology in [`Membrane`]. Writes: the world's
//! `ProteinAmount` components (in [`Membrane`]), [`SpeciesStatus`] (the
//! counts, the chemical potentials, the steps taken, which also count the
//! noise's draws, so a resumed checkpoint continues them), and the
//! measure of the tick's final mesh in [`TermInputs`] ([`MeasuredSurface`]:
//! the next tick's forces are evaluated at the same positions, where the
//! species term and the bending read it instead of measuring again).

use remembrane_core::energy::bending_measure::{MeasuredSurface, Surface};
use remembrane_core::engine::resources::{Res, ResMut};
use remembrane_core::engine::schedule::System;
use remembrane_core::engine::simulation::{Clock, Seed, SimError};
use remembrane_core::engine::term_inputs::TermInputs;
use remembrane_core::mesh::geometry::{Corners, face_geometry};
use remembrane_core::mesh::membrane::Membrane;
use remembrane_core::params::DynamicsParams;
use remembrane_core::species::model::{SpeciesModel, SpeciesStatus};
use remembrane_core::species::state::{SpeciesAmounts, write_amounts};
use remembrane_core::species::transport::{Noise, Transport};
use remembrane_core::timestep::TimeStepChoice;

/// Its name in the schedule.
pub const SPECIES_TRANSPORT: &str = "species_transport";

/// The transport system of the species.
#[derive(Default)]
pub struct SpeciesTransport {
    transport: Transport,
    amounts: SpeciesAmounts,
    positions: Vec<glam::DVec3>,
    geometry: Vec<Corners>,
    boundary: Vec<bool>,
}

impl System for SpeciesTransport {
    type Data<'a> = (
        Res<'a, TimeStepChoice>,
        Res<'a, DynamicsParams>,
        Res<'a, Seed>,
        Res<'a, SpeciesModel>,
        Res<'a, Clock>,
        ResMut<'a, Membrane>,
        ResMut<'a, SpeciesStatus>,
        ResMut<'a, TermInputs>,
    );

    fn name(&self) -> &str {
        SPECIES_TRANSPORT
    }

    fn run(
        &mut self,
        (time_step, dynamics, seed, model, clock, mut membrane, mut status, mut inputs): Self::Data<
            '_,
        >,
    ) -> Result<(), SimError> {
        let set = &model.set;
        let topology = membrane.cached_topology();
        membrane.gather_positions(&mut self.positions);
        face_geometry(&self.positions, &topology.faces, &mut self.geometry);
        self.amounts
            .gather(&membrane.world, topology, set.species.len());
        let shape = Surface::new(
            &self.positions,
            topology,
            &self.geometry,
            &mut self.boundary,
        );
        let noise = (dynamics.temperature > 0.0).then_some(Noise {
            seed: seed.0,
            steps: status.transport_steps,
        });
        let done = self
            .transport
            .advance(
                shape,
                model.base,
                set,
                &mut self.amounts.0,
                time_step.dt,
                noise,
            )
            .map_err(|source| SimError::SpeciesTransport {
                iteration: clock.iteration,
                source,
            })?;
        for (k, values) in self.amounts.0.iter().enumerate() {
            write_amounts(&mut membrane, k, values);
        }
        status.counts = self.amounts.counts();
        status.chemical_potentials = done.chemical_potentials;
        status.transport_steps += done.steps;
        let epoch = membrane.cached_topology().epoch;
        MeasuredSurface::publish(
            &mut inputs,
            self.transport.measure_mut(),
            &self.positions,
            epoch,
        );
        Ok(())
    }
}
