//! Helfrich bending in Jülicher's edge (dihedral-angle) form:
//! H = Σ_i ½κ A_i (h_i − C0)², h_i = 2M_i / A_i, M_i = ¼ Σ_{e∋i} ℓ_e θ_e,
//! A_i = ⅓ Σ_{f∋i} A_f.
//!
//! M_i is vertex i's share of the integrated mean curvature ∫H dA ≈
//! Σ_e ½ ℓ_e θ_e of the polyhedron (θ_e the signed angle between the
//! outward normals of edge e's two faces, positive where the surface is
//! convex), and A_i its barycentric area (F. Jülicher, J. Phys. II 6, 1797
//! (1996); Bian, Litvinov & Koumoutsakos, CMAME 359, 112758 (2020)).
//!
//! Against the cotangent form ([`crate::energy::bending`]) on the same
//! meshes of the axisymmetric solver's shapes (about 640 vertices, vertices
//! on the continuum surface), it reads within 0.3 % of the continuum where
//! the cotangent form reads 1-2.4 % low (benches/RESULTS.md, commit d749cee (2026-12-04)).
//! The signed h_i also carries the sign of the curvature without a normal.
//!
//! The force is the analytic gradient: an edge pass measures ℓ_e and θ_e,
//! a vertex pass forms M_i, A_i and the adjoints ∂H/∂M_i, ∂H/∂A_i, and an
//! edge pass and a face pass pull them back onto the positions.
//!
//! On an open mesh, as in the cotangent form ([`crate::energy::bending`]),
//! the sum runs over interior vertices: a boundary vertex carries no energy
//! of its own. A boundary edge has no dihedral angle (θ_e = 0, its quad's
//! second face standing in for the missing one); it is in no interior
//! vertex's ring, so it enters no energy.

use crate::mesh::geometry::Corners;
use crate::mesh::topology::{NO_SLOT, Topology};
use glam::DVec3;

/// The dihedral form's measure of a surface: per edge its quad, length
/// and angle, per vertex M_i and A_i. Read-only once taken, so a measure
/// published for the tick's positions serves every consumer
/// ([`DihedralMeasure::pull_back`] writes into the caller's buffers).
#[derive(Clone, Debug, Default)]
pub struct DihedralMeasure {
    /// Per edge: its four vertices [x0, x1, x2, x3], with face A = (x0, x1,
    /// x2) and face B = (x1, x0, x3) in their own orientation.
    quads: Vec<[u32; 4]>,
    /// Per edge: face A and face B.
    quad_faces: Vec<[u32; 2]>,
    /// Per edge: (ℓ_e, θ_e).
    edges: Vec<(f64, f64)>,
    /// Per vertex: M_i, A_i.
    m: Vec<f64>,
    a: Vec<f64>,
    /// The topology the quads were built for: its structure epoch and its
    /// edge and face counts (a remesh event or flip changes the epoch).
    oriented_for: Option<(u64, usize, usize)>,
}

/// The buffers of a pull-back onto the positions ([`DihedralMeasure::pull_back`]).
#[derive(Clone, Debug, Default)]
pub struct DihedralBuffers {
    edge_gradients: Vec<(f64, [DVec3; 4])>,
    face_gradients: Vec<(f64, [DVec3; 3])>,
}

/// Reusable buffers for [`bending_dihedral`]: a measure, the adjoints and
/// the pull-back's buffers.
#[derive(Clone, Debug, Default)]
pub struct DihedralScratch {
    measure: DihedralMeasure,
    /// Per vertex: ∂H/∂M_i, ∂H/∂A_i.
    g_m: Vec<f64>,
    g_a: Vec<f64>,
    buffers: DihedralBuffers,
}

/// The signed dihedral angle θ of an edge x0 → x1 between face A (normal
/// `na`) and face B (normal `nb`): positive where the surface is convex.
#[inline(always)]
fn dihedral(na: DVec3, nb: DVec3, e_hat: DVec3) -> f64 {
    na.cross(nb).dot(e_hat).atan2(na.dot(nb))
}

