//! The system that runs one registered force term (see
//! [`crate::simulation::SimBuilder::add_force_term`]).

use crate::core_resources::{DenseLipid, DensePositions};
use crate::error::SimError;
use crate::force::{FaceGeometry, ForceBuffers, ForceContext, ForceTerm};
use crate::membrane::Membrane;
use crate::resources::{Res, ResMut};
use crate::schedule::System;

/// The system running one force term into its own buffer, so each term is
/// ordered and timed on its own.
///
/// Stage: Forces (before `force_total`). Reads: the membrane (topology, the
/// term's own components), dense positions and lipid density, face
/// geometry. Writes: the term's buffer and energy in [`ForceBuffers`].
pub struct ForceTermSystem<T> {
    index: usize,
    name: String,
    term: T,
}

impl<T: ForceTerm> ForceTermSystem<T> {
    /// The system of `term`, whose buffer is `index` in [`ForceBuffers`].
    pub fn new(index: usize, term: T) -> Self {
        Self {
            index,
            name: term.name().to_string(),
            term,
        }
    }
}

impl<T: ForceTerm + 'static> System for ForceTermSystem<T> {
    type Data<'a> = (
        Res<'a, Membrane>,
        Res<'a, DensePositions>,
        Res<'a, DenseLipid>,
        Res<'a, FaceGeometry>,
        ResMut<'a, ForceBuffers>,
    );

    fn name(&self) -> &str {
        &self.name
    }

    fn run(
        &mut self,
        (membrane, positions, lipid, geometry, mut buffers): Self::Data<'_>,
    ) -> Result<(), SimError> {
        let ctx = ForceContext {
            world: &membrane.world,
            topology: membrane.cached_topology(),
            positions: &positions.0,
            lipid: &lipid.0,
            face_geometry: &geometry.0,
        };
        let ev = &mut buffers.evaluation;
        ev.energies[self.index] = self.term.accumulate(&ctx, &mut ev.term_forces[self.index]);
        Ok(())
    }
}
