//! The force-term plug-in interface and the force stage that sums terms.
//!
//! A [`ForceTerm`] reads dense positions (and lipid density, topology, and
//! its own components in the world) from a [`ForceContext`] and *adds* −∇E
//! into the force buffer it is given. Every term is evaluated into
//! its own buffer (so forces can be reported and checked per term): the
//! `force_terms` system (`remembrane::systems::force_terms`) evaluates every registered term into its slot of
//! [`ForceBuffers`]; `force_total` then applies the optional 1-ring
//! smoothing to penalty terms and sums the total.

use crate::engine::error::{BuildError, DuplicateTerm, SimError};
use crate::engine::persisted::PersistedResources;
use crate::engine::resources::{Res, Resources};
use crate::engine::schedule::Stage;
use crate::engine::simulation::{SimBuilder, Simulation};
use crate::engine::term_inputs::TermInputs;
use crate::mesh::flip::{Flip, FlipTotals};
use crate::mesh::geometry::{Corners, face_geometry};
use crate::mesh::topology::Topology;
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
    /// What the Gather stage measured for the terms this tick, by type
    /// ([`TermInputs`]); [`TermInputs::none`] outside the schedule (a term
    /// then measures what it needs itself).
    pub inputs: &'a TermInputs,
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
            inputs: TermInputs::none(),
        }
    }
}

/// A proposed edge flip, as the force terms price it
/// ([`ForceTerm::flip_energy_change`]).
#[derive(Clone, Copy)]
pub struct FlipProposal<'a> {
    /// The flip, in the dense slots of `before.topology`.
    pub flip: Flip,
    /// The state before the flip. Its face geometry and inputs are empty: a
    /// flip touches two faces, so a term measures what it needs.
    pub before: ForceContext<'a>,
    /// Area and enclosed volume before the flip (l̄², l̄³), kept current as
    /// flips are taken.
    pub totals: FlipTotals,
    /// The flip's change of the area and the enclosed volume (l̄², l̄³).
    pub change: FlipTotals,
}

