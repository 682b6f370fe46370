//! Parameters of the energy terms: one serde struct per term, each field
//! with its unit, default and meaning. Defaults are SPEC's as-run set
//! (natural units: energy Ē = 10 k_BT, length l̄ = 1 µm, time 1 s).

use serde::{Deserialize, Serialize};

pub use crate::energy::vin::{VinForm, VinParams};

/// A target value: absolute, or a fraction of the initial mesh's value.
/// Either number must be finite and > 0.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "TargetSpec")]
pub enum Target {
    /// An absolute value (l̄³ for volume, l̄² for area).
    Absolute(f64),
    /// This fraction of the value of the initial mesh (e.g. 0.6 of its volume).
    OfInitial(f64),
}

/// Unvalidated form of [`Target`] as written in a scene.
#[derive(Deserialize)]
enum TargetSpec {
    Absolute(f64),
    OfInitial(f64),
}

impl TryFrom<TargetSpec> for Target {
    type Error = String;
    fn try_from(spec: TargetSpec) -> Result<Self, String> {
        let (t, v) = match spec {
            TargetSpec::Absolute(v) => (Target::Absolute(v), v),
            TargetSpec::OfInitial(v) => (Target::OfInitial(v), v),
        };
        if v.is_finite() && v > 0.0 {
            Ok(t)
        } else {
            Err(format!("target must be a finite number > 0 (got {v})"))
        }
    }
}

impl Target {
    /// The target for an initial value `initial`.
    pub fn resolve(self, initial: f64) -> f64 {
        match self {
            Target::Absolute(v) => v,
            Target::OfInitial(f) => f * initial,
        }
    }

    /// The configured number (value or fraction).
    pub fn number(self) -> f64 {
        match self {
            Target::Absolute(v) | Target::OfInitial(v) => v,
        }
    }
}

/// Helfrich bending.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct BendingParams {
    /// κ, bending modulus (Ē; default 5 as run = 50 k_BT; paper table: 1).
    #[serde(deserialize_with = "crate::util::validate::non_negative")]
    pub kappa: f64,
    /// C0, spontaneous curvature (1/l̄; default 0). Enters as (2H − C0)², so a
    /// sphere of radius 2/C0 is stress-free.
    #[serde(deserialize_with = "crate::util::validate::finite")]
    pub c0: f64,
    /// How the mean curvature is discretised (default `Cotangent`, the
    /// paper's).
    #[serde(skip_serializing_if = "BendingDiscretisation::is_cotangent")]
    pub discretisation: BendingDiscretisation,
}

impl Default for BendingParams {
    fn default() -> Self {
        Self {
            kappa: 5.0,
            c0: 0.0,
            discretisation: BendingDiscretisation::Cotangent,
        }
    }
}

/// The discrete mean curvature of the bending energy. Both converge to the
/// Helfrich energy as O(h²); on the same mesh they differ in the constant.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum BendingDiscretisation {
    /// The paper's: the cotangent Laplacian over mixed Voronoi areas,
    /// h_i = |L_i| / (2A_i) signed by the vertex normal
    /// ([`crate::energy::bending`]). Reads low on coarse meshes (about
    /// 1-2.4 % at 640 vertices on the shape diagram's branches).
    #[default]
    Cotangent,
    /// Jülicher's edge form: h_i = ½ Σ_{e∋i} ℓ_e θ_e / A_i with the
    /// signed dihedral angles θ_e and barycentric areas A_i
    /// ([`crate::energy::bending_dihedral`]). Within 0.3 % of the continuum
    /// on the same meshes.
    Dihedral,
}

impl BendingDiscretisation {
    /// Whether this is the paper's (the default, left out when written).
    pub fn is_cotangent(&self) -> bool {
        *self == BendingDiscretisation::Cotangent
    }
}

/// Volume penalty E_V = k (V − V_t)² / V_t (osmotic pressure).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct VolumeParams {
    /// k_V, penalty strength (Ē/l̄³; default 4).
    #[serde(
        default = "default_k_volume",
        deserialize_with = "crate::util::validate::non_negative"
    )]
    pub k: f64,
    /// V_t, target volume (l̄³ or fraction of the initial volume).
    pub target: Target,
}

