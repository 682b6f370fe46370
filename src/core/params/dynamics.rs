//! How a run moves the membrane: overdamped dynamics or the minimiser, and
//! the exact constraints.

use super::*;

/// Overdamped Langevin dynamics and run length.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct DynamicsParams {
    /// μ, vertex mobility (l̄²/(Ē·s); default 1000 as run; paper table: 100).
    #[serde(deserialize_with = "crate::util::validate::positive")]
    pub mobility: f64,
    /// k_BT of the thermal noise (Ē; default 0 as run; 0.1 = 300 K).
    #[serde(deserialize_with = "crate::util::validate::non_negative")]
    pub temperature: f64,
    /// dt_max, cap of the adaptive time step (s; default 0.005).
    #[serde(deserialize_with = "crate::util::validate::positive")]
    pub dt_max: f64,
    /// s_max, largest displacement μ|F|Δt of any vertex per step (l̄;
    /// default 10, i.e. effectively off, as run; tether phases use 0.01).
    #[serde(deserialize_with = "crate::util::validate::positive")]
    pub max_displacement: f64,
    /// Number of iterations (accepted ticks) of a run (default 1000).
    pub iterations: u64,
    /// Number of frames written over a run, evenly spaced, plus the initial
    /// state (default 20; 0 = initial and final only).
    pub frames: u32,
    /// Stop once this much time has been simulated, even before
    /// `iterations` (s; default none).
    #[serde(deserialize_with = "crate::util::validate::optional_positive")]
    pub duration: Option<f64>,
    /// Write a frame whenever the simulated time passes a multiple of this
    /// interval, instead of `frames` evenly spaced iterations (s; default
    /// none).
    #[serde(deserialize_with = "crate::util::validate::optional_positive")]
    pub frame_time: Option<f64>,
    /// In a scene with bending and without V_in, keep the explicit step
    /// below the stability bound of the stiffest bending mode,
    /// Δt ≤ [`crate::timestep::BENDING_STABILITY`]·l_min²/(μκ), so that no
    /// hand-picked `max_displacement` is needed (default true). V_in's
    /// edge rule limits the step where V_in is declared; this bound then
    /// does not apply.
    pub bending_step_limit: bool,
    /// Keep V_in's edge rule (SPEC §3): no edge's drift crosses more than
    /// one segment of the V_in segmentation per step (default true, as run).
    /// With thermal noise whose step sqrt(2μk_BTΔt) is far longer than a
    /// segment (10⁻³ l̄ on the barriers' flanks), the rule no longer controls
    /// barrier crossings and only shrinks Δt (to 10⁻⁸ s for V_in barriers of
    /// 10 k_BT); a noisy scene may turn it off. Δt is then `dt_max`, bounded
    /// by `max_displacement` and, where `bending_step_limit` is on, by the
    /// explicit bending step's stability bound.
    pub vin_step_limit: bool,
    /// How each iteration moves the membrane: `Overdamped` (default, the
    /// paper's dynamics) or `Minimise(...)`, a FIRE energy minimiser that
    /// stops at equilibrium ([`Method`]).
    pub method: Method,
}

/// How each iteration moves the membrane.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub enum Method {
    /// Overdamped Langevin dynamics with the adaptive step (SPEC §3): a
    /// trajectory in physical time.
    #[default]
    Overdamped,
    /// Energy minimisation with FIRE (Bitzek et al. 2006, with the
    /// corrections of Guénolé et al. 2020): inertial steps of fictitious
    /// time whose velocity is mixed toward the force and zeroed whenever it
    /// runs uphill. Needs only forces, so it also relaxes force fields that
    /// are not exact gradients (projected or smoothed ones). Remeshing and
    /// flips run between its steps; after a topology change it restarts.
    /// The run ends when a convergence criterion holds or at `iterations`.
    Minimise(MinimiserParams),
}

impl Method {
    /// Whether this is the default overdamped dynamics.
    pub fn is_overdamped(&self) -> bool {
        matches!(self, Method::Overdamped)
    }
}

