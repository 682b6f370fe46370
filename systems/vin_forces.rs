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

/// The V_in segmentation shared by the V_in force, the time-step
/// controller and remeshing (inserted by the Vin plugin).
#[derive(Clone, Debug)]
pub struct VinSegmentation(pub Arc<Segmentation>);

/// The V_in force term.
pub struct VinForces {
    segmentation: Arc<Segmentation>,
    form: VinForm,
    /// Per-edge (energy, end forces) of the parallel form.
    per_edge: Vec<(f64, [DVec3; 2])>,
}

impl VinForces {
    /// A V_in system evaluating `form` on a shared segmentation.
    pub fn new(segmentation: Arc<Segmentation>, form: VinForm) -> Self {
        Self {
            segmentation,
            form,
            per_edge: Vec::new(),
        }
    }

    /// The segmentation this system uses.
    pub fn segmentation(&self) -> &Arc<Segmentation> {
        &self.segmentation
    }
}

/// Σ V(l_e) over edges, adding the edge forces when `force` is given.
#[inline(always)]
fn edge_loop(
    edges: &[[u32; 2]],
    p: &[DVec3],
    per_edge: &mut Vec<(f64, [DVec3; 2])>,
    mut force: Option<&mut [DVec3]>,
    v: impl Fn(f64) -> (f64, f64) + Sync + Send,
) -> f64 {
    if let Some(force) = force
        .as_deref_mut()
        .filter(|_| crate::parallel::splits(edges.len()))
    {
        // Per-edge work in parallel, added in edge order.
        return crate::parallel::accumulate(
            edges,
            force,
            per_edge,
            |e| {
                let [a, b] = edges[e].map(|i| i as usize);
                let d = p[b] - p[a];
                let l = d.length();
                let (value, slope) = v(l);
                let f = d * (slope / l);
                (value, [f, -f])
            },
            |f, c| *f += c,
        );
    }
    let mut energy = 0.0;
    for &[a, b] in edges {
        let (a, b) = (a as usize, b as usize);
        let d = p[b] - p[a];
        let l = d.length();
        let (value, slope) = v(l);
        energy += value;
        if let Some(force) = force.as_deref_mut() {
            let f = d * (slope / l);
            force[a] += f;
            force[b] -= f;
        }
    }
    energy
}

impl VinForces {
    fn run(&mut self, ctx: &ForceContext<'_>, force: Option<&mut [DVec3]>) -> f64 {
        let (edges, p, seg) = (&ctx.topology.edges, ctx.positions, &*self.segmentation);
        let per_edge = &mut self.per_edge;
        match self.form {
            VinForm::PiecewiseLinear => edge_loop(edges, p, per_edge, force, |l| seg.linear(l)),
            VinForm::Exact => edge_loop(edges, p, per_edge, force, |l| {
                (seg.exact(l), seg.params().derivative(l))
            }),
        }
    }
}

impl ForceTerm for VinForces {
    fn name(&self) -> &str {
        "vin"
    }

    fn energy(&mut self, ctx: &ForceContext<'_>) -> f64 {
        self.run(ctx, None)
    }

    fn accumulate(&mut self, ctx: &ForceContext<'_>, force: &mut [DVec3]) -> f64 {
        self.run(ctx, Some(force))
    }
}