/// Area penalty E_A = k (A − A_t)² / A_t (global tension).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AreaParams {
    /// k_A, penalty strength (Ē/l̄²; default 8).
    #[serde(
        default = "default_k_area",
        deserialize_with = "crate::util::validate::non_negative"
    )]
    pub k: f64,
    /// A_t, target area (l̄² or fraction of the initial area).
    pub target: Target,
}

/// Constant surface tension E_σ = σ A: the membrane exchanges area with a
/// reservoir at tension σ (tether pulling; no target area).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TensionParams {
    /// σ, surface tension (Ē/l̄² = 10 k_BT/µm²; ≥ 0). A tube pulled from
    /// such a membrane has radius √(κ/2σ) and force 2π√(2σκ).
    #[serde(deserialize_with = "crate::util::validate::non_negative")]
    pub sigma: f64,
}

/// Density-dependent local tension E_a = k Σ_i (A_i/ρ_i − a0)² / a0 with
/// a0 = A_t / N_initial. Requires lipid density.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LocalTensionParams {
    /// k_a, strength (Ē/l̄²; default 12).
    #[serde(
        default = "default_k_local",
        deserialize_with = "crate::util::validate::non_negative"
    )]
    pub k: f64,
    /// A_t, total target area from which a0 = A_t / N_initial (l̄² or
    /// fraction of the initial area; the reservoir condition uses 733).
    pub target_area: Target,
}

/// Self-avoidance: a repulsion k(d0 − r)³/(3 d0) between vertices that are
/// not 1-ring neighbours and closer than d0.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SelfAvoidanceParams {
    /// k, stiffness of the repulsion (Ē/l̄²; default 500: at an overlap of
    /// 0.1 l̄ the pair energy is 0.28 Ē and the force 8.3 Ē/l̄; two vertices
    /// on top of each other cost 60 Ē).
    #[serde(deserialize_with = "crate::util::validate::positive")]
    pub k: f64,
    /// d0, range of the repulsion (l̄; default 0.6: below the shortest edge
    /// the remesher lets live, 0.7, so no healthy mesh feels it between
    /// non-neighbours of its own patch).
    #[serde(deserialize_with = "crate::util::validate::positive")]
    pub distance: f64,
}

impl Default for SelfAvoidanceParams {
    fn default() -> Self {
        Self {
            k: 500.0,
            distance: 0.6,
        }
    }
}

/// External springs from control points to their nearest vertex and 1-ring.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SpringParams {
    /// k_ex, spring constant of control points that give none (Ē/l̄²;
    /// default 4 as run; 5 in the tether scenes).
    #[serde(deserialize_with = "crate::util::validate::non_negative")]
    pub stiffness: f64,
    /// How a control point's pull is shared over the attached patch.
    pub coupling: SpringCoupling,
}

impl Default for SpringParams {
    fn default() -> Self {
        Self {
            stiffness: 4.0,
            coupling: SpringCoupling::OneRing,
        }
    }
}

/// How a control point c pulls the membrane: the patch P = {i} ∪ 1-ring(i)
/// of its nearest vertex i (n = |P| vertices, centroid x̄), or a smooth
/// patch of physical radius.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub enum SpringCoupling {
    /// As run (SPEC §2): every patch vertex j is pulled toward c itself,
    /// F_j = k (c − x_j), E = ½k Σ_j |c − x_j|². By the parallel-axis
    /// theorem E = ½k n |c − x̄|² + ½k Σ_j |x_j − x̄|²: besides the net pull
    /// it squeezes the patch toward its centroid, ½k·(1 l̄)² = 2 Ē per ring
    /// vertex at k = 4 Ē/l̄², 20× the V_in barrier (0.1 Ē), and keeps
    /// merging the ring edges around every holder.
    #[default]
    OneRing,
    /// The same net force on the patch without the squeeze: the centroid is
    /// tied to c, E = ½k n |c − x̄|², F_j = k (c − x̄) for every j in P.
    Centroid,
    /// A smooth patch of physical size (the fluid model's coupling): the
    /// weighted centroid x̄ = Σ g_j x_j / Σ g_j of the vertices within 3a of
    /// c, with g_j = exp(−r_j²/2a²) − exp(−9/2)·(11/2 − r_j²/2a²) (r_j =
    /// |x_j − c|: the Gaussian less its tangent in r² at the cut-off, so
    /// weight and gradient both vanish there), is tied to c: E = ½k|c − x̄|², k the point's whole
    /// stiffness (not per vertex). The weights follow the vertices, so a
    /// remesh event near c changes the pull continuously, and the force is
    /// the exact gradient (weights included). With no vertex within 3a the
    /// nearest vertex alone is tied to c. In the fluid model only the
    /// forces' components along the vertex normals act: a fluid membrane
    /// at uniform tension holds no tangential point load.
    Gaussian {
        /// Patch radius a (l̄; 1-1.5 mean edge lengths resolve it).
        #[serde(deserialize_with = "crate::util::validate::positive")]
        radius: f64,
    },
}

