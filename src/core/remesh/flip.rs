//! Edge flips as Metropolis moves: pricing a flip under the scene's force
//! terms.
//!
//! A flip ([`Flip`]) replaces the edge a–b, shared by faces (a, b, c) and
//! (b, a, d), with the edge c–d: faces (a, d, c) and (d, b, c). No vertex
//! moves, so only the energies that depend on the triangulation change.
//! Each force term prices the flip itself
//! ([`ForceTerm::flip_energy_change`]): V_in from its one edge out and one
//! in, Helfrich bending (cotangent form) from the rings of a, b, c and d,
//! the volume and area penalties and a constant tension from the two
//! faces' tetrahedra and areas. Control-point springs are kept unchanged by
//! never flipping at a point's nearest vertex. A term without a local
//! formula (a plugin term, the dihedral bending, self-avoidance, the local
//! tension) is priced by [`FlipPricer`] as the difference of two whole
//! evaluations of its energy, before and after the flip, which is exact for
//! any term.
//!
//! Accepting a proposed flip with probability min(1, exp(−ΔE/k_BT)) keeps
//! the Boltzmann distribution of the whole energy (the proposal, a
//! uniformly drawn edge, is symmetric: a closed mesh keeps its edge count
//! under flips), so a membrane that moves by Langevin dynamics and flips by
//! this rule samples a fluid membrane's ensemble (dynamically triangulated
//! surfaces; Gompper & Kroll, Phys. Rev. E 51, 514, 1995).

use crate::engine::force::{FlipProposal, ForceContext, ForceTerm};
pub use crate::mesh::flip::{Flip, FlipTotals, dihedral, is_non_delaunay, keeps_surface_unfolded};
use crate::mesh::geometry::{Corners, face_geometry};
use crate::mesh::topology::Topology;

/// Prices flips under a list of force terms: each term's own local change
/// where it has one, otherwise the difference of whole evaluations on a
/// scratch copy of the topology with the flip applied in place.
///
/// The scratch (topology, face geometry and each such term's energy before
/// the flip) is made on the first proposal that needs it and dropped by
/// [`FlipPricer::invalidate`] whenever the mesh or the positions change.
#[derive(Default)]
pub struct FlipPricer {
    scratch: Option<Scratch>,
}

/// The mesh as the whole-energy pricing sees it.
struct Scratch {
    topology: Topology,
    geometry: Vec<Corners>,
    /// Energy of term `i` before any proposal, once asked for.
    before: Vec<Option<f64>>,
}

impl FlipPricer {
    /// Forgets the scratch (call after taking a flip or moving vertices).
    pub fn invalidate(&mut self) {
        self.scratch = None;
    }

    /// ΔE (Ē) of `proposal` summed over `terms` in their order; `+∞` when
    /// the scratch view of the flipped mesh cannot be built (a ring outgrew
    /// its block), which rejects the flip.
    pub fn change(&mut self, terms: &mut [Box<dyn ForceTerm>], proposal: &FlipProposal<'_>) -> f64 {
        let mut energy = 0.0;
        for i in 0..terms.len() {
            energy += match terms[i].flip_energy_change(proposal) {
                Some(change) => change,
                None => self.whole_change(i, terms.len(), &mut terms[i], proposal),
            };
        }
        energy
    }

    /// ΔE of term `i` (of `count`) as the difference of two whole
    /// evaluations.
    fn whole_change(
        &mut self,
        i: usize,
        count: usize,
        term: &mut Box<dyn ForceTerm>,
        proposal: &FlipProposal<'_>,
    ) -> f64 {
        let ctx = &proposal.before;
        let s = self.scratch.get_or_insert_with(|| {
            let mut geometry = Vec::new();
            face_geometry(ctx.positions, &ctx.topology.faces, &mut geometry);
            Scratch {
                topology: ctx.topology.clone(),
                geometry,
                before: vec![None; count],
            }
        });
        let before = match s.before[i] {
            Some(e) => e,
            None => {
                let e = term.energy(&view(ctx, &s.topology, &s.geometry));
                s.before[i] = Some(e);
                e
            }
        };
        let Ok(undo) = s.topology.apply_flip(&proposal.flip) else {
            return f64::INFINITY;
        };
        let faces = proposal.flip.faces.map(|f| f as usize);
        let saved = faces.map(|f| s.geometry[f]);
        for f in faces {
            let [a, b, c] = s.topology.faces[f].map(|v| ctx.positions[v as usize]);
            s.geometry[f] = Corners::new(a, b, c);
        }
        let after = term.energy(&view(ctx, &s.topology, &s.geometry));
        for (f, g) in faces.into_iter().zip(saved) {
            s.geometry[f] = g;
        }
        s.topology.undo_flip(undo);
        after - before
    }
}

/// `ctx` on another topology and face geometry (no edge samples).
fn view<'a>(
    ctx: &ForceContext<'a>,
    topology: &'a Topology,
    geometry: &'a [Corners],
) -> ForceContext<'a> {
    ForceContext {
        topology,
        face_geometry: geometry,
        inputs: crate::engine::term_inputs::TermInputs::none(),
        ..*ctx
    }
}
