//! The built-in recorders: what every frame holds (see [`crate::engine::recorder`]).
//!
//! - [`StateColumns`]: `iteration,time,dt,vertices`, `energy_<term>` per
//!   term, `energy_total,area,volume,reduced_volume,edge_min,edge_max,
//!   abnormal_edges,splits,merges,remesh_spread`.
//! - [`ForceField`]: point data `force` (the total force the next step
//!   applies, Ē/l̄).
//! - [`MeanCurvatureField`]: point data `mean_curvature` |K| (1/l̄).
//! - [`LipidDensityField`]: point data `density` (only with lipid density).
//! - [`TubeRadius`]: `radius_<name>` and `radius_<name>_norm` (divided by
//!   the first frame's radius) of one tube probe.
//! - [`ConstraintColumns`]: `tension` σ and `pressure` Δp, the exact
//!   constraints' multipliers, and `constraint_violation`.
//! - [`MinimiserColumns`]: `force_residual` (the largest force on a
//!   vertex) and `energy_change` of the FIRE minimiser.
//! - [`ControlPointForce`]: `force_<name>` and `force_<name>_x`, `_y`, `_z`,
//!   the force one named control point's springs exert on the membrane.
//! - [`ContactCurvatureColumn`]: `<name>_contact_curvature` (1/l̄) of one
//!   adhesive substrate ([`crate::analysis::contact_curvature`]).

use crate::analysis::tube_radius::TubeProbe;
use crate::engine::force::ForceBuffers;
use crate::engine::recorder::{FrameData, Recorder};
use crate::engine::resources::Res;
use crate::engine::shared_resources::AbnormalEdges;
use crate::engine::simulation::{Clock, DenseLipid, DensePositions, SimError};
use crate::mesh::membrane::Membrane;
use crate::remesh::RemeshStats;
use crate::timestep::TimeStepChoice;

/// The state columns of `series.csv`.
pub struct StateColumns;

impl Recorder for StateColumns {
    type Data<'a> = (
        Res<'a, Membrane>,
        Res<'a, DensePositions>,
        Res<'a, ForceBuffers>,
        Res<'a, TimeStepChoice>,
        Res<'a, Clock>,
        Res<'a, AbnormalEdges>,
        Option<Res<'a, RemeshStats>>,
    );

    fn name(&self) -> &str {
        "state_columns"
    }

    fn record(
        &mut self,
        (membrane, positions, buffers, step, clock, abnormal, stats): Self::Data<'_>,
        frame: &mut FrameData,
    ) -> Result<(), SimError> {
        let t = membrane.cached_topology();
        let p = &positions.0;
        let area = crate::mesh::geometry::total_area(p, &t.faces);
        let (mut lmin, mut lmax) = (f64::INFINITY, 0.0f64);
        for &[a, b] in &t.edges {
            let l = p[a as usize].distance(p[b as usize]);
            lmin = lmin.min(l);
            lmax = lmax.max(l);
        }
        frame.count("iteration", clock.iteration);
        frame.column("time", clock.time);
        frame.column("dt", step.dt);
        frame.count("vertices", t.vertex_count() as u64);
        for (term, e) in buffers.terms().iter().zip(&buffers.evaluation.energies) {
            frame.column(format!("energy_{}", term.name), *e);
        }
        frame.column("energy_total", buffers.evaluation.total_energy());
        frame.column("area", area);
        // An open membrane encloses no volume: its rows have no such columns.
        if !t.is_open() {
            let volume = crate::mesh::geometry::enclosed_volume(p, &t.faces, p[0]);
            frame.column("volume", volume);
            frame.column(
                "reduced_volume",
                crate::mesh::geometry::reduced_volume(volume, area),
            );
        }
        frame.column("edge_min", lmin);
        frame.column("edge_max", lmax);
        frame.count("abnormal_edges", abnormal.0.len() as u64);
        let none = RemeshStats::default();
        let stats = stats.as_deref().unwrap_or(&none);
        frame.count("splits", stats.split.success);
        frame.count("merges", stats.merge.success);
        frame.column("remesh_spread", stats.position_spread());
        Ok(())
    }
}

/// The total force as point data `force`.
pub struct ForceField;

impl Recorder for ForceField {
    type Data<'a> = Res<'a, ForceBuffers>;

    fn name(&self) -> &str {
        "force"
    }

    fn record(&mut self, buffers: Self::Data<'_>, frame: &mut FrameData) -> Result<(), SimError> {
        frame.vectors("force", buffers.evaluation.total.clone());
        Ok(())
    }
}

/// |K| of the discrete mean-curvature vector as point data `mean_curvature`.
pub struct MeanCurvatureField;

impl Recorder for MeanCurvatureField {
    type Data<'a> = (Res<'a, Membrane>, Res<'a, DensePositions>);

    fn name(&self) -> &str {
        "mean_curvature"
    }

    fn record(
        &mut self,
        (membrane, positions): Self::Data<'_>,
        frame: &mut FrameData,
    ) -> Result<(), SimError> {
        let k = crate::mesh::geometry::curvature_vectors(
            &positions.0,
            &membrane.cached_topology().faces,
        );
        frame.scalars("mean_curvature", k.iter().map(|k| k.length()).collect());
        Ok(())
    }
}

