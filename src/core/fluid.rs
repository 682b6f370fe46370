//! The fluid membrane model's kernels (SPEC §8; `MembraneModel::Fluid`).
//!
//! A lipid membrane is a two-dimensional fluid: it resists bending and
//! area change, not in-plane shear. On a fixed connectivity the paper's
//! V_in makes the mesh a pre-stressed spring network, an elastic shell.
//! The fluid model keeps V_in as mesh maintenance but lets only its
//! component in each vertex's tangent plane act: the normal (shape)
//! equation then holds bending, tension and pressure alone.
//!
//! The vertex normal is the area-weighted one, n_i ∝ Σ_{f∋i} A_f n̂_f, which
//! is parallel to ∇_i V (the enclosed volume's gradient): a tangential move
//! changes the volume only at second order.

use crate::mesh::topology::Topology;
use glam::DVec3;

/// The faces around vertex `v` (a boundary vertex's fan, without the
/// missing face that would close it).
#[inline]
fn ring_faces(topology: &Topology, v: usize) -> &[u32] {
    let faces = topology.ring_faces_of(v);
    match faces.last() {
        Some(&crate::mesh::topology::NO_SLOT) => &faces[..faces.len() - 1],
        _ => faces,
    }
}

/// Unit area-weighted normal of vertex `v`: Σ over its faces (a boundary
/// vertex's fan) of (p1 − p0) × (p2 − p0), normalised (zero for a
/// degenerate ring).
#[inline]
pub fn vertex_normal(positions: &[DVec3], topology: &Topology, v: usize) -> DVec3 {
    let mut n = DVec3::ZERO;
    for &f in ring_faces(topology, v) {
        let [a, b, c] = topology.faces[f as usize].map(|i| positions[i as usize]);
        n += (b - a).cross(c - a);
    }
    n.normalize_or_zero()
}

/// The unit area-weighted normal of every vertex, by dense slot (each
/// vertex computed on its own, so the same bits on any thread count).
pub fn vertex_normals(positions: &[DVec3], topology: &Topology, out: &mut Vec<DVec3>) {
    crate::util::parallel::fill_vec(out, positions.len(), |v| {
        vertex_normal(positions, topology, v)
    });
}

/// [`vertex_normals`] from the tick's per-face geometry (its unit normals
/// times twice the areas), without a cross product per corner: the same
/// directions to round-off.
pub fn vertex_normals_from_faces(
    faces: &[crate::mesh::geometry::Corners],
    topology: &Topology,
    out: &mut Vec<DVec3>,
) {
    crate::util::parallel::fill_vec(out, topology.vertex_count(), |v| {
        let mut n = DVec3::ZERO;
        for &f in ring_faces(topology, v) {
            let c = &faces[f as usize];
            n += c.n_hat * c.twice_area;
        }
        n.normalize_or_zero()
    });
}

/// Removes from every force its component along the vertex normal:
/// f ← f − (f·n) n.
pub fn keep_tangential(forces: &mut [DVec3], normals: &[DVec3]) {
    crate::util::parallel::for_each_mut(forces, |v, f| {
        let n = normals[v];
        *f -= f.dot(n) * n;
    });
}

/// Removes the net force from a force field: f ← f − (1/N) Σ_j f_j. The
/// projection onto tangent planes breaks action and reaction (a free
/// vesicle would drift); a uniform force is a rigid translation, which
/// moves no shape, so taking it away restores momentum conservation
/// without acting on the shape. At a fluid equilibrium the projected
/// maintenance force already sums to zero, so the equilibrium is
/// unchanged. The sum is sequential (the same bits on any thread count).
pub fn remove_net_force(forces: &mut [DVec3]) {
    if forces.is_empty() {
        return;
    }
    let mean = forces.iter().copied().sum::<DVec3>() / forces.len() as f64;
    crate::util::parallel::for_each_mut(forces, |_, f| *f -= mean);
}