impl<'a> FlipProposal<'a> {
    /// The proposal of `flip` at `positions` on `topology` (the flip's own
    /// change of area and volume measured here), with the totals before it.
    pub fn new(
        flip: Flip,
        world: &'a World,
        topology: &'a Topology,
        positions: &'a [DVec3],
        lipid: &'a [f64],
        totals: FlipTotals,
    ) -> Self {
        Self {
            flip,
            before: ForceContext {
                world,
                topology,
                positions,
                lipid,
                face_geometry: &[],
                inputs: TermInputs::none(),
            },
            totals,
            change: flip.totals_change(positions),
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
    /// Mesh maintenance (V_in): it keeps the triangles regular and is no
    /// physics of the membrane. Used as computed in the paper's model; in
    /// the fluid model ([`crate::params::MembraneModel::Fluid`]) only its
    /// component in each vertex's tangent plane acts.
    Maintenance,
    /// A load applied from outside (control-point springs). Used as
    /// computed in the paper's model; in the fluid model only its component
    /// along each vertex normal acts (a fluid membrane at uniform tension
    /// holds no tangential point load).
    External,
}

/// An energy term with an analytic force.
///
/// One method is required, [`ForceTerm::evaluate`]: it returns the energy
/// and, given a force buffer, *adds* −∇E to it (never overwrites). The
/// energy-only and force paths ([`ForceTerm::energy`],
/// [`ForceTerm::accumulate`]) call it. Check a new term with
/// [`crate::fd::check_force_term`].
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
    /// The energy of the current state (Ē), and with `force` its negative
    /// gradient −∇E added to it (Ē/l̄). The same energy with and without
    /// `force`.
    fn evaluate(&mut self, ctx: &ForceContext<'_>, force: Option<&mut [DVec3]>) -> f64;
    /// The energy of the current state (Ē): [`ForceTerm::evaluate`] without
    /// a force.
    fn energy(&mut self, ctx: &ForceContext<'_>) -> f64 {
        self.evaluate(ctx, None)
    }
    /// Adds −∇E to `force` (Ē/l̄) and returns the energy (Ē):
    /// [`ForceTerm::evaluate`] with a force.
    fn accumulate(&mut self, ctx: &ForceContext<'_>, force: &mut [DVec3]) -> f64 {
        self.evaluate(ctx, Some(force))
    }
    /// ΔE (Ē) of a proposed edge flip ([`FlipProposal`]; positions do not
    /// move), for the Metropolis edge flips ([`crate::remesh::flip`]).
    ///
    /// `None` (the default) means the term has no local formula: the flip
    /// system then prices it as the difference of two whole evaluations of
    /// [`ForceTerm::energy`], before and after the flip (on a scratch copy
    /// of the topology, [`Topology::apply_flip`]). That is exact for any
    /// term, at the cost of an evaluation per proposal. A term whose energy
    /// is a sum of local contributions overrides it with the change of the
    /// few contributions the flip touches; check such an override with
    /// [`crate::fd::check_flip_energy_change`].
    fn flip_energy_change(&mut self, proposal: &FlipProposal<'_>) -> Option<f64> {
        let _ = proposal;
        None
    }
    /// Adds the term's stiffness against a displacement of each vertex
    /// along the membrane's normal to `out` (by dense slot, Ē/l̄²): the
    /// magnitude of the energy's second derivative, lumped to the vertices
    /// (for a smooth displacement u of the whole membrane, ½ Σ_i out_i u²
    /// is the energy's second-order change). The Sobolev minimiser adds it
    /// to its metric ([`crate::minimise::sobolev`]), which otherwise sees
    /// only bending and in-plane stretching: a stiff, short-range term (a
    /// contact potential, a wall) then no longer forces its smallest step on
    /// the whole membrane. Returns whether the term has such a stiffness at
    /// all (true even where it adds nothing at this state: a minimiser
    /// then watches for vertices coming into its range). The default adds
    /// nothing and returns false, right for any term whose stiffness
    /// bending's dominates.
    fn normal_stiffness(&self, ctx: &ForceContext<'_>, out: &mut [f64]) -> bool {
        let _ = (ctx, out);
        false
    }
    /// Whether the state of `ctx` lies in the term's domain (default: it
    /// always does). A term whose energy is defined only on part of the
    /// states (the protein species need every fraction inside (0, 1) at
    /// their fixed amounts) says so here; the minimiser undoes and halves a
    /// step that leaves it, as it does a step that folds a face.
    fn admits(&self, ctx: &ForceContext<'_>) -> bool {
        let _ = ctx;
        true
    }
    /// State the term carries from one evaluation to the next, for
    /// checkpoints; `None` (the default) means none (caches that do not
    /// change results do not count). See
    /// [`crate::engine::schedule::System::save_state`].
    fn save_state(&self) -> Option<serde_json::Value> {
        None
    }
    /// Takes back what `save_state` returned (on resuming a run).
    fn restore_state(
        &mut self,
        state: serde_json::Value,
    ) -> Result<(), crate::engine::error::StateError> {
        let _ = state;
        Err(crate::engine::error::StateError::Stateless)
    }
}

/// Energies and forces of one evaluation of the registered terms
/// ([`ForceBuffers::evaluation`]).
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
    /// Total force by dense slot (Ē/l̄). With exact constraints, their
    /// reactions are removed from it ([`crate::constraint`]).
    pub total: Vec<DVec3>,
    /// The exact constraints' multipliers and the area and volume they
    /// were measured at; `None` when the scene holds no constraint.
    pub constraint: Option<crate::constraint::ConstraintState>,
    /// The exact constraints' area and volume gradients at the evaluated
    /// positions (measured once per evaluation by the
    /// `constraint_reactions` system, and read by the minimiser); empty
    /// or stale when `constraint` is `None`.
    pub constraint_gradients: crate::constraint::Gradients,
}

impl ForceEvaluation {
    /// Sum of all term energies (Ē).
    pub fn total_energy(&self) -> f64 {
        self.energies.iter().sum()
    }

