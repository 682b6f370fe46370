//! Relaxes the protein species' fields at the shape the minimiser reached:
//! with `dynamics: (method: Minimise(...))` the fields join the degrees of
//! freedom. Each tick first minimises the grand potential over the fields
//! at the current shape ([`remembrane_core::species::relax`]) with every
//! conserved count held, then the forces are evaluated and the shape steps
//! at fixed amounts (the species force term). At a fixed point both the
//! shape force and the fields' residual vanish: the joint minimum. (Relaxed
//! after the step instead, the fields lag the constraint projection and the
//! minimiser measured on the 642-vertex red blood cell with one species
//! stalls at a residual of 1.8e-2 Ē/l̄ with a creeping energy.)
//!
//! Stage: Gather, after `species_gather` and `face_geometry`. Reads:
//! [`DensePositions`], [`FaceGeometry`],
//! the topology (in [`Membrane`]), [`SpeciesModel`], [`Clock`]. Writes:
//! the [`SpeciesAmounts`], the surface's measure ([`MeasuredSurface`],
//! which the species term and the bending then reuse at the same positions)
//! and the relaxation's last evaluation ([`Evaluated`], which the species
//! term reuses for the same amounts) in
//! [`TermInputs`], the world's
//! `ProteinAmount` components (in [`Membrane`]), [`SpeciesStatus`]. The
//! conserved counts are rescaled to their initial values after each
//! relaxation, so round-off does not accumulate over iterations.

use remembrane_core::energy::bending_measure::{MeasuredSurface, Surface, VertexTerms};
use remembrane_core::engine::force::FaceGeometry;
use remembrane_core::engine::resources::{Res, ResMut};
use remembrane_core::engine::schedule::System;
use remembrane_core::engine::simulation::{Clock, DensePositions, SimError};
use remembrane_core::engine::term_inputs::TermInputs;
use remembrane_core::mesh::geometry::{Corners, face_geometry};
use remembrane_core::mesh::membrane::Membrane;
use remembrane_core::species::free_energy::Evaluated;
use remembrane_core::species::model::{SpeciesModel, SpeciesStatus};
use remembrane_core::species::params::Reservoir;
use remembrane_core::species::relax::{copy_into, relax_amounts_measured};
use remembrane_core::species::state::{SpeciesAmounts, write_amounts};

/// Its name in the schedule.
pub const SPECIES_RELAXATION: &str = "species_relaxation";

/// The relaxation system of the species.
#[derive(Default)]
pub struct SpeciesRelaxation {
    geometry: Vec<Corners>,
    boundary: Vec<bool>,
    /// The surface's measure at this tick (published in the term inputs
    /// after the relaxation, swapped with the last one published).
    measured: VertexTerms,
    /// The relaxation's last evaluation at this tick (published likewise).
    evaluated: Evaluated,
}

impl System for SpeciesRelaxation {
    type Data<'a> = (
        Res<'a, DensePositions>,
        Res<'a, FaceGeometry>,
        Res<'a, SpeciesModel>,
        Res<'a, Clock>,
        ResMut<'a, Membrane>,
        ResMut<'a, TermInputs>,
        ResMut<'a, SpeciesStatus>,
    );

    fn name(&self) -> &str {
        SPECIES_RELAXATION
    }

    fn run(
        &mut self,
        (positions, shared, model, clock, mut membrane, mut inputs, mut status): Self::Data<'_>,
    ) -> Result<(), SimError> {
        let Some(dense) = inputs.get_mut::<SpeciesAmounts>() else {
            return Ok(());
        };
        let positions = &positions.0;
        let topology = membrane.cached_topology();
        let epoch = topology.epoch;
        // The tick's face geometry where the force pass has measured it
        // (the species term asks for it), else measured here.
        let geometry = if shared.0.len() == topology.faces.len() {
            &shared.0
        } else {
            face_geometry(positions, &topology.faces, &mut self.geometry);
            &self.geometry
        };
        let shape = Surface::new(positions, topology, geometry, &mut self.boundary);
        let set = &model.set;
        self.measured.measure(shape, model.base.discretisation);
        let relaxed = relax_amounts_measured(
            shape,
            &self.measured,
            model.base,
            set,
            &mut dense.0,
            model.relax,
            Some(&mut self.evaluated),
        )
        .map_err(|source| SimError::Species {
            iteration: clock.iteration + 1,
            source,
        })?;
        for (k, s) in set.species.iter().enumerate() {
            if s.reservoir == Reservoir::Conserved {
                let target = status.initial_counts[k];
                let count: f64 = dense.0[k].iter().sum();
                if count > 0.0 {
                    dense.0[k].iter_mut().for_each(|x| *x *= target / count);
                }
            }
            write_amounts(&mut membrane, k, &dense.0[k]);
        }
        status.counts = dense.counts();
        status.chemical_potentials = relaxed.chemical_potentials;
        status.relaxations += 1;
        status.newton_steps += relaxed.iterations as u64;
        status.repaired_vertices += relaxed.repaired as u64;
        status.residual = relaxed.residual;
        // The measure, for the species term at the same positions.
        MeasuredSurface::publish(&mut inputs, &mut self.measured, positions, epoch);
        // The last evaluation, of the amounts as written (the conserved
        // counts' rescaling included), for the term at the same amounts.
        let dense = inputs.get::<SpeciesAmounts>().expect("read above");
        copy_into(&mut self.evaluated.amounts, &dense.0);
        match inputs.get_mut::<Evaluated>() {
            Some(e) => std::mem::swap(e, &mut self.evaluated),
            None => inputs.insert(std::mem::take(&mut self.evaluated)),
        }
        Ok(())
    }
}