/// Removes the net force and the net torque from a force field: f_i ← f_i
/// − f̄ − ω × (x_i − x̄), with f̄ the mean force, x̄ the centroid and ω
/// solving I ω = Σ_j (x_j − x̄) × f_j (I the inertia tensor of unit point
/// masses about x̄). Like a uniform force, a rigid rotation moves no shape;
/// the projections break angular momentum as they break linear momentum,
/// and on a helically ordered tube the tangential V_in forces of a
/// compressed lattice sum to a torque that spun the tube about its axis
/// without end (the n = 13 tether started at 0.8 r0: the largest force
/// stuck near 1e-3 Ē/l̄ while the energy crept up, commit 65cd623 (2026-12-04)). Sums are
/// sequential (the same bits on any thread count).
pub fn remove_net_force_and_torque(forces: &mut [DVec3], positions: &[DVec3]) {
    remove_net_force(forces);
    set_torque(forces, positions, DVec3::ZERO);
}

/// The torque of a force field about the centroid x̄ of its vertices,
/// Σ_j (x_j − x̄) × f_j (sequential sum).
pub fn torque(forces: &[DVec3], positions: &[DVec3]) -> DVec3 {
    let centroid = centroid(&positions[..forces.len()]);
    positions
        .iter()
        .zip(forces)
        .map(|(x, f)| (*x - centroid).cross(*f))
        .sum()
}

fn centroid(positions: &[DVec3]) -> DVec3 {
    positions.iter().copied().sum::<DVec3>() / positions.len().max(1) as f64
}

/// Adds the rigid rotation field ω × (x_i − x̄) that brings the field's
/// [`torque`] to `target`, leaving its net force unchanged (the field sums
/// to zero about the centroid). A degenerate inertia tensor (the vertices
/// on a line) leaves the field as it is.
pub fn set_torque(forces: &mut [DVec3], positions: &[DVec3], target: DVec3) {
    let n = forces.len();
    if n == 0 {
        return;
    }
    let centroid = centroid(&positions[..n]);
    let mut excess = -target;
    let mut inertia = glam::DMat3::ZERO;
    for (x, f) in positions[..n].iter().zip(forces.iter()) {
        let r = *x - centroid;
        excess += r.cross(*f);
        inertia += glam::DMat3::from_diagonal(DVec3::splat(r.length_squared()))
            - glam::DMat3::from_cols(r * r.x, r * r.y, r * r.z);
    }
    let scale = inertia.col(0).length() + inertia.col(1).length() + inertia.col(2).length();
    let det = inertia.determinant().abs();
    if det.is_nan() || det <= 1e-12 * scale * scale * scale {
        return;
    }
    let omega = inertia.inverse() * excess;
    crate::util::parallel::for_each_mut(forces, |v, f| {
        *f -= omega.cross(positions[v] - centroid);
    });
}

/// The boundary vertices of an open membrane and their unit boundary
/// tangents t_i ∝ x_next − x_prev (the loop's neighbours of i), by dense
/// slot; empty for a closed membrane. On a boundary the motions that keep
/// the shape are the slides along the boundary line, not the whole tangent
/// plane: a move along the conormal (in the tangent plane, across the
/// boundary) grows or shrinks the patch.
pub fn boundary_tangents(positions: &[DVec3], topology: &Topology) -> Vec<(u32, DVec3)> {
    if !topology.is_open() {
        return Vec::new();
    }
    (0..topology.vertex_count())
        .filter(|&v| topology.is_boundary_vertex(v))
        .map(|v| (v as u32, boundary_tangent(positions, topology, v)))
        .collect()
}

/// The unit boundary tangent of boundary vertex `v`: x_next − x_prev
/// normalised, its loop's neighbours being the first and the last of its
/// ring.
#[inline]
pub fn boundary_tangent(positions: &[DVec3], topology: &Topology, v: usize) -> DVec3 {
    let ring = topology.neighbours(v);
    let (next, prev) = (ring[0] as usize, ring[ring.len() - 1] as usize);
    (positions[next] - positions[prev]).normalize_or_zero()
}