    /// The largest total force on any vertex (Ē/l̄; 0 without vertices):
    /// the minimiser's residual.
    pub fn largest_force(&self) -> f64 {
        self.total.iter().map(|f| f.length()).fold(0.0, f64::max)
    }
}

/// Per-face geometry at the current positions, shared by the force terms
/// that ask for it (written in the Gather stage; empty when none does).
#[derive(Clone, Debug, Default)]
pub struct FaceGeometry(pub Vec<Corners>);

/// A registered term's name and how the force stage treats it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct TermInfo {
    /// Unique name.
    pub name: String,
    /// Exact or smoothed penalty force.
    pub kind: ForceKind,
    /// Whether it reads [`FaceGeometry`].
    pub uses_face_geometry: bool,
}

/// The force buffers: one per registered term and their sum. Registering a term ([`crate::engine::simulation::SimBuilder::add_force_term`])
/// adds its buffer here and hands the term to the `force_terms` system.
#[derive(Debug, Default)]
pub struct ForceBuffers {
    terms: Vec<TermInfo>,
    /// The current evaluation.
    pub evaluation: ForceEvaluation,
    vertices: usize,
    objects: TermObjects,
}

/// The registered terms themselves, in registration order.
#[derive(Default)]
struct TermObjects(Vec<Box<dyn ForceTerm>>);

impl std::fmt::Debug for TermObjects {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_list()
            .entries(self.0.iter().map(|t| t.name()))
            .finish()
    }
}

/// Name of the system that evaluates the force terms (`force_terms`).
pub const FORCE_TERMS: &str = "force_terms";

/// Name of the system that sums the term buffers (every term runs before it).
pub const FORCE_TOTAL: &str = "force_total";

impl ForceBuffers {
    /// No terms yet.
    pub fn new() -> Self {
        Self::default()
    }

    /// Registers `term` and adds its buffer; returns its index.
    pub fn register(&mut self, term: Box<dyn ForceTerm>) -> Result<usize, DuplicateTerm> {
        let info = TermInfo {
            name: term.name().to_string(),
            kind: term.kind(),
            uses_face_geometry: term.uses_face_geometry(),
        };
        if self.terms.iter().any(|t| t.name == info.name) {
            return Err(DuplicateTerm(info.name));
        }
        self.terms.push(info);
        self.objects.0.push(term);
        Ok(self.terms.len() - 1)
    }

    /// The registered terms, in evaluation order, to evaluate or to price
    /// a flip with.
    pub fn term_objects_mut(&mut self) -> &mut [Box<dyn ForceTerm>] {
        &mut self.objects.0
    }

    /// The sum of the terms' [`ForceTerm::normal_stiffness`] at `ctx`,
    /// written into `out` (by dense slot, Ē/l̄²; resized to the vertex
    /// count); returns whether any term has such a stiffness.
    pub fn normal_stiffness(&self, ctx: &ForceContext<'_>, out: &mut Vec<f64>) -> bool {
        out.clear();
        out.resize(ctx.positions.len(), 0.0);
        let mut any = false;
        for term in &self.objects.0 {
            any |= term.normal_stiffness(ctx, out);
        }
        any
    }

    /// The first term, in evaluation order, whose domain does not hold the
    /// state of `ctx` ([`ForceTerm::admits`]), by name.
    pub fn refusal(&self, ctx: &ForceContext<'_>) -> Option<&str> {
        self.objects
            .0
            .iter()
            .find(|t| !t.admits(ctx))
            .map(|t| t.name())
    }

    /// The registered terms and the evaluation they write, borrowed together.
    pub fn terms_and_evaluation(&mut self) -> (&mut [Box<dyn ForceTerm>], &mut ForceEvaluation) {
        (&mut self.objects.0, &mut self.evaluation)
    }

    /// The terms' own states ([`ForceTerm::save_state`]) for a checkpoint:
    /// a map from term name to state, `null` when no term keeps one.
    pub(crate) fn save_term_states(
        resources: &crate::engine::resources::Resources,
    ) -> Result<serde_json::Value, crate::engine::persisted::PersistError> {
        let buffers = resources.get::<Self>()?;
        let states = buffers
            .objects
            .0
            .iter()
            .map(|t| (t.name().to_string(), t.save_state()));
        Ok(crate::engine::persisted::save_named(states).unwrap_or(serde_json::Value::Null))
    }