/// FIRE minimiser settings and convergence criteria (units: Ē = 10 k_BT,
/// l̄ = 1 µm; the step is fictitious time with unit vertex mass).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct MinimiserParams {
    /// Converged when the largest force on any vertex (after the
    /// constraints' reactions are removed) is below this and every
    /// constraint holds (Ē/l̄; default 1e-3).
    #[serde(deserialize_with = "crate::util::validate::positive")]
    pub force_tolerance: f64,
    /// ... or when the total energy changed by less than this fraction of
    /// itself over the last `energy_window` iterations and every constraint
    /// holds (dimensionless; default 1e-9; 0 turns the criterion off).
    #[serde(deserialize_with = "crate::util::validate::non_negative")]
    pub energy_tolerance: f64,
    /// Iterations over which the energy change is measured; it restarts
    /// after every remesh event or flip (default 200).
    pub energy_window: u32,
    /// A constraint holds when |value − target| ≤ this × target
    /// (dimensionless; default 1e-7).
    #[serde(deserialize_with = "crate::util::validate::positive")]
    pub constraint_tolerance: f64,
    /// Largest displacement of any vertex in one iteration (l̄; default
    /// 0.02): steps are scaled down to it.
    #[serde(deserialize_with = "crate::util::validate::positive")]
    pub max_step: f64,
    /// FIRE's first step, also after each restart (fictitious time with
    /// unit vertex mass; default 0.02).
    #[serde(deserialize_with = "crate::util::validate::positive")]
    pub dt_start: f64,
    /// FIRE's largest step (default 0.2).
    #[serde(deserialize_with = "crate::util::validate::positive")]
    pub dt_max: f64,
    /// The metric in which FIRE steps: `None` (default: along the force
    /// itself) or `Sobolev(...)`, along P⁻¹F with P close to the energy's
    /// Hessian, so that the iterations hardly grow with the resolution
    /// ([`Preconditioner`]).
    pub preconditioner: Preconditioner,
    /// An axis (a direction, e.g. `axisymmetric: (0.0, 0.0, 1.0)`) about which an
    /// axisymmetric shape stays axisymmetric: every step is made orthogonal
    /// to the two quadrupolar deformations that break the symmetry
    /// ([`crate::minimise::axial`]), jointly with the constraints. For
    /// branches of axisymmetric equilibria that are saddles among all
    /// shapes (the shape diagram's oblate branch, which the Sobolev
    /// minimiser otherwise leaves for the prolate). The forces and the
    /// convergence criteria are unchanged. Default `None`.
    #[serde(deserialize_with = "crate::util::validate::optional_direction")]
    pub axisymmetric: Option<(f64, f64, f64)>,
    /// With protein species: their fields are relaxed at every iteration
    /// until each vertex's chemical-potential imbalance per area
    /// |∂F/∂φ − μ A/a_p| / A, at the best multipliers, is below this
    /// (Ē/l̄²; default 1e-7). A residual r moves φ by at most
    /// r a_p / (4 k_BT) (the mixing entropy's curvature is at least
    /// 4 k_BT/a_p per area): 1.25e-8 on the red blood cell with one species
    /// (a_p = 0.05, k_BT = 0.1), whose shape force then changes by about
    /// κ c δφ ~ 1e-7 Ē/l̄, four orders below the force tolerance. The fields
    /// then take 1.67 Newton steps per iteration there (1.84 at 1e-9).
    #[serde(deserialize_with = "crate::util::validate::positive")]
    pub field_tolerance: f64,
}

impl Default for MinimiserParams {
    fn default() -> Self {
        Self {
            force_tolerance: 1e-3,
            energy_tolerance: 1e-9,
            energy_window: 200,
            constraint_tolerance: 1e-7,
            max_step: 0.02,
            dt_start: 0.02,
            dt_max: 0.2,
            preconditioner: Preconditioner::None,
            axisymmetric: None,
            field_tolerance: 1e-7,
        }
    }
}

