//! Exact area and volume constraints (SPEC §8): the kernels behind the
//! `constraint_reactions` and `constraint_projection` systems.
//!
//! With constraints A(x) = A_t and V(x) = V_t the membrane is in equilibrium
//! when −∇E = σ∇A − Δp∇V, the Lagrange multipliers being the tension σ
//! (Ē/l̄²) and the pressure difference Δp = p_in − p_out (Ē/l̄³). Given the
//! force F = −∇E of every term, [`remove_reactions`] finds the (σ, Δp) that
//! minimise |F − σ∇A + Δp∇V| (least squares over all vertices) and leaves
//! F tangent to the constraint surface: what is left moves the shape
//! without changing A or V to first order, and vanishes at equilibrium.
//! A sphere under a tension term σ₀ with its volume held gives
//! Δp = σ₀·|∇A|/|∇V| = 2σ₀/R (Laplace).
//!
//! [`project`] then returns the positions to the constraint surface after a
//! step, by Gauss-Newton steps Δx = λ_A∇A + λ_V∇V (the shortest move that
//! corrects A and V to first order).

use glam::DVec3;

/// The targets held (l̄², l̄³); `None` is not constrained.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ConstraintTargets {
    /// Total area A_t (l̄²).
    pub area: Option<f64>,
    /// Enclosed volume V_t (l̄³).
    pub volume: Option<f64>,
}

/// Area, volume and their gradients at a set of positions.
#[derive(Clone, Debug, Default)]
pub struct Gradients {
    /// Total area (l̄²).
    pub area: f64,
    /// Enclosed volume (l̄³).
    pub volume: f64,
    /// ∂A/∂x_i by vertex slot (l̄).
    pub area_gradient: Vec<DVec3>,
    /// ∂V/∂x_i by vertex slot (l̄²).
    pub volume_gradient: Vec<DVec3>,
}

impl Gradients {
    /// Measures A, V, ∇A and ∇V at `positions` (one pass over the faces, in
    /// face order). The volume is summed against `positions[0]`, as
    /// everywhere else in the engine.
    pub fn measure(&mut self, positions: &[DVec3], faces: &[[u32; 3]]) {
        let n = positions.len();
        self.area_gradient.clear();
        self.area_gradient.resize(n, DVec3::ZERO);
        self.volume_gradient.clear();
        self.volume_gradient.resize(n, DVec3::ZERO);
        let origin = positions.first().copied().unwrap_or(DVec3::ZERO);
        let (mut twice_area, mut six_volume) = (0.0, 0.0);
        for f in faces {
            let [i0, i1, i2] = f.map(|v| v as usize);
            let (a, b, c) = (positions[i0], positions[i1], positions[i2]);
            let normal = (b - a).cross(c - a);
            let double = normal.length();
            twice_area += double;
            if double > 0.0 {
                let n_hat = normal / double;
                let g = crate::geometry::face_area_gradient(&[a, b, c], n_hat);
                self.area_gradient[i0] += g[0];
                self.area_gradient[i1] += g[1];
                self.area_gradient[i2] += g[2];
            }
            let (ra, rb, rc) = (a - origin, b - origin, c - origin);
            six_volume += ra.dot(rb.cross(rc));
            self.volume_gradient[i0] += rb.cross(rc) / 6.0;
            self.volume_gradient[i1] += rc.cross(ra) / 6.0;
            self.volume_gradient[i2] += ra.cross(rb) / 6.0;
        }
        self.area = 0.5 * twice_area;
        self.volume = six_volume / 6.0;
    }
}

/// The multipliers of one evaluation.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Reactions {
    /// σ, the tension that holds the area (Ē/l̄²; 0 without an area
    /// constraint).
    pub tension: f64,
    /// Δp = p_in − p_out, the pressure that holds the volume (Ē/l̄³; 0
    /// without a volume constraint).
    pub pressure: f64,
}

fn dot(a: &[DVec3], b: &[DVec3]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x.dot(*y)).sum()
}

