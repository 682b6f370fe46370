//! External Hookean springs from fixed control points (SPEC §2): each control
//! point c pulls its nearest vertex i and every 1-ring neighbour j of i with
//! force k (x_c − x_j); energy ½k|x_c − x_j|² summed over all pulled vertices
//! (the as-run coupling), or ties the centroid of that patch to c
//! ([`SpringCoupling::Centroid`]).
//!
//! ## The force term
//!
//! External spring forces from fixed control points.
//!
//! Stage: Forces. Reads: positions, topology (1-rings), [`ControlPoint`]
//! entities. Writes: force accumulator. Units: k_ex in Ē/l̄². Each control
//! point pulls its nearest vertex (re-chosen on every evaluation) and that
//! vertex's 1-ring: each toward the point itself (as run) or, with the
//! centroid coupling, the patch's centroid toward the point.

use crate::engine::force::{FlipProposal, ForceContext, ForceKind, ForceTerm};
use crate::engine::simulation::{Plugin, SimBuilder};
use crate::mesh::cell_list::CellList;
use crate::mesh::components::ControlPoint;
use glam::DVec3;
use serde::{Deserialize, Serialize};

/// Index of the vertex nearest to `point` (ties: lowest index).
pub fn nearest_vertex(positions: &[DVec3], point: DVec3) -> usize {
    crate::mesh::cell_list::nearest_by_scan(positions, point)
}

/// Spring energy; with `force`, adds the spring forces. Each control point
/// attaches to its nearest vertex and its 1-ring, coupled as `coupling`
/// says; `nearest[k]` is point k's nearest vertex ([`nearest_vertex`], or
/// the same answer from a [`crate::mesh::cell_list::CellList`]).
pub fn control_point_springs(
    positions: &[DVec3],
    topology: &crate::mesh::topology::Topology,
    points: &[ControlPoint],
    nearest: &[usize],
    coupling: SpringCoupling,
    mut force: Option<&mut [DVec3]>,
) -> f64 {
    let mut energy = 0.0;
    for (cp, &i) in points.iter().zip(nearest) {
        let patch = || std::iter::once(i as u32).chain(topology.neighbours(i).iter().copied());
        match coupling {
            SpringCoupling::OneRing => {
                for j in patch() {
                    let d = cp.position - positions[j as usize];
                    energy += 0.5 * cp.stiffness * d.length_squared();
                    if let Some(f) = force.as_deref_mut() {
                        f[j as usize] += cp.stiffness * d;
                    }
                }
            }
            SpringCoupling::Gaussian { radius } => {
                let mut patch = Vec::new();
                energy += gaussian_patch(positions, cp, radius, i, &mut patch);
                if let Some(f) = force.as_deref_mut() {
                    for (j, fj) in patch {
                        f[j as usize] += fj;
                    }
                }
            }
            SpringCoupling::Centroid => {
                let n = (topology.valence(i) + 1) as f64;
                let centroid = patch().map(|j| positions[j as usize]).sum::<DVec3>() / n;
                let d = cp.position - centroid;
                energy += 0.5 * cp.stiffness * n * d.length_squared();
                if let Some(f) = force.as_deref_mut() {
                    for j in patch() {
                        f[j as usize] += cp.stiffness * d;
                    }
                }
            }
        }
    }
    energy
}

/// exp(−9/2): the Gaussian's value at the cut-off 3a.
const GAUSSIAN_CUTOFF_WEIGHT: f64 = 0.011_108_996_538_242_306;

/// A patch vertex's weight at squared distance `r2` from the point, and the
/// factor φ with ∇_x g = −φ (x − c): g = e − e_c (11/2 − r²/2a²), e =
/// exp(−r²/2a²), e_c = exp(−9/2). That is the Gaussian less its tangent (in
/// r²) at the cut-off r = 3a, so the weight and its gradient both reach
/// zero there (g ≥ 0: e is convex in r²). Without the tangent the gradient
/// jumped by 3 e_c/a at the cut-off: a vertex hovering there flipped its
/// force by 0.07 Ē/l̄ from step to step and held FIRE in a cycle at its
/// smallest step (the n = 10 tether started at 0.8 r0, commit 65cd623 (2026-12-04)).
#[inline]
fn gaussian_weight(r2: f64, inv_a2: f64) -> (f64, f64) {
    let e = (-0.5 * r2 * inv_a2).exp();
    (
        e - GAUSSIAN_CUTOFF_WEIGHT * (5.5 - 0.5 * r2 * inv_a2),
        (e - GAUSSIAN_CUTOFF_WEIGHT) * inv_a2,
    )
}

