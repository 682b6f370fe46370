//! External Hookean springs from fixed control points (SPEC §2): each control
//! point c pulls its nearest vertex i and every 1-ring neighbour j of i with
//! force k (x_c − x_j); energy ½k|x_c − x_j|² summed over all pulled vertices
//! (the as-run coupling), or ties the centroid of that patch to c
//! ([`SpringCoupling::Centroid`]).

use crate::mesh::components::ControlPoint;
use crate::params::SpringCoupling;
use glam::DVec3;

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

/// exp(−9/2): the Gaussian weight at the cut-off 3a, subtracted so that a
/// vertex's weight reaches zero there.
const GAUSSIAN_CUTOFF_WEIGHT: f64 = 0.011_108_996_538_242_306;

/// The smooth-patch coupling ([`SpringCoupling::Gaussian`]) of control
/// point `cp` with patch radius `radius` (a, l̄): writes each patch vertex
/// and its force −∂E/∂x_j into `out` (vertex order) and returns the energy.
/// `nearest` is the vertex nearest to the point, the patch when no vertex
/// lies within 3a.
///
/// With d = c − x̄, G = Σ g, w_j = g_j/G and ∇g_j = −(x_j − c)/a² ·
/// exp(−r_j²/2a²): F_j = k [w_j d + (d·(x_j − x̄)) ∇g_j / G].
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
            let e = (-0.5 * r2 * inv_a2).exp();
            patch.push((
                j as u32,
                e - GAUSSIAN_CUTOFF_WEIGHT,
                -(x - c) * (e * inv_a2),
            ));
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
