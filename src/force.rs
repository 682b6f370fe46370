//! The force-term plug-in interface and the force stage that sums terms.
//!
//! A [`ForceTerm`] reads dense positions (and lipid density, topology, and
//! its own components in the world) from a [`ForceContext`] and *adds* −∇E
//! into the force buffer it is given. [`ForceSet`] evaluates every term into
//! its own buffer (so forces can be reported and checked per term), applies
//! the optional 1-ring smoothing to penalty terms, and sums the total.

use crate::geometry::{Corners, face_geometry};
use crate::topology::Topology;
use glam::DVec3;
use hecs::World;

/// Read-only inputs of a force evaluation.
#[derive(Clone, Copy)]
pub struct ForceContext<'a> {
    /// The world (for terms with their own components, e.g. control points).
    pub world: &'a World,
    /// Dense connectivity.
    pub topology: &'a Topology,
    /// Vertex positions by dense slot (l̄).
    pub positions: &'a [DVec3],
    /// Lipid density by dense slot; empty when the scene declares none.
    pub lipid: &'a [f64],
    /// Per-face geometry (edges, unit normal, area, cotangents) at
    /// `positions`, in face order; empty unless a term in the evaluation
    /// returned `true` from [`ForceTerm::uses_face_geometry`].
    pub face_geometry: &'a [Corners],
}

impl<'a> ForceContext<'a> {
    /// A context for `positions`; fills `geometry` with the per-face
    /// geometry first when `with_face_geometry` is set.
    pub fn new(
        world: &'a World,
        topology: &'a Topology,
        positions: &'a [DVec3],
        lipid: &'a [f64],
        geometry: &'a mut Vec<Corners>,
        with_face_geometry: bool,
    ) -> Self {
        if with_face_geometry {
            face_geometry(positions, &topology.faces, geometry);
        } else {
            geometry.clear();
        }
        Self {
            world,
            topology,
            positions,
            lipid,
            face_geometry: geometry,
        }
    }
}

/// How the force stage treats a term's force.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ForceKind {
    /// Used as computed: exactly −∇E.
    Conservative,
    /// A global penalty (volume, area, local tension): its force is averaged
    /// over closed 1-rings `penalty_smoothing` times (SPEC §2; 0 = exact).
    Penalty,
}