    /// Gives the terms back the states [`ForceBuffers::save_term_states`]
    /// saved.
    pub(crate) fn restore_term_states(
        resources: &crate::engine::resources::Resources,
        state: serde_json::Value,
    ) -> Result<(), crate::engine::persisted::PersistError> {
        let mut buffers = resources.get_mut::<Self>()?;
        crate::engine::persisted::restore_named(
            &mut buffers.objects.0,
            |_, t| t.name().to_string(),
            |t, v| t.restore_state(v),
            state,
        )
        .map_err(|e| crate::engine::persisted::PersistError::ForceTerm(Box::new(e)))
    }

    /// The registered terms, in evaluation order.
    pub fn terms(&self) -> &[TermInfo] {
        &self.terms
    }

    /// Term names in evaluation order.
    pub fn names(&self) -> Vec<String> {
        self.terms.iter().map(|t| t.name.clone()).collect()
    }

    /// Whether any term reads [`FaceGeometry`].
    pub fn needs_face_geometry(&self) -> bool {
        self.terms.iter().any(|t| t.uses_face_geometry)
    }

    /// Sizes and zeroes every term buffer for `n` vertices.
    pub fn begin(&mut self, n: usize) {
        self.vertices = n;
        let out = &mut self.evaluation;
        out.energies.clear();
        out.energies.resize(self.terms.len(), 0.0);
        out.term_forces.resize_with(self.terms.len(), Vec::new);
        for buf in &mut out.term_forces {
            crate::util::parallel::fill_vec(buf, n, |_| DVec3::ZERO);
        }
    }

    /// The first non-finite force or energy: (term, vertex or `None` for
    /// the energy).
    pub fn first_non_finite(&self) -> Option<(&str, Option<usize>)> {
        let ev = &self.evaluation;
        if crate::util::parallel::splits(self.vertices) {
            // One parallel pass over all buffers; the serial search below
            // only runs to name the culprit.
            let forces = &ev.term_forces;
            let bad = crate::util::parallel::position_first(self.vertices, |v| {
                forces
                    .iter()
                    .any(|buf| buf.get(v).is_some_and(|f| !f.is_finite()))
            });
            if bad.is_none() && ev.energies.iter().all(|e| e.is_finite()) {
                return None;
            }
        }
        self.terms
            .iter()
            .zip(ev.term_forces.iter().zip(&ev.energies))
            .find_map(|(t, (buf, energy))| {
                let bad = buf.iter().position(|f| !f.is_finite());
                (bad.is_some() || !energy.is_finite()).then_some((t.name.as_str(), bad))
            })
    }

    /// Sums the term forces into the total. The [`ForceKind::Penalty`]
    /// terms are summed apart, handed to `treat_penalty` (the 1-ring
    /// smoothing the `force_total` system applies; a linear map, so treating
    /// the sum equals treating each term) and then added.
    pub fn finish(&mut self, treat_penalty: impl FnOnce(&mut Vec<DVec3>)) {
        let out = &mut self.evaluation;
        // Sized by the vertices, not the terms: with no term at all (pure
        // diffusion) the total is zero, not empty.
        let n = self.vertices;
        let has_penalty = self.terms.iter().any(|t| t.kind == ForceKind::Penalty);
        if crate::util::parallel::splits(n) {
            // Per vertex, the same additions in the same term order, from
            // zero; each sum is written once (no separate zeroing pass).
            let (terms, forces) = (&self.terms, &out.term_forces);
            let sum_into = |penalty: bool, sum: &mut Vec<DVec3>| {
                crate::util::parallel::fill_vec(sum, n, |v| {
                    let mut s = DVec3::ZERO;
                    for (term, buf) in terms.iter().zip(forces) {
                        if (term.kind == ForceKind::Penalty) == penalty {
                            s += buf[v];
                        }
                    }
                    s
                })
            };
            sum_into(false, &mut out.total);
            if has_penalty {
                sum_into(true, &mut out.smoothed_penalty);
            } else {
                out.smoothed_penalty.clear();
            }
        } else {
            out.total.clear();
            out.total.resize(n, DVec3::ZERO);
            out.smoothed_penalty.clear();
            if has_penalty {
                out.smoothed_penalty.resize(n, DVec3::ZERO);
            }
            Self::sum_terms(
                &self.terms,
                &out.term_forces,
                &mut out.total,
                &mut out.smoothed_penalty,
            );
        }
        if has_penalty {
            treat_penalty(&mut out.smoothed_penalty);
            let smoothed = &out.smoothed_penalty;
            crate::util::parallel::for_each_mut(&mut out.total, |v, t| *t += smoothed[v]);
        }
    }

