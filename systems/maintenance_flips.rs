//! Delaunay edge flips as mesh maintenance in the fluid model
//! (`model: Fluid(flips: (...))`).
//!
//! Stage: Remesh, before the split/merge system. Reads: [`DensePositions`],
//! [`ValenceRange`], [`CheckInvariants`], [`Clock`]. Writes: the face and
//! edge entities of [`Membrane`] (flips through the mesh-edit layer; no
//! vertex moves or is added, so the dense slots and positions stay valid)
//! and [`MaintenanceFlipStats`].
//!
//! A fluid membrane flows in its plane: under an elongation or a shear the
//! triangles of a fixed connectivity stretch in one direction, every edge of
//! a region grows at once, and splits and merges, which fix one edge at a
//! time, cannot follow (measured: a 2562-vertex prolate vesicle deflated to
//! v = 0.9 left 53 abnormal edges and 647 failed split relaxations in 90
//! iterations). Every `every` iterations the system sweeps the edges once,
//! in slot order, and flips each edge that is not locally Delaunay (its two
//! opposite angles sum to more than π, i.e. its cotangent weight is
//! negative), unless a guard holds:
//! - **valence**: an end would fall to the scene's minimum or an opposite
//!   corner rise to its maximum, or the new edge exists already;
//! - **dihedral**: the two faces meet at more than `max_dihedral` degrees
//!   from flat, so the flip would move the surface (it changes the surface
//!   by the tetrahedron between the four corners, whose height is ∝ the
//!   dihedral angle);
//! - **fold**: before or after, two faces would meet at more than 90°.
//!
//! Control points need no guard: the fluid model's springs use the
//! Gaussian coupling, whose weights depend on the vertices' distances to
//! the point, not on the connectivity. Deterministic: the sweep order is
//! the edge slots', and there is no randomness.
//!
//! The Delaunay test of every edge runs first, in parallel on a large mesh
//! (a map: the same bits on any thread count), and the sweep then visits
//! only the edges it found and those whose quad a flip has since changed:
//! the same flips as testing every edge in the sweep (at 10 242 vertices
//! the serial sweep took 1.3 ms a tick, almost all of it the test).

use remembrane_core::engine::resources::{Res, ResMut};
use remembrane_core::engine::schedule::System;
use remembrane_core::engine::shared_resources::MaintenanceFlipStats;
use remembrane_core::engine::simulation::{CheckInvariants, Clock, DensePositions, SimError};
use remembrane_core::mesh::ValenceRange;
use remembrane_core::mesh::membrane::Membrane;
use remembrane_core::params::MaintenanceFlipParams;
use remembrane_core::remesh::flip::{Flip, dihedral, is_non_delaunay, keeps_surface_unfolded};

/// The maintenance-flip system.
pub struct MaintenanceFlips {
    params: MaintenanceFlipParams,
    /// By edge slot: whether the sweep must test the edge (not locally
    /// Delaunay at the sweep's start, or in a quad a flip changed).
    to_test: Vec<bool>,
}

impl MaintenanceFlips {
    /// Sweeps at `params`' interval with its dihedral guard.
    pub fn new(params: MaintenanceFlipParams) -> Self {
        Self {
            params,
            to_test: Vec::new(),
        }
    }
}

impl System for MaintenanceFlips {
    type Data<'a> = (
        (
            Res<'a, DensePositions>,
            Res<'a, ValenceRange>,
            Res<'a, Clock>,
            Res<'a, CheckInvariants>,
        ),
        (ResMut<'a, Membrane>, ResMut<'a, MaintenanceFlipStats>),
    );

    fn name(&self) -> &str {
        "maintenance_flips"
    }

    fn run(
        &mut self,
        ((positions, valence, clock, check), (mut membrane, mut stats)): Self::Data<'_>,
    ) -> Result<(), SimError> {
        if !clock.iteration.is_multiple_of(u64::from(self.params.every)) {
            return Ok(());
        }
        let positions = &positions.0;
        let max_dihedral = self.params.max_dihedral.to_radians();
        stats.sweeps += 1;
        {
            let t = membrane.cached_topology();
            remembrane_core::util::parallel::fill_vec(&mut self.to_test, t.edges.len(), |e| {
                Flip::of(t, e as u32).is_some_and(|flip| is_non_delaunay(&flip, positions))
            });
        }
        let mut edge = 0;
        while edge < membrane.cached_topology().edges.len() {
            let t = membrane.cached_topology();
            let slot = edge as u32;
            edge += 1;
            if !self.to_test.get(slot as usize).copied().unwrap_or(true) {
                continue;
            }
            let Some(flip) = Flip::of(t, slot) else {
                continue;
            };
            if !is_non_delaunay(&flip, positions) {
                continue;
            }
            stats.non_delaunay += 1;
            let degree = |v: u32| t.valence(v as usize) as u32;
            if degree(flip.a) <= valence.min
                || degree(flip.b) <= valence.min
                || degree(flip.c) >= valence.max
                || degree(flip.d) >= valence.max
                || t.edge_between(flip.c, flip.d).is_some()
            {
                stats.kept_valence += 1;
                continue;
            }
            if dihedral(&flip, positions) > max_dihedral {
                stats.kept_dihedral += 1;
                continue;
            }
            if !keeps_surface_unfolded(&flip, positions) {
                stats.kept_fold += 1;
                continue;
            }
            let edit = flip.edit(t);
            if membrane.apply_patch(&edit, *valence).is_err() {
                stats.kept_fold += 1;
                continue;
            }
            stats.flipped += 1;
            // The new edge and the quad's four sides have new opposite
            // corners: test them when the sweep reaches them.
            let t = membrane.cached_topology();
            let (a, b, c, d) = (flip.a, flip.b, flip.c, flip.d);
            for (u, v) in [(c, d), (a, c), (c, b), (b, d), (d, a)] {
                if let Some(e) = t.edge_between(u, v)
                    && let Some(x) = self.to_test.get_mut(e as usize)
                {
                    *x = true;
                }
            }
            if check.0 {
                let t = membrane.cached_topology();
                if let Err(e) =
                    remembrane_core::mesh::check_mesh(positions, &t.faces, Some(*valence))
                {
                    return Err(SimError::Output(format!(
                        "mesh invariant broken after a maintenance flip at iteration {}: {e}",
                        clock.iteration + 1
                    )));
                }
            }
        }
        Ok(())
    }
}
