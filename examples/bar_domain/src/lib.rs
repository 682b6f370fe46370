//! BAR-domain proteins as a remembrane plugin, written only against the
//! engine's public API (no fork):
//!
//! - a per-vertex protein coverage φ ∈ [0, 1], the [`Coverage`] component,
//!   carried through remeshing by interpolation (an intensive field);
//! - the energy E = ½κ Σ_i A_i (h_i − φ_i C_p)²: Helfrich bending whose
//!   spontaneous curvature is set locally by the proteins (C_p at full
//!   coverage; h_i the signed cotangent mean curvature |K_i| of the
//!   built-in bending term, 2/R on a sphere of radius R), with its analytic
//!   force ([`BarDomainForces`]); it replaces the scene's `Bending` term,
//!   and prices Metropolis edge flips from the four vertices a flip
//!   touches;
//! - protein diffusion on the mesh ([`ProteinDiffusion`], a Diffuse-stage
//!   system);
//! - a recorder writing φ as point data and the patch's height and mean
//!   curvature as series columns ([`CoverageRecorder`]).
//!
//! Scenes name them `Custom(name: "bar_domain", params: (...))` in
//! `energy` and `Custom(name: "protein_diffusion", stage: Diffuse, params:
//! (...))` in `systems`; [`registry`] registers both for
//! `remembrane::cli::main_with`.

use glam::DVec3;
use hecs::Entity;
use remembrane::energy::bending::{BendingScratch, bending_varying, signed_curvatures};
use remembrane::engine::force::{FaceGeometry, FlipProposal, ForceContext, ForceTerm};
use remembrane::engine::recorder::{FrameData, Recorder};
use remembrane::engine::resources::{Res, ResMut};
use remembrane::engine::schedule::{Stage, System};
use remembrane::engine::simulation::{BuildError, DensePositions, SimBuilder, SimError};
use remembrane::mesh::membrane::Membrane;
use remembrane::mesh::vertex_field::{ScalarComponent, TransferPolicy};
use remembrane::scene::registry::PluginRegistry;
use remembrane::timestep::TimeStepChoice;
use serde::{Deserialize, Serialize};

/// Protein coverage of a vertex: the area fraction covered by BAR-domain
/// proteins (dimensionless, 0..1).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Coverage(pub f64);

impl ScalarComponent for Coverage {
    fn value(&self) -> f64 {
        self.0
    }
    fn from_value(value: f64) -> Self {
        Self(value)
    }
}

/// Where the proteins are at the start.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum Patch {
    /// A spherical cap: vertices within `half_angle` (degrees, 0..=180) of
    /// `axis`, seen from the membrane's centroid, get `coverage`; the rest 0.
    Cap {
        /// Direction of the cap's centre from the centroid (any length > 0).
        axis: (f64, f64, f64),
        /// Angular radius of the cap (degrees).
        half_angle: f64,
        /// Coverage inside the cap (0..=1; default 1).
        #[serde(default = "full", deserialize_with = "unit_interval")]
        coverage: f64,
    },
    /// The same coverage everywhere (0..=1).
    Uniform(#[serde(deserialize_with = "unit_interval")] f64),
}

fn full() -> f64 {
    1.0
}

fn unit_interval<'de, D: serde::Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    let v = f64::deserialize(d)?;
    if (0.0..=1.0).contains(&v) {
        Ok(v)
    } else {
        Err(serde::de::Error::custom(format!(
            "a coverage must be in [0, 1] (got {v})"
        )))
    }
}

/// Parameters of the `bar_domain` term.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BarDomainParams {
    /// Bending modulus κ (Ē = 10 k_BT).
    #[serde(deserialize_with = "remembrane::util::validate::non_negative")]
    pub kappa: f64,
    /// C_p: the spontaneous curvature at full coverage (1/l̄; h = 2/R, so a
    /// fully covered region prefers spheres of radius 2/C_p).
    #[serde(deserialize_with = "remembrane::util::validate::finite")]
    pub curvature: f64,
    /// The initial protein distribution.
    pub patch: Patch,
}