/// The metric of the minimiser's steps.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub enum Preconditioner {
    /// FIRE along the force (the Euclidean metric, unit vertex masses):
    /// iterations grow about as the number of vertices.
    #[default]
    None,
    /// FIRE along P⁻¹F, with the H² (normal) and H¹ (tangential) Sobolev
    /// metric of the cotangent Laplacian, factorised by a sparse Cholesky
    /// ([`crate::minimise::sobolev`]); the constraints are kept in the same
    /// metric. `dt_start` and `dt_max` of the minimiser are replaced by
    /// this variant's (the step is then measured in the metric's units).
    Sobolev(SobolevParams),
}

/// Settings of the Sobolev-preconditioned minimiser.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SobolevParams {
    /// s_n, the scale of the normal (bending) block (Ē; default: the sum
    /// of the scene's bending rigidities κ, 1 without bending).
    #[serde(deserialize_with = "crate::util::validate::optional_positive")]
    pub normal_scale: Option<f64>,
    /// s_t, the scale of the tangential block (Ē/l̄², at edge length 1;
    /// divided by h² at resolution h; default 0.2, V_in's V0 per l̄²).
    /// Measured on the fluid red blood cell's ladder (h = 1, 1/2, 1/4):
    /// 0.15-0.2 converge in 285-550 iterations per rung; at 0.5 and above
    /// the tangential relaxation lags the shape, the mesh is remeshed and
    /// the finest rung takes thousands.
    #[serde(deserialize_with = "crate::util::validate::positive")]
    pub tangential_scale: f64,
    /// The factor is rebuilt at the current positions every this many
    /// iterations, and after every topology change (default 20).
    pub rebuild_every: u32,
    /// FIRE's first step in the metric (default 0.1).
    #[serde(deserialize_with = "crate::util::validate::positive")]
    pub dt_start: f64,
    /// FIRE's largest step in the metric (default 0.1). Above about 0.17
    /// the fluid model's last phase at 40962 vertices turns uphill every
    /// few tens of iterations (a mode the metric leaves stiff grows, FIRE
    /// zeroes its velocity and halves the step). Measured
    /// (benches/RESULTS.md, 2026-12-08), 0.1 against 1: the fluid oblate
    /// (v = 0.8) at 642 and 40962 vertices in 248 and 601 iterations
    /// against 215 and 1023, the red blood cell in 388 and 794 against
    /// 475 and 1411, the bundled shape diagram in 17 628 iterations
    /// against 23 363 (every point by the force), the adhered vesicle at
    /// h = 1/4 in 528 and 745 against 2516 and 3204; at 0.2 the 40962-vertex
    /// runs stopped by the energy change, the red blood cell in 2257.
    #[serde(deserialize_with = "crate::util::validate::positive")]
    pub dt_max: f64,
    /// Stiffen the normal patterns of rigid motions in the metric on a
    /// free closed membrane ([`crate::minimise::sobolev`], default false).
    /// Measured (benches/RESULTS.md, 2026-12-07): the fluid red blood cell
    /// at 40962 vertices in 978 iterations instead of 1411, the oblate in
    /// 762 instead of 1023; but the bundled shape diagram's 2562-vertex
    /// stomatocyte then took 1866 iterations instead of 1396 at v = 0.6
    /// and stopped by the energy change at v = 0.55, so it is not the
    /// default. These were with `dt_max` 1; at 0.1 (the default since
    /// 2026-12-08) it no longer pays: the oblate 612 against 601.
    pub rigid_patterns: bool,
}

impl Default for SobolevParams {
    fn default() -> Self {
        Self {
            normal_scale: None,
            tangential_scale: 0.2,
            rebuild_every: 20,
            dt_start: 0.1,
            dt_max: 0.1,
            rigid_patterns: false,
        }
    }
}