    /// Adds every term's buffer into `total` or, for penalty terms,
    /// `penalty`, term by term (one thread).
    fn sum_terms(
        terms: &[TermInfo],
        forces: &[Vec<DVec3>],
        total: &mut [DVec3],
        penalty: &mut [DVec3],
    ) {
        for (term, buf) in terms.iter().zip(forces) {
            let sum = if term.kind == ForceKind::Penalty {
                &mut *penalty
            } else {
                &mut *total
            };
            for (t, f) in sum.iter_mut().zip(buf) {
                *t += *f;
            }
        }
    }
}

impl<T: ForceTerm + ?Sized> ForceTerm for Box<T> {
    fn name(&self) -> &str {
        (**self).name()
    }
    fn kind(&self) -> ForceKind {
        (**self).kind()
    }
    fn uses_face_geometry(&self) -> bool {
        (**self).uses_face_geometry()
    }
    fn evaluate(&mut self, ctx: &ForceContext<'_>, force: Option<&mut [DVec3]>) -> f64 {
        (**self).evaluate(ctx, force)
    }
    fn flip_energy_change(&mut self, proposal: &FlipProposal<'_>) -> Option<f64> {
        (**self).flip_energy_change(proposal)
    }
    fn normal_stiffness(&self, ctx: &ForceContext<'_>, out: &mut [f64]) -> bool {
        (**self).normal_stiffness(ctx, out)
    }
    fn admits(&self, ctx: &ForceContext<'_>) -> bool {
        (**self).admits(ctx)
    }
    fn save_state(&self) -> Option<serde_json::Value> {
        (**self).save_state()
    }
    fn restore_state(
        &mut self,
        state: serde_json::Value,
    ) -> Result<(), crate::engine::error::StateError> {
        (**self).restore_state(state)
    }
}

/// Registering force terms and evaluating them: the force stage's part of
/// the builder's and the simulation's API.
impl SimBuilder {
    /// Registers a force term: its buffer in [`ForceBuffers`], evaluated by
    /// the core plugin's `force_terms` system in the Forces stage, in
    /// registration order of the buffers. Needs the core plugin (which
    /// inserts the buffers). Returns the term's buffer index.
    pub fn add_force_term(&mut self, term: impl ForceTerm + 'static) -> Result<usize, BuildError> {
        register_force_term(self.resources_mut(), term)
    }
}

impl Simulation {
    /// Evaluates the forces of the current state by running the schedule's
    /// own Gather and Forces systems (the same terms, finite checks and
    /// timing as a tick), without moving anything.
    pub fn evaluate_forces(&mut self) -> Result<Res<'_, ForceBuffers>, SimError> {
        self.run_stages(&[Stage::Gather, Stage::Forces])?;
        Ok(self.resource::<ForceBuffers>())
    }
}

fn register_force_term(
    resources: &mut Resources,
    term: impl ForceTerm + 'static,
) -> Result<usize, BuildError> {
    let name = term.name().to_string();
    let buffers = resources
        .value_mut::<ForceBuffers>()
        .ok_or_else(|| BuildError::Requires {
            what: format!("force term `{name}`"),
            resource: "ForceBuffers",
            plugin: "the core plugin",
        })?;
    let index = buffers.register(Box::new(term))?;
    if !resources.contains::<PersistedResources>() {
        resources.insert(PersistedResources::default());
    }
    if let Some(p) = resources.value_mut::<PersistedResources>() {
        p.add_optional(
            "force terms",
            ForceBuffers::save_term_states,
            ForceBuffers::restore_term_states,
        );
    }
    Ok(index)
}