impl Patch {
    /// The unit axis of a cap (+z for a uniform coverage).
    pub fn axis(&self) -> DVec3 {
        match *self {
            Patch::Cap { axis, .. } => DVec3::new(axis.0, axis.1, axis.2).normalize_or(DVec3::Z),
            Patch::Uniform(_) => DVec3::Z,
        }
    }

    /// Coverage of a vertex at `p` on a membrane centred at `centre`.
    pub fn coverage(&self, p: DVec3, centre: DVec3) -> f64 {
        match *self {
            Patch::Cap {
                half_angle,
                coverage,
                ..
            } => {
                let d = (p - centre).normalize_or_zero();
                let inside = d.dot(self.axis()) >= half_angle.to_radians().cos();
                if inside { coverage } else { 0.0 }
            }
            Patch::Uniform(c) => c,
        }
    }

    fn check(&self) -> Result<(), BuildError> {
        if let Patch::Cap {
            axis, half_angle, ..
        } = *self
        {
            let a = DVec3::new(axis.0, axis.1, axis.2);
            if !(a.is_finite() && a.length() > 0.0) {
                return Err(BuildError::Invalid {
                    field: "bar_domain.params.patch.axis".into(),
                    reason: format!("must be a finite non-zero direction (got {axis:?})"),
                });
            }
            if !(half_angle > 0.0 && half_angle <= 180.0) {
                return Err(BuildError::Invalid {
                    field: "bar_domain.params.patch.half_angle".into(),
                    reason: format!("must be in (0, 180] degrees (got {half_angle})"),
                });
            }
        }
        Ok(())
    }
}

/// The coverage of every vertex by dense slot (0 where a vertex has none).
pub fn coverage_by_slot(
    world: &hecs::World,
    topology: &remembrane::mesh::topology::Topology,
    out: &mut Vec<f64>,
) {
    out.clear();
    out.resize(topology.vertex_count(), 0.0);
    for (e, c) in world.query::<(Entity, &Coverage)>().iter() {
        if let Some(s) = topology.slot(e) {
            out[s as usize] = c.0;
        }
    }
}

/// E = ½κ Σ_i A_i (h_i − φ_i C_p)², the force its exact negative gradient
/// with respect to the positions (φ held fixed).
pub struct BarDomainForces {
    kappa: f64,
    curvature: f64,
    scratch: BendingScratch,
    c0: Vec<f64>,
}

impl BarDomainForces {
    /// The term with modulus `kappa` (Ē) and full-coverage curvature
    /// `curvature` (1/l̄).
    pub fn new(kappa: f64, curvature: f64) -> Self {
        Self {
            kappa,
            curvature,
            scratch: BendingScratch::default(),
            c0: Vec::new(),
        }
    }
}

impl ForceTerm for BarDomainForces {
    fn name(&self) -> &str {
        "bar_domain"
    }
    fn uses_face_geometry(&self) -> bool {
        true
    }
    fn evaluate(&mut self, ctx: &ForceContext<'_>, force: Option<&mut [DVec3]>) -> f64 {
        coverage_by_slot(ctx.world, ctx.topology, &mut self.c0);
        for c in &mut self.c0 {
            *c *= self.curvature;
        }
        bending_varying(
            &ctx.topology.faces,
            ctx.face_geometry,
            self.kappa,
            &self.c0,
            &mut self.scratch,
            force,
        )
    }
    /// A flip changes the rings of its four vertices only, so ΔE is the
    /// change of their four vertex energies, each with its own C0 = φ C_p
    /// (read from the four vertices' [`Coverage`]). Without this the flip
    /// system would price the term by two whole evaluations per proposal.
    fn flip_energy_change(&mut self, proposal: &FlipProposal<'_>) -> Option<f64> {
        let ctx = &proposal.before;
        let c0 = |v: u32| {
            let entity = ctx.topology.vertex_entities[v as usize];
            ctx.world.get::<&Coverage>(entity).map_or(0.0, |c| c.0) * self.curvature
        };
        Some(remembrane::energy::bending::flip_energy_change(
            ctx.positions,
            ctx.topology,
            &proposal.flip,
            self.kappa,
            c0,
        ))
    }
}