fn default_k_volume() -> f64 {
    4.0
}
fn default_k_area() -> f64 {
    8.0
}
fn default_k_local() -> f64 {
    12.0
}

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

fn default_max_correction() -> f64 {
    0.02
}

fn default_constraint_smoothing() -> u32 {
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
enum VolumeConstraintSpec {
    Absolute(f64),
    OfInitial(f64),
    Reduced(f64),
}

impl TryFrom<VolumeConstraintSpec> for VolumeConstraint {
    type Error = String;
    fn try_from(spec: VolumeConstraintSpec) -> Result<Self, String> {
        match spec {
            VolumeConstraintSpec::Absolute(v) | VolumeConstraintSpec::OfInitial(v)
                if !(v.is_finite() && v > 0.0) =>
            {
                Err(format!("target must be a finite number > 0 (got {v})"))
            }
            VolumeConstraintSpec::Reduced(v) if !(v > 0.0 && v <= 1.0) => {
                Err(format!("a reduced volume must be in (0, 1] (got {v})"))
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

/// Edge flips as Metropolis moves ([`crate::remesh::flip`]): after every tick,
/// edges drawn at random are flipped with probability min(1, exp(−ΔE/k_BT)),
/// so the triangulation is fluid and the membrane samples the Boltzmann
/// ensemble of its energy (at k_BT = 0 only flips that lower the energy are
/// taken).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EdgeFlipParams {
    /// Flip proposals per edge per tick (dimensionless, e.g. 0.01: each edge
    /// is proposed once every 100 ticks on average). Any rate keeps the
    /// ensemble; it sets how fast the triangulation (the membrane's
    /// in-plane structure) relaxes, and costs about 1 µs per proposal.
    #[serde(deserialize_with = "crate::util::validate::positive")]
    pub attempts_per_edge: f64,
    /// Both the edge removed and the edge created must lie in this range
    /// (l̄; default (0.7, 1.3), the remesh triggers' normal range). V_in has
    /// a second well beyond its far barrier (1.75-2.2 l̄, as low as the
    /// normal one), so without this bound a flip could create an edge there,
    /// between two of V_in's steepest walls. Required both ways, so the
    /// reverse flip is allowed exactly when this one is.
    #[serde(default = "default_flip_range")]
    pub edge_range: (f64, f64),
}

fn default_flip_range() -> (f64, f64) {
    (0.7, 1.3)
}

/// Which remeshing runs.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum RemeshMode {
    /// No remeshing: barrier crossings are only detected and counted.
    #[default]
    Off,
    /// The paper's free-energy-controlled split/merge (V_in acts globally).
    FreeEnergy,
    /// Geometry-based baseline: the same triggers and relaxation, but V_in
    /// exerts no force in the global dynamics (still sets Δt and relaxes).
    Geometric,
}

/// Barrier-crossing remeshing (SPEC §4). Defaults are the as-run values.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RemeshParams {
    /// Off (default), FreeEnergy or Geometric.
    pub mode: RemeshMode,
    /// l_−: an edge shorter than this crossed the near barrier (l̄; default 0.7).
    #[serde(deserialize_with = "crate::util::validate::positive")]
    pub shorter_than: f64,
    /// l_+: an edge longer than this crossed the far barrier (l̄; default 1.3).
    #[serde(deserialize_with = "crate::util::validate::positive")]
    pub longer_than: f64,
    /// l_++: a split's pre-relaxation succeeds once the edge is longer (l̄;
    /// default 1.8 as run; paper 1.7).
    #[serde(deserialize_with = "crate::util::validate::positive")]
    pub split_done: f64,
    /// L_−: a merge's pre-relaxation succeeds once the edge is shorter (l̄;
    /// default 0.05 as run; paper 0.1).
    #[serde(deserialize_with = "crate::util::validate::positive")]
    pub merge_done: f64,
    /// Range the other patch edges must lie in during relaxation (l̄;
    /// default (0.8, 1.2) as run).
    pub normal_range: (f64, f64),
    /// D, scale of the Lévy kicks (Ē/l̄; default 10).
    #[serde(deserialize_with = "crate::util::validate::positive")]
    pub kick_scale: f64,
    /// Iteration cap of one local relaxation (default 5000; in the
    /// filopodium scene successful pre-relaxations took a median of 725
    /// iterations, 99 % under 6500; a failed 1-ring relaxation is retried
    /// once with a 2-ring patch).
    pub relax_iterations: u32,
    /// Most remesh events per tick; abnormal edges left over are counted as
    /// an overflow and retried next tick (default 64).
    pub max_events_per_tick: u32,
}

impl Default for RemeshParams {
    fn default() -> Self {
        Self {
            mode: RemeshMode::Off,
            shorter_than: 0.7,
            longer_than: 1.3,
            split_done: 1.8,
            merge_done: 0.05,
            normal_range: (0.8, 1.2),
            kick_scale: 10.0,
            relax_iterations: 5000,
            max_events_per_tick: 64,
        }
    }
}

/// How fast lipid density equilibrates over edges.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum DiffusionRate {
    /// k_d per sweep (dimensionless fraction, 0 < k_d ≤ 1; paper 0.025-0.25).
    Finite(f64),
    /// k_d = ∞: uniform density Σρ / N after every remesh.
    Instant,
}

/// A region whose vertices block diffusion on their edges.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum BlockedRegion {
    /// The tether barrier: blocked where |x| < `half_width` and
    /// |y| / |r| > `gap` (r measured from the origin; 1.5 and 0.1 in the
    /// paper, leaving ≈ 6 % of the barrier permeable near y = 0).
    Slab {
        /// Half width of the slab around x = 0 (l̄).
        half_width: f64,
        /// Open gap: vertices with |y| ≤ gap·|r| stay permeable (0..1).
        gap: f64,
    },
}