impl DihedralMeasure {
    /// Fills the per-edge quads from the topology. A boundary edge's quad
    /// repeats its face (x3 = x2, face B = face A): its angle is 0.
    fn orient(&mut self, topology: &Topology) {
        let ne = topology.edges.len();
        let key = (topology.epoch, ne, topology.faces.len());
        if self.oriented_for == Some(key) {
            return;
        }
        self.oriented_for = Some(key);
        self.quads.resize(ne, [0; 4]);
        self.quad_faces.resize(ne, [0; 2]);
        for e in 0..ne {
            let [a, b] = topology.edges[e];
            let [f1, f2] = topology.edge_faces[e];
            let face = topology.faces[f1 as usize];
            // The rotation of face 1 that starts with the edge.
            let k = (0..3)
                .find(|&k| {
                    let (p, q) = (face[k], face[(k + 1) % 3]);
                    (p == a && q == b) || (p == b && q == a)
                })
                .expect("an edge is a side of its face");
            let (x0, x1, x2) = (face[k], face[(k + 1) % 3], face[(k + 2) % 3]);
            if f2 == NO_SLOT {
                self.quads[e] = [x0, x1, x2, x2];
                self.quad_faces[e] = [f1, f1];
                continue;
            }
            let x3 = topology.faces[f2 as usize]
                .into_iter()
                .find(|&v| v != x0 && v != x1)
                .expect("a face has a corner off its edge");
            self.quads[e] = [x0, x1, x2, x3];
            self.quad_faces[e] = [f1, f2];
        }
    }
}

/// Bending energy (Ē) in the dihedral form for bending modulus `kappa` (Ē)
/// and spontaneous curvature `c0` (1/l̄), from the positions, the topology
/// and the faces' precomputed geometry. With `force = Some(f)`, adds −∇H to
/// `f`. The same bits on any thread count.
pub fn bending_dihedral(
    positions: &[DVec3],
    topology: &Topology,
    geometry: &[Corners],
    kappa: f64,
    c0: f64,
    scratch: &mut DihedralScratch,
    force: Option<&mut [DVec3]>,
) -> f64 {
    scratch.measure.measure(positions, topology, geometry);
    bending_dihedral_measured(
        positions, topology, geometry, kappa, c0, scratch, None, force,
    )
}

/// [`bending_dihedral`] on a measure taken at these positions: `measured`
/// (read, not copied) where given, else the scratch's own (taken by the
/// caller).
#[allow(clippy::too_many_arguments)]
pub fn bending_dihedral_measured(
    positions: &[DVec3],
    topology: &Topology,
    geometry: &[Corners],
    kappa: f64,
    c0: f64,
    scratch: &mut DihedralScratch,
    measured: Option<&DihedralMeasure>,
    force: Option<&mut [DVec3]>,
) -> f64 {
    let n = positions.len();
    let DihedralScratch {
        measure: own,
        g_m,
        g_a,
        buffers,
    } = scratch;
    let measure = measured.unwrap_or(own);
    g_m.resize(n, 0.0);
    g_a.resize(n, 0.0);
    let mut energy = 0.0;
    for i in 0..n {
        if topology.is_boundary_vertex(i) {
            g_m[i] = 0.0;
            g_a[i] = 0.0;
            continue;
        }
        let a = measure.a[i];
        let h = 2.0 * measure.m[i] / a;
        let dh = h - c0;
        energy += 0.5 * kappa * a * dh * dh;
        g_m[i] = 2.0 * kappa * dh;
        g_a[i] = 0.5 * kappa * dh * dh - kappa * dh * h;
    }
    if let Some(force) = force {
        measure.pull_back(g_m, g_a, buffers, positions, topology, geometry, force);
    }
    energy
}

impl DihedralScratch {
    /// The scratch's own measure, to be taken by
    /// [`DihedralMeasure::measure`] before [`bending_dihedral_measured`]
    /// reads it.
    pub fn measure_mut(&mut self) -> &mut DihedralMeasure {
        &mut self.measure
    }
}

