//! V_in edge forces.
//!
//! Stage: Forces. Reads: positions, topology (edges). Writes: force
//! accumulator. Units: Ē, Ē/l̄. One V_in per edge: E_in = Σ_edges V_in(l_e);
//! the force on an edge's end points is ∓V_in'(l) along the edge, with V_in'
//! the chord slope of l's segment (piecewise-linear form) or the exact slope.

use crate::energy::vin::{Segmentation, VinForm};
use crate::engine::force::{FlipProposal, ForceContext, ForceKind, ForceTerm};
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
}

/// Σ V(l_e) over edges, adding the edge forces when `force` is given.
/// `sample(e)` gives edge e's vector, length and segment; `v(s, l)` its
/// V_in value and slope.
///
/// One thread, also on a large mesh: an edge's work (a slope lookup on the
/// tick's samples) costs about what its two additions cost, so the form
/// that computes edges in parallel and adds them in order (as the bending
/// pull-back does) gained nothing. On the 40962-vertex RBC with 2 threads,
/// where this term runs beside the others, per-tick times of the two forms
/// were within the VM's run-to-run noise, and this one holds no per-edge
/// buffers (1.8 MB).
#[inline(always)]
fn edge_loop(
    edges: &[[u32; 2]],
    sample: impl Fn(usize) -> (DVec3, f64, usize),
    mut force: Option<&mut [DVec3]>,
    v: impl Fn(usize, f64) -> (f64, f64),
) -> f64 {
    let mut energy = 0.0;
    for (e, &[a, b]) in edges.iter().enumerate() {
        let (a, b) = (a as usize, b as usize);
        let (d, l, s) = sample(e);
        let (value, slope) = v(s, l);
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
        let linear = |s: usize, l: f64| seg.linear_in(s, l);
        let exact = |_: usize, l: f64| seg.exact_and_slope(l);
        // The tick's edge samples when the Gather stage measured them (the
        // same vectors, lengths and segments this would compute).
        let samples = ctx.edge_samples;
        if samples.len() == edges.len() {
            let sample = |e: usize| {
                let s = samples[e];
                (s.d, s.length, s.segment as usize)
            };
            return match self.form {
                VinForm::PiecewiseLinear => edge_loop(edges, sample, force, linear),
                VinForm::Exact => edge_loop(edges, sample, force, exact),
            };
        }
        let sample = |e: usize| {
            let [a, b] = edges[e].map(|i| i as usize);
            let d = p[b] - p[a];
            let l = d.length();
            (d, l, seg.segment_of(l))
        };
        match self.form {
            VinForm::PiecewiseLinear => edge_loop(edges, sample, force, linear),
            VinForm::Exact => edge_loop(edges, sample, force, exact),
        }
    }
}

impl ForceTerm for VinForces {
    fn name(&self) -> &str {
        "vin"
    }

    fn kind(&self) -> ForceKind {
        ForceKind::Maintenance
    }

    fn energy(&mut self, ctx: &ForceContext<'_>) -> f64 {
        self.run(ctx, None)
    }

    fn accumulate(&mut self, ctx: &ForceContext<'_>, force: &mut [DVec3]) -> f64 {
        self.run(ctx, Some(force))
    }

    /// V of the new edge c–d less V of the old edge a–b, in the form the
    /// force uses.
    fn flip_energy_change(&mut self, proposal: &FlipProposal<'_>) -> Option<f64> {
        let (p, flip) = (proposal.before.positions, &proposal.flip);
        let v = |l: f64| match self.form {
            VinForm::PiecewiseLinear => self.segmentation.linear(l).0,
            VinForm::Exact => self.segmentation.exact(l),
        };
        let ab = p[flip.a as usize].distance(p[flip.b as usize]);
        let cd = p[flip.c as usize].distance(p[flip.d as usize]);
        Some(v(cd) - v(ab))
    }
}
