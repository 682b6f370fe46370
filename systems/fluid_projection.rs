//! The fluid model's force stage ([`remembrane_core::fluid`]): mesh maintenance acts
//! only in the tangent planes, external loads only along the normals.
//!
//! Stage: Forces (after `force_terms`, before `force_total`). Reads:
//! [`DensePositions`], [`VertexNormals`], [`Membrane`] (its boundary
//! loops), [`PinnedVertices`] (if any). Writes: in [`ForceBuffers`], the
//! buffers of the [`ForceKind::Maintenance`] terms (V_in), which lose their
//! component along the area-weighted vertex normal and then their net force
//! and torque (rigid motions, so that a free vesicle neither drifts nor
//! spins), and of the
//! [`ForceKind::External`] terms (control-point springs), which keep only
//! that component, and with [`PhysicalForces::Normal`] the physical terms,
//! which keep only that component and lose their net force and torque too (measured
//! on the stomatocyte: 0.54 Ē/l̄ left, a drift that kept the minimiser from
//! converging). The per-term forces reported are then the ones that act.
//!
//! On an open membrane a boundary vertex keeps its shape under slides
//! along its boundary line only ([`boundary_tangents`]): there the
//! maintenance forces keep only their component along the boundary, and
//! the external and (with `Normal`) physical forces lose only that
//! component, so a free rim still moves across the surface under a line
//! tension or the membrane's tension. When the membrane has held vertices
//! (a pinned or roller loop), the net force and torque are not removed:
//! the held rim takes them, as a clamped membrane's frame does, and a
//! uniform force taken from every vertex would be a load of its own.

use glam::DVec3;
use remembrane_core::engine::force::{FORCE_TERMS, FORCE_TOTAL, ForceBuffers, ForceKind};
use remembrane_core::engine::resources::{Res, ResMut};
use remembrane_core::engine::schedule::System;
use remembrane_core::engine::shared_resources::PinnedVertices;
use remembrane_core::engine::shared_resources::VertexNormals;
use remembrane_core::engine::simulation::DensePositions;
use remembrane_core::engine::simulation::SimError;
use remembrane_core::fluid::{
    across_boundary, along_boundary, boundary_tangents, keep_normal, keep_tangential,
    remove_net_force_and_torque,
};
use remembrane_core::mesh::membrane::Membrane;
use remembrane_core::params::PhysicalForces;

/// Its name in the schedule.
pub const FLUID_PROJECTION: &str = "fluid_projection";

/// The fluid-projection system.
pub struct FluidProjection {
    /// Which components of the physical terms' forces act.
    pub physical: PhysicalForces,
}

impl FluidProjection {
    /// Runs after every term and before their sum.
    pub const AFTER: &'static str = FORCE_TERMS;
    /// See [`Self::AFTER`].
    pub const BEFORE: &'static str = FORCE_TOTAL;
}

impl System for FluidProjection {
    type Data<'a> = (
        Res<'a, DensePositions>,
        Res<'a, VertexNormals>,
        Res<'a, Membrane>,
        Option<Res<'a, PinnedVertices>>,
        ResMut<'a, ForceBuffers>,
    );

    fn name(&self) -> &str {
        FLUID_PROJECTION
    }

    fn run(
        &mut self,
        (positions, normals, membrane, pinned, mut buffers): Self::Data<'_>,
    ) -> Result<(), SimError> {
        let boundary = boundary_tangents(&positions.0, membrane.cached_topology());
        let free = pinned.is_none_or(|p| p.vertices.is_empty());
        let mut rim: Vec<DVec3> = Vec::with_capacity(boundary.len());
        let kinds: Vec<ForceKind> = buffers.terms().iter().map(|t| t.kind).collect();
        for (kind, buf) in kinds.iter().zip(&mut buffers.evaluation.term_forces) {
            rim.clear();
            rim.extend(boundary.iter().map(|&(v, _)| buf[v as usize]));
            let on_rim = |buf: &mut [DVec3], part: fn(DVec3, DVec3) -> DVec3| {
                for (&(v, t), &f) in boundary.iter().zip(&rim) {
                    buf[v as usize] = part(f, t);
                }
            };
            match kind {
                ForceKind::Maintenance => {
                    keep_tangential(buf, &normals.0);
                    on_rim(buf, along_boundary);
                    if free {
                        remove_net_force_and_torque(buf, &positions.0);
                    }
                }
                ForceKind::External => {
                    keep_normal(buf, &normals.0);
                    on_rim(buf, across_boundary);
                }
                ForceKind::Conservative | ForceKind::Penalty => match self.physical {
                    PhysicalForces::Full => {}
                    PhysicalForces::Normal => {
                        keep_normal(buf, &normals.0);
                        on_rim(buf, across_boundary);
                        if free {
                            remove_net_force_and_torque(buf, &positions.0);
                        }
                    }
                },
            }
        }
        Ok(())
    }
}