/// Exact constraints held by Lagrange multipliers (SPEC §8): the force on
/// the membrane loses its components along ∇A and ∇V (the multipliers are
/// reported as the tension σ and the pressure difference Δp), and after
/// every step the positions are projected back onto the constraint surface
/// by Gauss-Newton steps along ∇A and ∇V.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ConstraintParams {
    /// Total area held exactly (l̄² or fraction of the initial area;
    /// default none).
    #[serde(default)]
    pub area: Option<Target>,
    /// Enclosed volume held exactly (default none).
    #[serde(default)]
    pub volume: Option<VolumeConstraint>,
    /// Largest displacement of any vertex by one tick's projection (l̄;
    /// default 0.02). A target farther away than that (a scene starting
    /// away from its constraint) is approached over several ticks.
    #[serde(
        default = "default_max_correction",
        deserialize_with = "crate::util::validate::positive"
    )]
    pub max_correction: f64,
    /// Passes of 1-ring averaging of the projection's directions ∇A and ∇V
    /// (default 4; 0 = the exact gradients). The targets are reached
    /// exactly either way; smoothing keeps a large correction (a target
    /// approached from afar) from carrying the discrete curvature's
    /// vertex-to-vertex noise into the shape.
    #[serde(default = "default_constraint_smoothing")]
    pub smoothing: u32,
}

pub(super) fn default_max_correction() -> f64 {
    0.02
}

pub(super) fn default_constraint_smoothing() -> u32 {
    4
}

/// The volume a constraint holds.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "VolumeConstraintSpec")]
pub enum VolumeConstraint {
    /// An absolute volume (l̄³).
    Absolute(f64),
    /// This fraction of the initial mesh's volume.
    OfInitial(f64),
    /// The volume of reduced volume v = 6√π V / A^{3/2} at the area
    /// constraint's target (needs `area`; 0 < v ≤ 1).
    Reduced(f64),
}

#[derive(Deserialize)]
pub(super) enum VolumeConstraintSpec {
    Absolute(f64),
    OfInitial(f64),
    Reduced(f64),
}

impl TryFrom<VolumeConstraintSpec> for VolumeConstraint {
    type Error = crate::util::validate::ValidationError;
    fn try_from(spec: VolumeConstraintSpec) -> Result<Self, Self::Error> {
        match spec {
            VolumeConstraintSpec::Absolute(v) | VolumeConstraintSpec::OfInitial(v)
                if !(v.is_finite() && v > 0.0) =>
            {
                Err(format!("target must be a finite number > 0 (got {v})").into())
            }
            VolumeConstraintSpec::Reduced(v) if !(v > 0.0 && v <= 1.0) => {
                Err(format!("a reduced volume must be in (0, 1] (got {v})").into())
            }
            VolumeConstraintSpec::Absolute(v) => Ok(VolumeConstraint::Absolute(v)),
            VolumeConstraintSpec::OfInitial(v) => Ok(VolumeConstraint::OfInitial(v)),
            VolumeConstraintSpec::Reduced(v) => Ok(VolumeConstraint::Reduced(v)),
        }
    }
}

impl ConstraintParams {
    /// The (area, volume) targets for an initial mesh of `initial_area` and
    /// `initial_volume` (l̄², l̄³). A reduced volume needs an area target
    /// (checked when the scene is loaded).
    pub fn targets(&self, initial_area: f64, initial_volume: f64) -> (Option<f64>, Option<f64>) {
        let area = self.area.map(|t| t.resolve(initial_area));
        let volume = self.volume.map(|v| match v {
            VolumeConstraint::Absolute(x) => x,
            VolumeConstraint::OfInitial(f) => f * initial_volume,
            VolumeConstraint::Reduced(r) => {
                let a = area.unwrap_or(initial_area);
                r * a.powf(1.5) / (6.0 * std::f64::consts::PI.sqrt())
            }
        });
        (area, volume)
    }
}

impl Default for DynamicsParams {
    fn default() -> Self {
        Self {
            mobility: 1000.0,
            temperature: 0.0,
            dt_max: 0.005,
            max_displacement: 10.0,
            iterations: 1000,
            frames: 20,
            duration: None,
            frame_time: None,
            bending_step_limit: true,
            vin_step_limit: true,
            method: Method::Overdamped,
        }
    }
}
