//! Edge flips as Metropolis moves ([`remembrane_core::remesh::flip`]).
//!
//! Stage: Remesh (after split/merge, if the scene remeshes). Reads:
//! [`DensePositions`], [`DenseLipid`], [`DynamicsParams`] (k_BT),
//! [`ValenceRange`], [`Seed`], [`Clock`], [`CheckInvariants`], and
//! [`SpringCoupling`] when springs act. Writes: the face and edge entities
//! of [`Membrane`] (flips through the mesh-edit layer; no vertex moves or
//! is added, so the dense vertex slots and positions stay valid),
//! [`FlipStats`], and the force terms in [`ForceBuffers`] (each prices the
//! flips, [`remembrane_core::engine::force::ForceTerm::flip_energy_change`]).
//!
//! Each tick proposes ⌊r·E⌋ flips (plus one with probability of the
//! fraction) for r proposals per edge and E edges, each on an edge drawn
//! uniformly. A proposal is rejected without drawing if the flip would
//! leave the valence range, duplicate an edge, touch a control point's
//! nearest vertex, remove or create an edge outside `edge_range`, or fold
//! the surface (each rule holds both ways, so the reverse flip is allowed
//! exactly when this one is); otherwise it is accepted with probability
//! min(1, exp(−ΔE/k_BT)), ΔE summed over every registered term.

use rand::{RngExt, SeedableRng};
use remembrane_core::engine::force::{FlipProposal, ForceBuffers};
use remembrane_core::engine::resources::{Res, ResMut};
use remembrane_core::engine::schedule::System;
use remembrane_core::engine::shared_resources::FlipStats;
use remembrane_core::engine::simulation::{
    CheckInvariants, Clock, DenseLipid, DensePositions, Seed, SimError,
};
use remembrane_core::mesh::ValenceRange;
use remembrane_core::mesh::membrane::Membrane;
use remembrane_core::params::{DynamicsParams, EdgeFlipParams, SpringCoupling};
use remembrane_core::remesh::flip::{Flip, FlipPricer, FlipTotals, keeps_surface_unfolded};
use remembrane_core::util::rng::stream_seed;

/// Stream id of the flips' randomness (edges drawn, acceptance).
const FLIP_STREAM: u64 = 0x666c_6970_0000_0001;

/// The edge-flip system.
pub struct EdgeFlips {
    params: EdgeFlipParams,
    pricer: FlipPricer,
}

impl EdgeFlips {
    /// Flips at `params`' rate under the registered force terms.
    pub fn new(params: EdgeFlipParams) -> Self {
        Self {
            params,
            pricer: FlipPricer::default(),
        }
    }
}

/// Why a proposal was turned down before its energy was priced.
enum Screened {
    /// No flip, a pinned vertex, a valence out of range or c–d already an edge.
    Topology,
    /// An edge outside `edge_range`, or a fold.
    Geometry,
}

impl EdgeFlips {
    /// The flip of `edge` if it passes the rules that need no energy (each
    /// holds both ways, so the reverse flip passes exactly when this one
    /// does).
    fn screen(
        &self,
        t: &remembrane_core::mesh::topology::Topology,
        edge: u32,
        positions: &[glam::DVec3],
        pinned: &[u32],
        valence: ValenceRange,
    ) -> Result<Flip, Screened> {
        let flip = Flip::of(t, edge).ok_or(Screened::Topology)?;
        let degree = |v: u32| t.valence(v as usize) as u32;
        if [flip.a, flip.b, flip.c, flip.d]
            .iter()
            .any(|v| pinned.contains(v))
            || degree(flip.a) <= valence.min
            || degree(flip.b) <= valence.min
            || degree(flip.c) >= valence.max
            || degree(flip.d) >= valence.max
            || t.edge_between(flip.c, flip.d).is_some()
        {
            return Err(Screened::Topology);
        }
        let (lo, hi) = self.params.edge_range;
        let in_range = |u: u32, v: u32| {
            let l = positions[u as usize].distance(positions[v as usize]);
            l >= lo && l <= hi
        };
        if !in_range(flip.a, flip.b)
            || !in_range(flip.c, flip.d)
            || !keeps_surface_unfolded(&flip, positions)
        {
            return Err(Screened::Geometry);
        }
        Ok(flip)
    }
}

impl System for EdgeFlips {
    type Data<'a> = (
        (
            Res<'a, DensePositions>,
            Res<'a, DenseLipid>,
            Res<'a, DynamicsParams>,
            Res<'a, ValenceRange>,
            Res<'a, Seed>,
            Res<'a, Clock>,
            Res<'a, CheckInvariants>,
            Option<Res<'a, SpringCoupling>>,
        ),
        (
            ResMut<'a, Membrane>,
            ResMut<'a, FlipStats>,
            ResMut<'a, ForceBuffers>,
        ),
    );

    fn name(&self) -> &str {
        "edge_flips"
    }

    fn run(
        &mut self,
        (
            (positions, lipid, dynamics, valence, seed, clock, check, springs),
            (mut membrane, mut stats, mut buffers),
        ): Self::Data<'_>,
    ) -> Result<(), SimError> {
        let positions = &positions.0;
        let terms = buffers.term_objects_mut();
        self.pricer.invalidate();
        let kbt = dynamics.temperature;
        let mut rng = rand::rngs::Xoshiro256PlusPlus::seed_from_u64(stream_seed(
            seed.0,
            FLIP_STREAM,
            clock.iteration,
        ));
        let t = membrane.cached_topology();
        let expected = self.params.attempts_per_edge * t.edges.len() as f64;
        let proposals = expected.floor() as u64 + u64::from(rng.random::<f64>() < expected.fract());
        let mut totals = FlipTotals::of(positions, &t.faces);
        // Each control point's nearest vertex (first on ties, like the
        // springs' full scan): flips never touch one.
        let pinned: Vec<u32> = if springs.is_some() {
            membrane
                .control_points()
                .iter()
                .map(|c| {
                    remembrane_core::mesh::cell_list::nearest_by_scan(positions, c.position) as u32
                })
                .collect()
        } else {
            Vec::new()
        };
        for _ in 0..proposals {
            let t = membrane.cached_topology();
            stats.proposed += 1;
            let edge = rng.random_range(0..t.edges.len()) as u32;
            let flip = match self.screen(t, edge, positions, &pinned, *valence) {
                Ok(flip) => flip,
                Err(Screened::Topology) => {
                    stats.rejected_topology += 1;
                    continue;
                }
                Err(Screened::Geometry) => {
                    stats.rejected_geometry += 1;
                    continue;
                }
            };
            let proposal = FlipProposal::new(flip, &membrane.world, t, positions, &lipid.0, totals);
            let energy = self.pricer.change(terms, &proposal);
            let change = proposal.change;
            let accept =
                energy <= 0.0 || (kbt > 0.0 && rng.random::<f64>() < (-energy / kbt).exp());
            if !accept {
                stats.rejected_energy += 1;
                continue;
            }
            let edit = flip.edit(t);
            if membrane.apply_patch(&edit, *valence).is_err() {
                stats.rejected_geometry += 1;
                continue;
            }
            stats.accepted += 1;
            self.pricer.invalidate();
            totals.volume += change.volume;
            totals.area += change.area;
            if check.0 {
                let t = membrane.cached_topology();
                if let Err(e) =
                    remembrane_core::mesh::check_mesh(positions, &t.faces, Some(*valence))
                {
                    return Err(SimError::Output(format!(
                        "mesh invariant broken after an edge flip at iteration {}: {e}",
                        clock.iteration + 1
                    )));
                }
            }
        }
        Ok(())
    }
}