/// Lipid density as point data `density` (nothing without lipid density).
pub struct LipidDensityField;

impl Recorder for LipidDensityField {
    type Data<'a> = Res<'a, DenseLipid>;

    fn name(&self) -> &str {
        "density"
    }

    fn record(&mut self, lipid: Self::Data<'_>, frame: &mut FrameData) -> Result<(), SimError> {
        if !lipid.0.is_empty() {
            frame.scalars("density", lipid.0.clone());
        }
        Ok(())
    }
}

/// The protein species: per species the columns `count_<name>`,
/// `mu_<name>` (Ē per protein; `NaN` for a conserved species before its
/// first relaxation), `phi_min_<name>`, `phi_mean_<name>` (area-weighted)
/// and `phi_max_<name>`, and the point data `phi_<name>` (area fractions).
pub struct SpeciesColumns;

impl Recorder for SpeciesColumns {
    type Data<'a> = (
        Res<'a, Membrane>,
        Res<'a, DensePositions>,
        Res<'a, crate::engine::term_inputs::TermInputs>,
        Res<'a, crate::species::model::SpeciesModel>,
        Res<'a, crate::species::model::SpeciesStatus>,
    );

    fn name(&self) -> &str {
        "species"
    }

    fn record(
        &mut self,
        (membrane, positions, inputs, model, status): Self::Data<'_>,
        frame: &mut FrameData,
    ) -> Result<(), SimError> {
        use crate::species::params::Reservoir;
        use crate::species::state::{SpeciesAmounts, fractions_at};
        let Some(amounts) = inputs.get::<SpeciesAmounts>() else {
            return Ok(());
        };
        let set = &model.set;
        let faces = &membrane.cached_topology().faces;
        let phi = fractions_at(
            set,
            &amounts.0,
            &positions.0,
            faces,
            model.base.discretisation,
        );
        // The vertex areas partition the faces: Σ A_i φ_i / Σ A_i = a_s N / A.
        let area = crate::mesh::geometry::total_area(&positions.0, faces);
        for (k, s) in set.species.iter().enumerate() {
            let name = &s.name;
            let count: f64 = amounts.0[k].iter().sum();
            let unrelaxed = s.reservoir == Reservoir::Conserved
                && status.relaxations == 0
                && status.transport_steps == 0;
            let mu = if unrelaxed {
                f64::NAN
            } else {
                status.chemical_potentials[k]
            };
            let p = &phi[k];
            let (lo, hi) = p
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &x| {
                    (l.min(x), h.max(x))
                });
            frame.column(format!("count_{name}"), count);
            frame.column(format!("mu_{name}"), mu);
            frame.column(format!("phi_min_{name}"), lo);
            frame.column(
                format!("phi_mean_{name}"),
                count * s.area_per_protein / area,
            );
            frame.column(format!("phi_max_{name}"), hi);
            frame.scalars(format!("phi_{name}"), phi[k].clone());
        }
        Ok(())
    }
}

/// The radius of one tube by circle fits on its planes.
pub struct TubeRadius {
    probe: TubeProbe,
    first: Option<f64>,
    /// `radius_<name>`: the recorder's name.
    column: String,
}

impl TubeRadius {
    /// A recorder measuring `probe`.
    pub fn new(probe: TubeProbe) -> Self {
        let column = format!("radius_{}", probe.name);
        Self {
            probe,
            first: None,
            column,
        }
    }
}

impl Recorder for TubeRadius {
    type Data<'a> = (Res<'a, Membrane>, Res<'a, DensePositions>);

    fn name(&self) -> &str {
        &self.column
    }

    fn save_state(&self) -> Option<serde_json::Value> {
        // The first frame's radius, which later frames are divided by
        // (`null` until a frame measured one).
        Some(serde_json::json!({ "first": self.first.filter(|r| r.is_finite()) }))
    }

    fn restore_state(
        &mut self,
        state: serde_json::Value,
    ) -> Result<(), crate::engine::error::StateError> {
        match state.get("first") {
            Some(serde_json::Value::Null) => self.first = None,
            Some(v) => self.first = Some(v.as_f64().ok_or("`first` is not a number")?),
            None => return Err("no `first`".into()),
        }
        Ok(())
    }

    fn record(
        &mut self,
        (membrane, positions): Self::Data<'_>,
        frame: &mut FrameData,
    ) -> Result<(), SimError> {
        let r = self
            .probe
            .measure(&positions.0, &membrane.cached_topology().edges)
            .map(|(r, _)| r);
        if self.first.is_none() {
            self.first = r;
        }
        let norm = match (r, self.first) {
            (Some(r), Some(r0)) => r / r0,
            _ => f64::NAN,
        };
        frame.column(self.column.clone(), r.unwrap_or(f64::NAN));
        frame.column(format!("{}_norm", self.column), norm);
        Ok(())
    }
}

