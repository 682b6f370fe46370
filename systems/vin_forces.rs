//! V_in edge forces.
//!
//! Stage: Forces. Reads: positions, topology (edges). Writes: force
//! accumulator. Units: Ē, Ē/l̄. One V_in per edge: E_in = Σ_edges V_in(l_e);
//! the force on an edge's end points is ∓V_in'(l) along the edge, with V_in'
//! the chord slope of l's segment (piecewise-linear form) or the exact slope.

use crate::energy::vin::{Segmentation, VinForm};
use crate::force::{ForceContext, ForceTerm};
use glam::DVec3;
use std::sync::Arc;

/// The V_in force system.
pub struct VinForces {
    segmentation: Arc<Segmentation>,
    form: VinForm,
}

impl VinForces {
    /// A V_in system evaluating `form` on a shared segmentation.
    pub fn new(segmentation: Arc<Segmentation>, form: VinForm) -> Self {
        Self { segmentation, form }
    }

    /// The segmentation this system uses.
    pub fn segmentation(&self) -> &Arc<Segmentation> {
        &self.segmentation
    }

    #[inline]
    fn value_and_slope(&self, l: f64) -> (f64, f64) {
        match self.form {
            VinForm::PiecewiseLinear => self.segmentation.linear(l),
            VinForm::Exact => (
                self.segmentation.exact(l),
                self.segmentation.params().derivative(l),
            ),
        }
    }
}

impl ForceTerm for VinForces {
    fn name(&self) -> &str {
        "vin"
    }

    fn energy(&mut self, ctx: &ForceContext<'_>) -> f64 {
        let p = ctx.positions;
        ctx.topology
            .edges
            .iter()
            .map(|&[a, b]| {
                self.value_and_slope(p[a as usize].distance(p[b as usize]))
                    .0
            })
            .sum()
    }

    fn accumulate(&mut self, ctx: &ForceContext<'_>, force: &mut [DVec3]) -> f64 {
        let p = ctx.positions;
        let mut energy = 0.0;
        for &[a, b] in &ctx.topology.edges {
            let d = p[b as usize] - p[a as usize];
            let l = d.length();
            let (v, slope) = self.value_and_slope(l);
            energy += v;
            let f = d * (slope / l);
            force[a as usize] += f;
            force[b as usize] -= f;
        }
        energy
    }
}