/// The smooth-patch coupling ([`SpringCoupling::Gaussian`]) of control
/// point `cp` with patch radius `radius` (a, l̄): writes each patch vertex
/// and its force −∂E/∂x_j into `out` (vertex order) and returns the energy.
/// `nearest` is the vertex nearest to the point, the patch when no vertex
/// lies within 3a.
///
/// With d = c − x̄, G = Σ g, w_j = g_j/G and ∇g_j = −φ_j (x_j − c)
/// (`gaussian_weight`): F_j = k [w_j d + (d·(x_j − x̄)) ∇g_j / G].
pub fn gaussian_patch(
    positions: &[DVec3],
    cp: &ControlPoint,
    radius: f64,
    nearest: usize,
    out: &mut Vec<(u32, DVec3)>,
) -> f64 {
    out.clear();
    let c = cp.position;
    let inv_a2 = 1.0 / (radius * radius);
    let cutoff2 = 9.0 * radius * radius;
    // (vertex, g, ∇g) of the patch.
    let mut patch: Vec<(u32, f64, DVec3)> = Vec::new();
    for (j, &x) in positions.iter().enumerate() {
        let r2 = x.distance_squared(c);
        if r2 < cutoff2 {
            let (g, phi) = gaussian_weight(r2, inv_a2);
            patch.push((j as u32, g, -(x - c) * phi));
        }
    }
    let total: f64 = patch.iter().map(|p| p.1).sum();
    if patch.is_empty() || total <= 0.0 {
        let d = c - positions[nearest];
        out.push((nearest as u32, cp.stiffness * d));
        return 0.5 * cp.stiffness * d.length_squared();
    }
    let centroid = patch
        .iter()
        .map(|&(j, g, _)| positions[j as usize] * g)
        .sum::<DVec3>()
        / total;
    let d = c - centroid;
    let k = cp.stiffness;
    for &(j, g, grad) in &patch {
        let xj = positions[j as usize];
        out.push((
            j,
            k * (d * (g / total) + grad * (d.dot(xj - centroid) / total)),
        ));
    }
    0.5 * k * d.length_squared()
}