/// The shape-keeping part of a force on a boundary vertex of tangent `t`:
/// its component along the boundary, (f·t) t.
#[inline]
pub fn along_boundary(f: DVec3, t: DVec3) -> DVec3 {
    f.dot(t) * t
}

/// The shape-changing part of a force on a boundary vertex of tangent `t`:
/// all but its component along the boundary, f − (f·t) t (the normal and
/// the conormal parts, which bend the rim and move it across the surface).
#[inline]
pub fn across_boundary(f: DVec3, t: DVec3) -> DVec3 {
    f - f.dot(t) * t
}

/// Keeps of every force only its component along the vertex normal:
/// f ← (f·n) n.
pub fn keep_normal(forces: &mut [DVec3], normals: &[DVec3]) {
    crate::util::parallel::for_each_mut(forces, |v, f| {
        let n = normals[v];
        *f = f.dot(n) * n;
    });
}

/// What the fluid model measures of a force evaluation (Ē/l̄).
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct FluidResiduals {
    /// Largest normal component of the total force, max_i |n_i·F_i|: the
    /// residual of the discrete shape equation (0 at equilibrium). On a
    /// boundary vertex, the part of the force across its boundary line
    /// (normal and conormal).
    pub normal_residual: f64,
    /// Largest tangential force of the maintenance terms, max_i |P_T F_i|
    /// (what keeps the triangles regular; it does not act on the shape).
    pub maintenance_tangential: f64,
    /// Net force on the membrane, |Σ_i F_i|: zero for a free membrane
    /// (every term is translation-invariant, and the fluid model removes
    /// the net force its projection would leave), so above round-off it is
    /// the load of the control points.
    pub net_force: f64,
}