/// Lipid diffusion (SPEC §5); needs `lipid_density: true`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DiffusionParams {
    /// k_d: Finite(k) or Instant.
    pub rate: DiffusionRate,
    /// n_d, synchronous sweeps after every tick whose remeshing was
    /// triggered (default 50).
    #[serde(default = "default_sweeps")]
    pub sweeps: u32,
    /// Regions whose vertices block diffusion (default none).
    #[serde(default)]
    pub barrier: Vec<BlockedRegion>,
}

fn default_sweeps() -> u32 {
    50
}

/// The membrane model (SPEC §8): what the mesh-maintenance forces act on.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum MembraneModel {
    /// The paper's model: V_in acts on every degree of freedom, so on a
    /// fixed connectivity the mesh is a pre-stressed spring network with a
    /// shear modulus (an elastic shell).
    #[default]
    Paper,
    /// A two-dimensional fluid: the forces of mesh-maintenance terms
    /// ([`crate::engine::force::ForceKind::Maintenance`], V_in) are projected onto
    /// the vertices' tangent planes, and so are the local relaxations and
    /// kicks of remesh events. V_in then keeps the triangles regular without
    /// acting on the shape, which only the physical terms move (bending,
    /// tension, pressure or volume, area, plugins): no shear modulus.
    Fluid(FluidParams),
}

impl MembraneModel {
    /// Whether this is the fluid model.
    pub fn is_fluid(&self) -> bool {
        matches!(self, MembraneModel::Fluid(_))
    }

