//! Helfrich bending forces (analytic gradient of the discrete energy, in
//! the scene's discretisation).
//!
//! Stage: Forces. Reads: positions, topology (faces; edges for the dihedral
//! form). Writes: force accumulator. Units: κ in Ē, C0 in 1/l̄. See
//! [`crate::energy::bending`] and [`crate::energy::bending_dihedral`].

use crate::energy::bending::{BendingScratch, bending};
use crate::energy::bending_dihedral::{DihedralScratch, bending_dihedral};
use crate::engine::force::{FlipProposal, ForceContext, ForceTerm};
use crate::params::{BendingDiscretisation, BendingParams};
use glam::DVec3;

/// The bending force system.
pub struct BendingForces {
    params: BendingParams,
    scratch: BendingScratch,
    dihedral: DihedralScratch,
}

impl BendingForces {
    /// A bending system with the given modulus and spontaneous curvature.
    pub fn new(params: BendingParams) -> Self {
        Self {
            params,
            scratch: BendingScratch::default(),
            dihedral: DihedralScratch::default(),
        }
    }
}

impl ForceTerm for BendingForces {
    fn name(&self) -> &str {
        "bending"
    }

    fn uses_face_geometry(&self) -> bool {
        true
    }

    fn energy(&mut self, ctx: &ForceContext<'_>) -> f64 {
        self.evaluate(ctx, None)
    }

    fn accumulate(&mut self, ctx: &ForceContext<'_>, force: &mut [DVec3]) -> f64 {
        self.evaluate(ctx, Some(force))
    }

    /// The cotangent form's change at the four vertices whose rings the
    /// flip changes; `None` for the dihedral form (priced whole).
    fn flip_energy_change(&mut self, proposal: &FlipProposal<'_>) -> Option<f64> {
        let p = &self.params;
        (p.discretisation == BendingDiscretisation::Cotangent).then(|| {
            crate::energy::bending::flip_energy_change(
                proposal.before.positions,
                proposal.before.topology,
                &proposal.flip,
                p.kappa,
                |_| p.c0,
            )
        })
    }
}

impl BendingForces {
    /// The energy, and with `force` its negative gradient added to it.
    fn evaluate(&mut self, ctx: &ForceContext<'_>, force: Option<&mut [DVec3]>) -> f64 {
        let p = &self.params;
        match p.discretisation {
            BendingDiscretisation::Cotangent => bending(
                ctx.positions.len(),
                &ctx.topology.faces,
                ctx.face_geometry,
                p.kappa,
                p.c0,
                &mut self.scratch,
                force,
            ),
            BendingDiscretisation::Dihedral => bending_dihedral(
                ctx.positions,
                ctx.topology,
                ctx.face_geometry,
                p.kappa,
                p.c0,
                &mut self.dihedral,
                force,
            ),
        }
    }
}