/// An energy term with an analytic force.
///
/// Contract: [`ForceTerm::accumulate`] *adds* −∇E to `force` (never
/// overwrites) and returns the same energy [`ForceTerm::energy`] would.
/// Check a new term with [`crate::fd::check_force_term`].
pub trait ForceTerm: Send {
    /// Unique name, used in reports, per-term force output and errors.
    fn name(&self) -> &str;
    /// How the force stage treats this term's force.
    fn kind(&self) -> ForceKind {
        ForceKind::Conservative
    }
    /// Whether the term reads [`ForceContext::face_geometry`] (computed once
    /// per evaluation for all terms that ask).
    fn uses_face_geometry(&self) -> bool {
        false
    }
    /// Energy of the current state (Ē).
    fn energy(&mut self, ctx: &ForceContext<'_>) -> f64;
    /// Adds −∇E to `force` (Ē/l̄) and returns the energy (Ē).
    fn accumulate(&mut self, ctx: &ForceContext<'_>, force: &mut [DVec3]) -> f64;
}

/// Energies and forces of one evaluation of a [`ForceSet`].
#[derive(Clone, Debug, Default)]
pub struct ForceEvaluation {
    /// Energy of each term, in term order (Ē).
    pub energies: Vec<f64>,
    /// Force of each term, by dense slot (Ē/l̄): exactly −∇E of the term
    /// (before any smoothing).
    pub term_forces: Vec<Vec<DVec3>>,
    /// Sum of the penalty terms' forces after 1-ring smoothing (Ē/l̄); empty
    /// when there are no penalty terms. Included in `total`.
    pub smoothed_penalty: Vec<DVec3>,
    /// Total force by dense slot (Ē/l̄).
    pub total: Vec<DVec3>,
}

impl ForceEvaluation {
    /// Sum of all term energies (Ē).
    pub fn total_energy(&self) -> f64 {
        self.energies.iter().sum()
    }
}

/// The force stage: an ordered list of terms plus penalty smoothing.
pub struct ForceSet {
    terms: Vec<Box<dyn ForceTerm>>,
    /// Passes of closed 1-ring averaging applied to [`ForceKind::Penalty`]
    /// terms (as run: 4; 0 = exact gradient).
    pub penalty_smoothing: u32,
    scratch: Vec<DVec3>,
    geometry: Vec<Corners>,
}

impl ForceSet {
    /// An empty force set.
    pub fn new(penalty_smoothing: u32) -> Self {
        Self {
            terms: Vec::new(),
            penalty_smoothing,
            scratch: Vec::new(),
            geometry: Vec::new(),
        }
    }

    /// Adds a term; names must be unique.
    pub fn push(&mut self, term: Box<dyn ForceTerm>) -> Result<(), String> {
        if self.terms.iter().any(|t| t.name() == term.name()) {
            return Err(format!(
                "a force term named `{}` is already registered",
                term.name()
            ));
        }
        self.terms.push(term);
        Ok(())
    }

    /// Term names in evaluation order.
    pub fn names(&self) -> Vec<String> {
        self.terms.iter().map(|t| t.name().to_string()).collect()
    }

    /// Mutable access to the terms (e.g. for finite-difference checks).
    pub fn terms_mut(&mut self) -> &mut [Box<dyn ForceTerm>] {
        &mut self.terms
    }

    /// Evaluates every term into `out`, reusing its buffers:
    /// [`ForceSet::begin`], [`ForceSet::evaluate_term`] for each term, then
    /// [`ForceSet::finish`] (the schedule runs the same three steps as
    /// separately timed systems).
    pub fn evaluate(
        &mut self,
        world: &World,
        topology: &Topology,
        positions: &[DVec3],
        lipid: &[f64],
        out: &mut ForceEvaluation,
    ) {
        self.begin(topology, positions, out);
        for i in 0..self.terms.len() {
            self.evaluate_term(i, world, topology, positions, lipid, out);
        }
        self.finish(topology, out);
    }

    /// Number of terms.
    pub fn len(&self) -> usize {
        self.terms.len()
    }

    /// Whether there are no terms.
    pub fn is_empty(&self) -> bool {
        self.terms.is_empty()
    }

    /// Sizes `out` for `positions` and computes the shared per-face
    /// geometry if any term uses it.
    pub fn begin(&mut self, topology: &Topology, positions: &[DVec3], out: &mut ForceEvaluation) {
        let n = positions.len();
        out.energies.clear();
        out.energies.resize(self.terms.len(), 0.0);
        out.term_forces.resize_with(self.terms.len(), Vec::new);
        for buf in &mut out.term_forces {
            buf.clear();
            buf.resize(n, DVec3::ZERO);
        }
        if self.terms.iter().any(|t| t.uses_face_geometry()) {
            face_geometry(positions, &topology.faces, &mut self.geometry);
        } else {
            self.geometry.clear();
        }
    }

    /// Evaluates term `index` into `out.term_forces[index]` and
    /// `out.energies[index]` (after [`ForceSet::begin`]).
    pub fn evaluate_term(
        &mut self,
        index: usize,
        world: &World,
        topology: &Topology,
        positions: &[DVec3],
        lipid: &[f64],
        out: &mut ForceEvaluation,
    ) {
        let ctx = ForceContext {
            world,
            topology,
            positions,
            lipid,
            face_geometry: &self.geometry,
        };
        out.energies[index] = self.terms[index].accumulate(&ctx, &mut out.term_forces[index]);
    }

    /// Sums the term forces into `out.total`; penalty terms are summed first
    /// and smoothed once (smoothing is linear, so this equals smoothing each).
    pub fn finish(&mut self, topology: &Topology, out: &mut ForceEvaluation) {
        let n = out.term_forces.first().map_or(0, Vec::len);
        out.total.clear();
        out.total.resize(n, DVec3::ZERO);
        out.smoothed_penalty.clear();
        let has_penalty = self.terms.iter().any(|t| t.kind() == ForceKind::Penalty);
        if has_penalty {
            out.smoothed_penalty.resize(n, DVec3::ZERO);
        }
        for (term, buf) in self.terms.iter().zip(&out.term_forces) {
            let sum = if term.kind() == ForceKind::Penalty {
                &mut out.smoothed_penalty
            } else {
                &mut out.total
            };
            for (t, f) in sum.iter_mut().zip(buf) {
                *t += *f;
            }
        }
        if has_penalty {
            crate::energy::penalty::smooth_over_rings(
                &mut out.smoothed_penalty,
                &topology.ring_offsets,
                &topology.ring,
                self.penalty_smoothing,
                &mut self.scratch,
            );
            for (t, f) in out.total.iter_mut().zip(&out.smoothed_penalty) {
                *t += *f;
            }
        }
    }

    /// Energy of each term without forces.
    pub fn energies(
        &mut self,
        world: &World,
        topology: &Topology,
        positions: &[DVec3],
        lipid: &[f64],
    ) -> Vec<f64> {
        let with_geometry = self.terms.iter().any(|t| t.uses_face_geometry());
        let ctx = ForceContext::new(
            world,
            topology,
            positions,
            lipid,
            &mut self.geometry,
            with_geometry,
        );
        self.terms.iter_mut().map(|t| t.energy(&ctx)).collect()
    }
}