/// Measures [`FluidResiduals`] from the total force and the (projected)
/// maintenance forces; `boundary` holds an open membrane's
/// [`boundary_tangents`].
pub fn residuals(
    total: &[DVec3],
    maintenance: &[DVec3],
    normals: &[DVec3],
    boundary: &[(u32, DVec3)],
) -> FluidResiduals {
    let interior = total
        .iter()
        .zip(normals)
        .map(|(f, n)| f.dot(*n).abs())
        .fold(0.0, f64::max);
    let normal_residual = boundary
        .iter()
        .map(|&(v, t)| across_boundary(total[v as usize], t).length())
        .fold(interior, f64::max);
    let maintenance_tangential = maintenance.iter().map(|f| f.length()).fold(0.0, f64::max);
    let net_force = total.iter().copied().sum::<DVec3>().length();
    FluidResiduals {
        normal_residual,
        maintenance_tangential,
        net_force,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::geometry::enclosed_volume;

    /// After the removal the field has no net force and no torque, and what
    /// was removed is a rigid motion: (d_i − d_j)·(x_i − x_j) = 0.
    #[test]
    fn removing_net_force_and_torque_takes_away_a_rigid_motion() {
        let points: Vec<DVec3> = (0..40)
            .map(|i| {
                let t = i as f64;
                DVec3::new((1.3 * t).sin() * 2.0, (0.7 * t).cos() * 3.0, 0.1 * t - 1.0)
            })
            .collect();
        let forces: Vec<DVec3> = (0..40)
            .map(|i| {
                let t = i as f64;
                DVec3::new(
                    (2.1 * t).cos() + 0.3,
                    (1.7 * t).sin(),
                    (0.9 * t).sin() - 0.2,
                )
            })
            .collect();
        assert!(torque(&forces, &points).length() > 1.0);
        let mut g = forces.clone();
        remove_net_force_and_torque(&mut g, &points);
        assert!(g.iter().copied().sum::<DVec3>().length() < 1e-12);
        assert!(torque(&g, &points).length() < 1e-11);
        let d: Vec<DVec3> = forces.iter().zip(&g).map(|(f, g)| *f - *g).collect();
        for i in 0..40 {
            for j in 0..40 {
                let rigid = (d[i] - d[j]).dot(points[i] - points[j]);
                assert!(rigid.abs() < 1e-11, "{i} {j}: {rigid}");
            }
        }
    }

    #[test]
    fn normal_is_the_volume_gradient_direction() {
        let mesh = crate::mesh::icosphere(2, 1.0);
        let mut m = crate::mesh::membrane::Membrane::from_mesh(&mesh, false).unwrap();
        let t = m.topology().unwrap().clone();
        let mut p = mesh.positions.clone();
        // Perturb so that the ring is not symmetric.
        for (i, x) in p.iter_mut().enumerate() {
            *x *= 1.0 + 0.05 * ((i * 7919) % 13) as f64 / 13.0;
        }
        let mut normals = Vec::new();
        vertex_normals(&p, &t, &mut normals);
        for v in [0usize, 5, 17, 40] {
            let h = 1e-6;
            let mut g = DVec3::ZERO;
            for k in 0..3 {
                let mut q = p.clone();
                q[v][k] += h;
                let up = enclosed_volume(&q, &t.faces, DVec3::ZERO);
                q[v][k] -= 2.0 * h;
                let down = enclosed_volume(&q, &t.faces, DVec3::ZERO);
                g[k] = (up - down) / (2.0 * h);
            }
            let cos = g.normalize().dot(normals[v]);
            assert!(cos > 1.0 - 1e-9, "vertex {v}: cos = {cos}");
        }
    }

    #[test]
    fn projection_leaves_no_normal_component() {
        let normals = vec![DVec3::Z, DVec3::new(1.0, 1.0, 0.0).normalize()];
        let mut f = vec![DVec3::new(1.0, 2.0, 3.0), DVec3::new(2.0, 0.0, 1.0)];
        keep_tangential(&mut f, &normals);
        assert_eq!(f[0], DVec3::new(1.0, 2.0, 0.0));
        assert!(f[1].dot(normals[1]).abs() < 1e-15);
        assert!((f[1].z - 1.0).abs() < 1e-15);
    }
}

/// The membrane model of a run and what its in-plane mechanics weigh, in
/// `summary.json` (every model).
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ModelSummary {
    /// `paper` or `fluid`.
    pub name: String,
    /// The moduli V_in gives the mesh at its edges' lengths (Ē/l̄²; `None`
    /// without V_in). In the paper's model they act on the shape; in the
    /// fluid model they do not.
    pub vin_moduli: Option<crate::energy::vin_elasticity::NetworkModuli>,
    /// Föppl-von Kármán number γ = Y·A/(4πκ) of that network against
    /// bending (`None` without V_in or bending).
    pub foppl_von_karman: Option<f64>,
    /// The fluid model's residuals of the last force evaluation (`None` in
    /// the paper's model).
    pub residuals: Option<FluidResiduals>,
    /// In the paper's model with γ > [`FVK_CAUTION`]: that V_in's elastic
    /// shell competes with bending, so results depend on the vesicle's size
    /// (omitted otherwise). The CLI prints it unless `--quiet`.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub caution: Option<String>,
}

/// Above this Föppl-von Kármán number the paper's model is cautioned: its
/// elastic shell competes with bending.
pub const FVK_CAUTION: f64 = 1.0;

impl ModelSummary {
    /// The caution a paper-model run earns when V_in's shell competes with
    /// bending (γ > [`FVK_CAUTION`]).
    pub fn elastic_shell_caution(&self) -> Option<String> {
        let gamma = self.foppl_von_karman?;
        let mu = self.vin_moduli?.shear;
        (self.name == "paper" && gamma > FVK_CAUTION).then(|| {
            format!(
                "V_in makes this mesh an elastic shell (shear modulus {mu:.3} Ē/l̄², \
                 Föppl-von Kármán number γ = Y·A/(4πκ) = {gamma:.2} > {FVK_CAUTION}): its \
                 in-plane elasticity competes with bending, so results depend on the vesicle's \
                 size in l̄, not only on its shape (measured: the RBC 0.9 % above the continuum \
                 at 2562 vertices, 9.7 % at 10242); `model: Fluid()` removes it"
            )
        })
    }
}