/// Solves the normal equations of the active constraints for the
/// coefficients c of Δ = c_A g_A + c_V g_V with g·Δ = r, scaled to unit
/// gradients so that the 2×2 solve is well conditioned; a nearly
/// degenerate pair (a sphere, where ∇A ∥ ∇V) is regularised (Tikhonov,
/// 1e-12 of the diagonal), which gives the least-norm compromise.
fn solve(g: &Gradients, t: ConstraintTargets, r: [f64; 2]) -> [f64; 2] {
    let (ga, gv) = (&g.area_gradient, &g.volume_gradient);
    match (t.area.is_some(), t.volume.is_some()) {
        (false, false) => [0.0, 0.0],
        (true, false) => [r[0] / dot(ga, ga).max(f64::MIN_POSITIVE), 0.0],
        (false, true) => [0.0, r[1] / dot(gv, gv).max(f64::MIN_POSITIVE)],
        (true, true) => {
            let (na, nv) = (dot(ga, ga).sqrt(), dot(gv, gv).sqrt());
            if na == 0.0 || nv == 0.0 {
                return [0.0, 0.0];
            }
            let rho = dot(ga, gv) / (na * nv);
            let (d, b) = (1.0 + 1e-12, [r[0] / na, r[1] / nv]);
            let det = d * d - rho * rho;
            let y = [(d * b[0] - rho * b[1]) / det, (d * b[1] - rho * b[0]) / det];
            [y[0] / na, y[1] / nv]
        }
    }
}

/// Removes the constraints' reactions from `force` (Ē/l̄, by vertex slot):
/// afterwards `force` is orthogonal to ∇A and ∇V of the active targets.
/// Returns the multipliers (see the module documentation for the signs).
pub fn remove_reactions(g: &Gradients, t: ConstraintTargets, force: &mut [DVec3]) -> Reactions {
    let r = [dot(&g.area_gradient, force), dot(&g.volume_gradient, force)];
    let c = solve(g, t, r);
    for (i, f) in force.iter_mut().enumerate() {
        *f -= c[0] * g.area_gradient[i] + c[1] * g.volume_gradient[i];
    }
    Reactions {
        tension: c[0],
        pressure: -c[1],
    }
}

/// The constraints as one force evaluation saw them.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ConstraintState {
    /// The targets held.
    pub targets: ConstraintTargets,
    /// Area at the evaluation (l̄²).
    pub area: f64,
    /// Volume at the evaluation (l̄³).
    pub volume: f64,
    /// The multipliers removed from the force.
    pub reactions: Reactions,
}

impl ConstraintState {
    /// The largest relative violation |value − target| / target of the
    /// active constraints (0 when none is active).
    pub fn violation(&self) -> f64 {
        let rel = |value: f64, target: Option<f64>| target.map_or(0.0, |t| ((value - t) / t).abs());
        rel(self.area, self.targets.area).max(rel(self.volume, self.targets.volume))
    }
}

/// What one projection did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Projection {
    /// Gauss-Newton steps taken.
    pub steps: u32,
    /// Whether a step was scaled down to the largest correction (the
    /// target is still being approached).
    pub limited: bool,
}

/// Relative violation below which [`project`] stops.
const PROJECTION_TOLERANCE: f64 = 1e-13;
/// Most Gauss-Newton steps of one projection.
const PROJECTION_STEPS: u32 = 8;

/// Moves `positions` onto A = A_t, V = V_t by Gauss-Newton steps along ∇A
/// and ∇V, none moving a vertex by more than `max_correction` (l̄): a
/// target farther away is approached by one scaled step per call.
/// `scratch` holds the gradients.
pub fn project(
    positions: &mut [DVec3],
    faces: &[[u32; 3]],
    t: ConstraintTargets,
    max_correction: f64,
    scratch: &mut Gradients,
) -> Projection {
    let mut out = Projection::default();
    for _ in 0..PROJECTION_STEPS {
        scratch.measure(positions, faces);
        let r = [
            t.area.map_or(0.0, |a| a - scratch.area),
            t.volume.map_or(0.0, |v| v - scratch.volume),
        ];
        let held = |r: f64, target: Option<f64>| {
            target.is_none_or(|x| r.abs() <= PROJECTION_TOLERANCE * x.abs())
        };
        if held(r[0], t.area) && held(r[1], t.volume) {
            break;
        }
        let c = solve(scratch, t, r);
        let (ga, gv) = (&scratch.area_gradient, &scratch.volume_gradient);
        let largest = (0..positions.len())
            .map(|i| (c[0] * ga[i] + c[1] * gv[i]).length())
            .fold(0.0, f64::max);
        let scale = if largest > max_correction {
            out.limited = true;
            max_correction / largest
        } else {
            1.0
        };
        for (i, p) in positions.iter_mut().enumerate() {
            *p += scale * (c[0] * ga[i] + c[1] * gv[i]);
        }
        out.steps += 1;
        if out.limited {
            break;
        }
    }
    out
}

/// The scene's exact constraints, resolved against the initial mesh (a
/// resource inserted by the constraints plugin).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Constraints {
    /// The targets held.
    pub targets: ConstraintTargets,
    /// Largest displacement of any vertex by one tick's projection (l̄).
    pub max_correction: f64,
}