/// Parameters of the `protein_diffusion` system.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ProteinDiffusionParams {
    /// Diffusion coefficient D of the proteins on the membrane (l̄²/s).
    #[serde(deserialize_with = "remembrane::util::validate::non_negative")]
    pub rate: f64,
}

/// Explicit diffusion of the coverage over mesh edges: every tick of Δt,
/// each edge (a, b) moves D Δt / l̄² (φ_a − φ_b) from a to b (Σφ kept), in
/// as many equal sub-steps as keep every sub-step below a quarter of the
/// stability limit of the most connected vertex.
///
/// Stage: Diffuse. Reads: [`TimeStepChoice`]. Writes: the [`Coverage`]
/// components of the [`Membrane`]'s world.
pub struct ProteinDiffusion {
    rate: f64,
    phi: Vec<f64>,
    next: Vec<f64>,
}

impl ProteinDiffusion {
    /// Diffusion with coefficient `rate` (l̄²/s).
    pub fn new(rate: f64) -> Self {
        Self {
            rate,
            phi: Vec::new(),
            next: Vec::new(),
        }
    }
}

/// The largest explicit sub-step weight used (stable below 1/valence).
const MAX_STEP_WEIGHT: f64 = 0.25 / 8.0;

impl System for ProteinDiffusion {
    type Data<'a> = (Res<'a, TimeStepChoice>, ResMut<'a, Membrane>);

    fn name(&self) -> &str {
        "protein_diffusion"
    }

    fn run(&mut self, (time_step, mut membrane): Self::Data<'_>) -> Result<(), SimError> {
        let k = self.rate * time_step.dt;
        if k <= 0.0 {
            return Ok(());
        }
        membrane.topology()?;
        let t = membrane.cached_topology();
        coverage_by_slot(&membrane.world, t, &mut self.phi);
        let steps = (k / MAX_STEP_WEIGHT).ceil().max(1.0);
        let w = k / steps;
        for _ in 0..steps as usize {
            self.next.clone_from(&self.phi);
            for &[a, b] in &t.edges {
                let flow = w * (self.phi[a as usize] - self.phi[b as usize]);
                self.next[a as usize] -= flow;
                self.next[b as usize] += flow;
            }
            std::mem::swap(&mut self.phi, &mut self.next);
        }
        let entities = t.vertex_entities.clone();
        for (e, &phi) in entities.iter().zip(&self.phi) {
            if let Ok(mut c) = membrane.world.get::<&mut Coverage>(*e) {
                c.0 = phi;
            }
        }
        Ok(())
    }
}

/// Records `coverage` as point data and, as series columns, the patch's
/// bud height, mean curvature and area (the patch: vertices with φ > ½).
///
/// - `coverage_total`: Σφ.
/// - `patch_area` (l̄²): Σ A_i over the patch.
/// - `patch_mean_curvature` (1/l̄): Σ A_i h_i / Σ A_i over the patch, to
///   compare with C_p.
/// - `bud_height` (l̄): how far the patch's farthest vertex along the axis
///   stands out beyond the mean radius of the uncovered membrane (φ < 0.1),
///   both from the centroid; 0 for a sphere.
pub struct CoverageRecorder {
    axis: DVec3,
    scratch: BendingScratch,
    phi: Vec<f64>,
}

impl CoverageRecorder {
    /// A recorder measuring the bud along `axis`.
    pub fn new(axis: DVec3) -> Self {
        Self {
            axis,
            scratch: BendingScratch::default(),
            phi: Vec::new(),
        }
    }
}