/// The force one control point's springs exert on the membrane, k Σ_j
/// (x_c − x_j) over its nearest vertex and that vertex's 1-ring (the same
/// total for both couplings; Ē/l̄).
pub struct ControlPointForce {
    index: u32,
    /// `force_<name>`: the recorder's name and its columns' prefix.
    column: String,
}

impl ControlPointForce {
    /// A recorder for the control point declared `index`-th, columns named
    /// after `name`.
    pub fn new(name: String, index: u32) -> Self {
        Self {
            index,
            column: format!("force_{name}"),
        }
    }
}

impl Recorder for ControlPointForce {
    type Data<'a> = (
        Res<'a, Membrane>,
        Res<'a, DensePositions>,
        Option<Res<'a, crate::params::SpringCoupling>>,
        Option<Res<'a, crate::params::MembraneModel>>,
    );

    fn name(&self) -> &str {
        &self.column
    }

    fn record(
        &mut self,
        (membrane, positions, coupling, model): Self::Data<'_>,
        frame: &mut FrameData,
    ) -> Result<(), SimError> {
        use crate::mesh::components::{ControlPoint, ControlPointIndex};
        let p = &positions.0;
        let coupling = coupling.map(|c| *c).unwrap_or_default();
        let fluid = model.is_some_and(|m| m.is_fluid());
        let t = membrane.cached_topology();
        let point = membrane
            .world
            .query::<(&ControlPointIndex, &ControlPoint)>()
            .iter()
            .find(|(i, _)| i.0 == self.index)
            .map(|(_, cp)| *cp);
        let force = match point {
            Some(cp) if !p.is_empty() => {
                // The force stage's nearest vertex (its cell list gives the
                // brute-force answer).
                let i = crate::energy::springs::nearest_vertex(p, cp.position);
                crate::energy::springs::delivered_force(p, t, &cp, coupling, i, fluid)
            }
            _ => glam::DVec3::NAN,
        };
        let name = &self.column;
        frame.column(name.clone(), force.length());
        frame.column(format!("{name}_x"), force.x);
        frame.column(format!("{name}_y"), force.y);
        frame.column(format!("{name}_z"), force.z);
        Ok(())
    }
}

/// The exact constraints' multipliers: `tension` σ (Ē/l̄²), `pressure` Δp
/// (Ē/l̄³) and `constraint_violation`, the largest relative violation.
pub struct ConstraintColumns;

impl Recorder for ConstraintColumns {
    type Data<'a> = Res<'a, ForceBuffers>;

    fn name(&self) -> &str {
        "constraints"
    }

    fn record(&mut self, buffers: Self::Data<'_>, frame: &mut FrameData) -> Result<(), SimError> {
        let c = buffers.evaluation.constraint.unwrap_or_default();
        frame.column("tension", c.reactions.tension);
        frame.column("pressure", c.reactions.pressure);
        frame.column("constraint_violation", c.violation());
        Ok(())
    }
}

/// The minimiser's progress: `force_residual`, the largest force on a
/// vertex of the recorded state (Ē/l̄), and `energy_change` (relative,
/// over its window up to the previous iteration; NaN until the window
/// has filled).
pub struct MinimiserColumns;

impl Recorder for MinimiserColumns {
    type Data<'a> = (
        Res<'a, ForceBuffers>,
        Res<'a, crate::minimise::MinimiserStatus>,
    );

    fn name(&self) -> &str {
        "minimiser"
    }

    fn record(
        &mut self,
        (buffers, status): Self::Data<'_>,
        frame: &mut FrameData,
    ) -> Result<(), SimError> {
        let residual = buffers.evaluation.largest_force();
        frame.column("force_residual", residual);
        frame.column("energy_change", status.energy_change.unwrap_or(f64::NAN));
        Ok(())
    }
}

/// The contact curvature of the membrane on one adhesive substrate: the
/// fit of [`crate::analysis::contact_curvature`] over the vertices above
/// the substrate's range ρ with a tilt up to
/// [`MAX_TILT`](crate::analysis::contact_curvature::MAX_TILT). NaN when
/// there is no contact line to fit.
pub struct ContactCurvatureColumn {
    params: crate::energy::adhesion::AdhesionParams,
    column: String,
}

impl ContactCurvatureColumn {
    /// The column of the substrate `params` (at the scene's resolution).
    pub fn new(params: crate::energy::adhesion::AdhesionParams) -> Self {
        let column = format!("{}_contact_curvature", params.name);
        Self { params, column }
    }
}

impl Recorder for ContactCurvatureColumn {
    type Data<'a> = (Res<'a, Membrane>, Res<'a, DensePositions>);

    fn name(&self) -> &str {
        &self.column
    }

    fn record(
        &mut self,
        (membrane, positions): Self::Data<'_>,
        frame: &mut FrameData,
    ) -> Result<(), SimError> {
        use crate::analysis::contact_curvature::{MAX_TILT, contact_curvature};
        let faces = &membrane.cached_topology().faces;
        let p = &self.params;
        let fit = contact_curvature(&positions.0, faces, &p.shape, p.range, MAX_TILT);
        frame.column(self.column.clone(), fit.map_or(f64::NAN, |f| f.curvature));
        Ok(())
    }
}