    /// Whether remesh events edit directly (the fluid model with
    /// [`FluidEdits::Direct`]).
    pub fn direct_edits(&self) -> bool {
        matches!(
            self,
            MembraneModel::Fluid(FluidParams {
                edits: FluidEdits::Direct,
                ..
            })
        )
    }
}

/// Settings of the fluid model. The vertex normal of the projection is the
/// area-weighted one, n_i ∝ Σ_f∋i A_f n_f ∝ ∇_i V, so tangential moves keep
/// the enclosed volume to first order; it has no setting.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct FluidParams {
    /// How a remesh event edits the mesh (default `Relaxed`, the paper's
    /// event made tangential).
    pub edits: FluidEdits,
    /// Delaunay flips as mesh maintenance (default: none). A fluid flows in
    /// its plane; without flips an elongation stretches the triangles until
    /// splits and merges cannot follow (see `systems/maintenance_flips.rs`).
    pub flips: Option<MaintenanceFlipParams>,
    /// Which components of the physical terms' forces act (default `Full`).
    #[serde(skip_serializing_if = "PhysicalForces::is_full")]
    pub physical_forces: PhysicalForces,
}

/// Which components of the physical terms' forces (bending, tension,
/// area and volume penalties, plugins) act in the fluid model.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum PhysicalForces {
    /// The whole gradient of the discrete energy.
    #[default]
    Full,
    /// Only the component along each vertex's area-weighted normal, as in
    /// Mem3DG, less the net force that leaves (a rigid translation). The continuum's shape derivative of an energy that does not
    /// depend on the parametrisation has no tangential part; the discrete
    /// energy's tangential gradient only slides vertices along the surface,
    /// against the mesh maintenance. Measured with the dihedral bending on
    /// the stomatocyte at 642 vertices: with `Full` its neck fires remesh
    /// events without end (981 splits and 900 merges in 20 000 iterations,
    /// E_b/8πκ +1.9 % to +23 %), with `Normal` 47 splits and 14 merges and
    /// +0.27 %. The forces are then no longer a gradient: use it with the
    /// minimiser (FIRE needs no gradient) or dynamics, not with the
    /// paper's energy-based flips.
    Normal,
}

impl PhysicalForces {
    /// Whether this is the default (left out when written).
    pub fn is_full(&self) -> bool {
        *self == PhysicalForces::Full
    }
}

/// Delaunay flips as mesh maintenance in the fluid model.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MaintenanceFlipParams {
    /// Largest angle between the normals of an edge's two faces at which
    /// the edge may be flipped (degrees; default 20): the flip moves the
    /// surface by the tetrahedron between the four corners.
    #[serde(
        default = "default_max_dihedral",
        deserialize_with = "crate::util::validate::positive"
    )]
    pub max_dihedral: f64,
    /// Iterations between sweeps over the edges (default 1). Every flip is
    /// a topology change, after which the minimiser restarts from rest.
    #[serde(default = "default_flip_every")]
    pub every: u32,
}

fn default_max_dihedral() -> f64 {
    20.0
}

fn default_flip_every() -> u32 {
    1
}

/// How a split or merge is carried out in the fluid model.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum FluidEdits {
    /// The paper's event, every move tangential: the patch is first relaxed
    /// under V_in and Lévy kicks until the edge crosses l_++ (split) or L_−
    /// (merge), then edited, then the new vertex's 1-ring relaxes into the
    /// normal range.
    #[default]
    Relaxed,
    /// The edit is applied at once, without the free-energy pre-relaxation,
    /// and the new vertex's 1-ring then relaxes tangentially into the normal
    /// range. In the fluid model V_in only keeps triangles regular, so the
    /// barrier crossing it guards has no physical meaning; the pre-relaxation
    /// fails where a region is stretched as a whole (every neighbour long at
    /// once: 647 failed splits in 90 iterations on the 2562-vertex prolate,
    /// none with direct edits). Needs `remesh.longer_than` > 2 ×
    /// `remesh.shorter_than`, so that a split's halves are never merged
    /// again (without that gap, split and merge ping-pong).
    Direct,
}