/// The patch measures of [`CoverageRecorder`]: (area, mean curvature, bud
/// height).
pub fn patch_measures(
    positions: &[DVec3],
    faces: &[[u32; 3]],
    geometry: &[remembrane::mesh::geometry::Corners],
    phi: &[f64],
    axis: DVec3,
    scratch: &mut BendingScratch,
) -> (f64, f64, f64) {
    let (h, areas) = signed_curvatures(positions.len(), faces, geometry, scratch);
    let centre = positions.iter().copied().sum::<DVec3>() / positions.len() as f64;
    let (mut area, mut curvature, mut apex) = (0.0, 0.0, f64::NEG_INFINITY);
    let (mut body, mut body_n) = (0.0, 0usize);
    for i in 0..positions.len() {
        let r = positions[i] - centre;
        if phi[i] > 0.5 {
            area += areas[i];
            curvature += areas[i] * h[i];
            apex = apex.max(r.dot(axis));
        } else if phi[i] < 0.1 {
            body += r.length();
            body_n += 1;
        }
    }
    let mean_curvature = if area > 0.0 {
        curvature / area
    } else {
        f64::NAN
    };
    let height = if body_n > 0 && apex.is_finite() {
        apex - body / body_n as f64
    } else {
        f64::NAN
    };
    (area, mean_curvature, height)
}

impl Recorder for CoverageRecorder {
    type Data<'a> = (
        Res<'a, Membrane>,
        Res<'a, DensePositions>,
        Res<'a, FaceGeometry>,
    );

    fn name(&self) -> &str {
        "coverage"
    }

    fn record(
        &mut self,
        (membrane, positions, geometry): Self::Data<'_>,
        frame: &mut FrameData,
    ) -> Result<(), SimError> {
        let t = membrane.cached_topology();
        coverage_by_slot(&membrane.world, t, &mut self.phi);
        let (area, curvature, height) = patch_measures(
            &positions.0,
            &t.faces,
            &geometry.0,
            &self.phi,
            self.axis,
            &mut self.scratch,
        );
        frame.column("coverage_total", self.phi.iter().sum());
        frame.column("patch_area", area);
        frame.column("patch_mean_curvature", curvature);
        frame.column("bud_height", height);
        frame.scalars("coverage", self.phi.clone());
        Ok(())
    }
}

/// The `bar_domain` plugin: the coverage field (initialised from `patch`,
/// interpolated through remeshing), the energy term and the recorder.
pub fn plugin(params: BarDomainParams) -> impl remembrane::engine::simulation::Plugin {
    move |b: &mut SimBuilder| -> Result<(), BuildError> {
        params.patch.check()?;
        let membrane = b.resource_mut::<Membrane>().ok_or(BuildError::Requires {
            what: "bar_domain".into(),
            resource: "Membrane",
            plugin: "SimBuilder::new",
        })?;
        let mut positions = Vec::new();
        membrane.topology().map_err(invalid)?;
        membrane.gather_positions(&mut positions);
        let centre = positions.iter().copied().sum::<DVec3>() / positions.len() as f64;
        let patch = params.patch;
        membrane
            .add_vertex_field::<Coverage>("coverage", TransferPolicy::Interpolate, |_, p| {
                patch.coverage(p, centre)
            })
            .map_err(invalid)?;
        b.add_force_term(BarDomainForces::new(params.kappa, params.curvature))?;
        b.add_recorder(CoverageRecorder::new(params.patch.axis()));
        Ok(())
    }
}

fn invalid(e: impl std::fmt::Display) -> BuildError {
    BuildError::Invalid {
        field: "bar_domain".into(),
        reason: e.to_string(),
    }
}

/// The registry with `bar_domain` (term) and `protein_diffusion` (system).
pub fn registry() -> PluginRegistry {
    let mut r = PluginRegistry::new();
    r.register_term("bar_domain", |p: BarDomainParams, b: &mut SimBuilder| {
        b.add_plugin(plugin(p))?;
        Ok(())
    });
    r.register_system(
        "protein_diffusion",
        |p: ProteinDiffusionParams, stage: Stage, b: &mut SimBuilder| {
            b.add_system(stage, ProteinDiffusion::new(p.rate));
            Ok(())
        },
    );
    r
}
