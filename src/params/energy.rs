//! Parameters of the built-in energy terms.

use super::*;

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

pub(super) fn default_k_volume() -> f64 {
    4.0
}
pub(super) fn default_k_area() -> f64 {
    8.0
}
pub(super) fn default_k_local() -> f64 {
    12.0
}