impl DihedralMeasure {
    /// Measures every edge's length ℓ_e and angle θ_e, and every vertex's
    /// M_i = ¼ Σ_{e∋i} ℓ_e θ_e and barycentric area A_i.
    pub fn measure(&mut self, positions: &[DVec3], topology: &Topology, geometry: &[Corners]) {
        let n = positions.len();
        let s = self;
        s.orient(topology);
        let (quads, quad_faces) = (&s.quads, &s.quad_faces);
        crate::util::parallel::fill_vec(&mut s.edges, quads.len(), |e| {
            let [x0, x1, ..] = quads[e].map(|v| positions[v as usize]);
            let [fa, fb] = quad_faces[e].map(|f| geometry[f as usize].n_hat);
            let d = x1 - x0;
            let l = d.length();
            (l, dihedral(fa, fb, d / l))
        });
        let edges = &s.edges;
        crate::util::parallel::fill_vec(&mut s.m, n, |i| {
            0.25 * topology
                .ring_edges_of(i)
                .iter()
                .map(|&e| {
                    let (l, t) = edges[e as usize];
                    l * t
                })
                .sum::<f64>()
        });
        crate::util::parallel::fill_vec(&mut s.a, n, |i| {
            topology
                .ring_faces_of(i)
                .iter()
                .filter(|&&f| f != NO_SLOT)
                .map(|&f| geometry[f as usize].twice_area)
                .sum::<f64>()
                / 6.0
        });
    }

    /// M_i of the last [`DihedralMeasure::measure`] (l̄).
    pub(crate) fn integrated_curvature(&self) -> &[f64] {
        &self.m
    }

    /// A_i of the last [`DihedralMeasure::measure`] (l̄²).
    pub(crate) fn areas(&self) -> &[f64] {
        &self.a
    }

    /// Subtracts ∇E from `force` for an energy E(M, A) with the adjoints
    /// `g_m` = ∂E/∂M_i and `g_a` = ∂E/∂A_i, at the measured state.
    #[allow(clippy::too_many_arguments)]
    pub fn pull_back(
        &self,
        g_m: &[f64],
        g_a: &[f64],
        buffers: &mut DihedralBuffers,
        positions: &[DVec3],
        topology: &Topology,
        geometry: &[Corners],
        force: &mut [DVec3],
    ) {
        let s = self;
        let (quads, quad_faces, edges) = (&s.quads, &s.quad_faces, &s.edges);
        let edge_gradient = |e: usize| {
            let [i0, i1, ..] = quads[e];
            let [x0, x1, x2, x3] = quads[e].map(|v| positions[v as usize]);
            let [ca, cb] = quad_faces[e].map(|f| &geometry[f as usize]);
            let (l, theta) = edges[e];
            let d = x1 - x0;
            let e_hat = d / l;
            let c = 0.25 * (g_m[i0 as usize] + g_m[i1 as usize]);
            // ∂θ/∂x2 = −ℓ n̂_A / (2A_A), ∂θ/∂x3 = −ℓ n̂_B / (2A_B); the edge's
            // ends take the rest by where x2 and x3 project onto the edge.
            let t2 = -l * ca.inv_twice_area * ca.n_hat;
            let t3 = -l * cb.inv_twice_area * cb.n_hat;
            let inv_l2 = 1.0 / (l * l);
            let alpha_a = (x2 - x0).dot(d) * inv_l2;
            let alpha_b = (x3 - x0).dot(d) * inv_l2;
            let t0 = -(1.0 - alpha_a) * t2 - (1.0 - alpha_b) * t3;
            let t1 = -alpha_a * t2 - alpha_b * t3;
            // d(ℓθ) = θ dℓ + ℓ dθ.
            let (cl, ct) = (c * theta, c * l);
            (
                0.0,
                [ct * t0 - cl * e_hat, ct * t1 + cl * e_hat, ct * t2, ct * t3],
            )
        };
        subtract(quads, force, &mut buffers.edge_gradients, edge_gradient);
        let faces = &topology.faces;
        let face_gradient = |k: usize| {
            let [i0, i1, i2] = faces[k].map(|v| v as usize);
            let c = &geometry[k];
            // ∂A_f/∂p_k = ½ n̂ × e_k, and A_i takes a third of A_f.
            let w = (g_a[i0] + g_a[i1] + g_a[i2]) / 6.0;
            (0.0, c.e.map(|e| w * c.n_hat.cross(e)))
        };
        subtract(faces, force, &mut buffers.face_gradients, face_gradient);
    }
}