/// The force control point `cp` exerts on the membrane, Σ_j F_j over its
/// patch (Ē/l̄), with `coupling` and `nearest` its nearest vertex. In the
/// fluid model (`fluid`) each F_j first loses its tangential component
/// (area-weighted vertex normals at `positions`), as in the force stage:
/// the force the membrane actually receives.
pub fn delivered_force(
    positions: &[DVec3],
    topology: &crate::mesh::topology::Topology,
    cp: &ControlPoint,
    coupling: SpringCoupling,
    nearest: usize,
    fluid: bool,
) -> DVec3 {
    let mut parts: Vec<(u32, DVec3)> = Vec::new();
    match coupling {
        SpringCoupling::Gaussian { radius } => {
            gaussian_patch(positions, cp, radius, nearest, &mut parts);
        }
        SpringCoupling::OneRing | SpringCoupling::Centroid => {
            // Both give Σ_j F_j = k Σ_j (c − x_j) over the 1-ring patch
            // (the fluid model, the only reader of the shares, refuses
            // these couplings).
            let patch =
                std::iter::once(nearest as u32).chain(topology.neighbours(nearest).iter().copied());
            parts.extend(patch.map(|j| (j, cp.stiffness * (cp.position - positions[j as usize]))));
        }
    }
    parts
        .iter()
        .map(|&(j, f)| {
            if fluid {
                let n = crate::fluid::vertex_normal(positions, topology, j as usize);
                f.dot(n) * n
            } else {
                f
            }
        })
        .sum()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The patch force on a vertex crossing the cut-off 3a changes by O(ε),
    /// not by a jump: weight and gradient both vanish there.
    #[test]
    fn gaussian_patch_force_is_continuous_at_the_cut_off() {
        let a = 1.0;
        let cp = ControlPoint {
            position: DVec3::ZERO,
            stiffness: 100.0,
        };
        let force_on_last = |r: f64| {
            let positions = vec![
                DVec3::new(0.3, 0.0, 0.2),
                DVec3::new(-0.5, 0.4, 0.1),
                DVec3::new(0.0, -0.6, 0.3),
                DVec3::new(r, 0.0, 0.0),
            ];
            let mut out = Vec::new();
            gaussian_patch(&positions, &cp, a, 0, &mut out);
            out.iter()
                .find(|(j, _)| *j == 3)
                .map_or(DVec3::ZERO, |&(_, f)| f)
        };
        let eps = 1e-6;
        let inside = force_on_last(3.0 * a - eps);
        let outside = force_on_last(3.0 * a + eps);
        assert_eq!(outside, DVec3::ZERO);
        assert!(inside.length() < 1e-4, "force just inside: {inside}");
        // The weight stays non-negative over the patch.
        for k in 0..=300 {
            let r = 3.0 * a * k as f64 / 300.0;
            assert!(gaussian_weight(r * r, 1.0 / (a * a)).0 >= 0.0, "r = {r}");
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

/// Cell size of the nearest-vertex grid (l̄): two mean edge lengths, a few
/// vertices per cell on the surface.
const NEAREST_CELL_SIZE: f64 = 2.0;

/// The control-point spring system. Control points are read from the world
/// on each evaluation (a handful of entities, not a per-edge loop).
#[derive(Default)]
pub struct SpringForces {
    coupling: SpringCoupling,
    points: Vec<ControlPoint>,
    /// Each point's nearest vertex, kept as the next search's first guess.
    nearest: Vec<usize>,
    cells: CellList,
}

impl SpringForces {
    /// Springs with the given coupling.
    pub fn new(coupling: SpringCoupling) -> Self {
        Self {
            coupling,
            ..Default::default()
        }
    }
}

impl ForceTerm for SpringForces {
    fn name(&self) -> &str {
        "springs"
    }

    fn kind(&self) -> ForceKind {
        ForceKind::External
    }

    /// Gathers the control points, returns the spring energy and, with
    /// `force`, adds the spring forces.
    fn evaluate(&mut self, ctx: &ForceContext<'_>, force: Option<&mut [DVec3]>) -> f64 {
        self.points.clear();
        self.points
            .extend(ctx.world.query::<&ControlPoint>().iter().copied());
        let p = ctx.positions;
        // Nearest vertices through a cell list (exactly the brute-force
        // answer): O(N) to build plus a few cells per point, instead of
        // O(N) per point.
        self.cells.build(p, NEAREST_CELL_SIZE);
        self.nearest.resize(self.points.len(), 0);
        for (cp, guess) in self.points.iter().zip(self.nearest.iter_mut()) {
            let start = if *guess < p.len() { *guess } else { 0 };
            *guess = self.cells.nearest(p, cp.position, start);
        }
        let (t, points, nearest) = (ctx.topology, &self.points, &self.nearest);
        control_point_springs(p, t, points, nearest, self.coupling, force)
    }

    /// Zero: the springs act on each point's nearest vertex and its 1-ring,
    /// and a flip changes the 1-rings of its four vertices only, so the
    /// flip system, while springs act, never flips at a point's nearest
    /// vertex (nearest vertices depend on positions alone, so the rule is
    /// the same both ways).
    fn flip_energy_change(&mut self, _: &FlipProposal<'_>) -> Option<f64> {
        Some(0.0)
    }
}

/// Control-point springs with `coupling` (the points come from
/// the `control_points` plugin).
pub fn plugin(coupling: SpringCoupling) -> impl Plugin {
    move |b: &mut SimBuilder| {
        b.insert_resource(coupling);
        b.add_force_term(SpringForces::new(coupling))?;
        Ok(())
    }
}

impl crate::energy::builtin::BuiltinTerm for SpringParams {
    /// Correct on open meshes: a control point's nearest vertex and its ring (a boundary vertex's is its fan), or vertices by distance.
    const CORRECT_ON_OPEN_MESHES: bool = true;

    fn plugin(&self, _context: crate::energy::builtin::TermContext) -> impl Plugin {
        plugin(self.coupling)
    }

    fn at_resolution(&mut self, h: f64) {
        if let SpringCoupling::Gaussian { radius } = &mut self.coupling {
            *radius *= h;
        }
    }

    /// It pulls through the control points; a 1-ring coupling cannot run
    /// in the fluid model.
    fn needs(&self) -> crate::energy::builtin::TermNeeds {
        crate::energy::builtin::TermNeeds {
            control_points: true,
            control_point_stiffness: Some(self.stiffness),
            not_in_fluid_model: (!matches!(self.coupling, SpringCoupling::Gaussian { .. })).then(
                || {
                    (
                        "coupling",
                        format!(
                            "{:?} ties a control point to the nearest vertex's 1-ring, which \
                             slides away in the fluid model; use `coupling: Gaussian(radius: a)` \
                             (a smooth patch of physical radius a ≈ 1-1.5 l̄, pulled along the \
                             surface normal)",
                            self.coupling
                        ),
                    )
                },
            ),
            ..Default::default()
        }
    }
}