/// Subtracts every item's per-vertex gradients from `force`, in item order:
/// on a large mesh computed in parallel blocks, otherwise in one serial
/// loop (a small mesh would pay more for handing blocks to the pool than
/// for the work: 180 µs against 89 µs at 642 vertices, criterion).
fn subtract<const K: usize>(
    items: &[[u32; K]],
    force: &mut [DVec3],
    scratch: &mut Vec<(f64, [DVec3; K])>,
    gradient: impl Fn(usize) -> (f64, [DVec3; K]) + Sync + Send,
) {
    if crate::util::parallel::splits(items.len()) {
        crate::util::parallel::accumulate(items, force, scratch, gradient, |f, g| *f -= g);
        return;
    }
    for (k, item) in items.iter().enumerate() {
        let (_, g) = gradient(k);
        for (&v, g) in item.iter().zip(g) {
            force[v as usize] -= g;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The signed curvature h_i = 2M_i/A_i of every vertex (1/l̄), with the
    /// barycentric vertex areas A_i (l̄²).
    fn dihedral_curvatures(
        positions: &[DVec3],
        topology: &Topology,
        geometry: &[Corners],
        scratch: &mut DihedralScratch,
    ) -> (Vec<f64>, Vec<f64>) {
        bending_dihedral(positions, topology, geometry, 0.0, 0.0, scratch, None);
        let m = &scratch.measure;
        let h = m.m.iter().zip(&m.a).map(|(m, a)| 2.0 * m / a).collect();
        (h, m.a.clone())
    }

    fn sphere(level: u32) -> (Vec<DVec3>, Topology) {
        let mesh = crate::mesh::icosphere(level, 1.0);
        let mut m = crate::mesh::membrane::Membrane::from_mesh(&mesh, false).unwrap();
        (mesh.positions.clone(), m.topology().unwrap().clone())
    }

    fn geometry(p: &[DVec3], t: &Topology) -> Vec<Corners> {
        t.faces
            .iter()
            .map(|f| Corners::new(p[f[0] as usize], p[f[1] as usize], p[f[2] as usize]))
            .collect()
    }

    #[test]
    fn sphere_energy_approaches_eight_pi_kappa() {
        let mut previous = f64::INFINITY;
        for level in 2..=4 {
            let (p, t) = sphere(level);
            let g = geometry(&p, &t);
            let e = bending_dihedral(&p, &t, &g, 1.0, 0.0, &mut Default::default(), None);
            let err = (e / (8.0 * std::f64::consts::PI) - 1.0).abs();
            assert!(err < previous, "level {level}: error {err} did not fall");
            previous = err;
        }
        assert!(previous < 2e-3, "level 4: error {previous}");
    }

    #[test]
    fn sphere_of_spontaneous_radius_is_nearly_stress_free() {
        let (p, t) = sphere(3);
        let r = p[0].length();
        let g = geometry(&p, &t);
        let e = bending_dihedral(&p, &t, &g, 1.0, 2.0 / r, &mut Default::default(), None);
        let (h, a) = dihedral_curvatures(&p, &t, &g, &mut Default::default());
        let mean = h.iter().zip(&a).map(|(h, a)| h * a).sum::<f64>() / a.iter().sum::<f64>();
        let rms = (h
            .iter()
            .zip(&a)
            .map(|(h, a)| (h * r / 2.0 - 1.0).powi(2) * a)
            .sum::<f64>()
            / a.iter().sum::<f64>())
        .sqrt();
        eprintln!(
            "E/8πκ = {}, mean h r/2 = {}, rms = {rms}",
            e / (8.0 * std::f64::consts::PI),
            mean * r / 2.0
        );
        // The mean curvature is right on average; what is left is the
        // pointwise scatter of the edge form on the icosphere's unequal
        // triangles (valence-5 vertices).
        assert!(
            (mean * r / 2.0 - 1.0).abs() < 5e-3,
            "mean h r/2 = {}",
            mean * r / 2.0
        );
        assert!(e < 0.01 * 8.0 * std::f64::consts::PI, "E = {e}");
    }
}
