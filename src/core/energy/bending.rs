//! Helfrich bending with the cotangent curvature and mixed Voronoi areas:
//! H = Σ_i ½κ A_i (h_i − C0)², h_i = s_i |K_i|, K_i = L_i / (2A_i),
//! L_i = Σ_j (cot α_ij + cot β_ij)(r_i − r_j), s_i = sign(K_i · N_i) with N_i
//! the area-weighted vertex normal. For C0 = 0 this is Σ κ|L_i|²/(8A_i).
//!
//! The force is the analytic gradient of this discrete energy, computed in
//! reverse mode: one face pass accumulates L_i and A_i, a vertex pass forms
//! the adjoints ∂H/∂L_i and ∂H/∂A_i, and a second face pass pulls them back
//! onto the corner positions ([`Corners::backward`]).
//!
//! ## Open meshes
//!
//! On a mesh with boundary loops the sum runs over the interior vertices
//! only: a boundary vertex's fan spans part of a turn, so its cotangent
//! Laplacian is not a curvature (on a flat patch it points across the
//! rim), and it carries no bending energy of its own. It still enters its
//! interior neighbours' L_j and A_j, so it feels their bending forces. This
//! is the interior discretisation unchanged: a flat patch has zero energy
//! and force, and a cap cut from a sphere has the sphere's forces at every
//! vertex two rings or more from its rim (`tests/integration/open_bending.rs`; the
//! dihedral form does the same, [`crate::energy::bending_dihedral`]). It
//! suits pinned boundaries, whose vertices do not move; a free boundary's
//! own bending (a geodesic-curvature or clamped term) is not modelled.
//!
//! ## The force term
//!
//! Helfrich bending forces (analytic gradient of the discrete energy, in
//! the scene's discretisation).
//!
//! Stage: Forces. Reads: positions, topology (faces; edges for the dihedral
//! form). Writes: force accumulator. Units: κ in Ē, C0 in 1/l̄. See
//! [`crate::energy::bending`] and [`crate::energy::bending_dihedral`].

use crate::energy::bending_dihedral::{DihedralScratch, bending_dihedral_measured};
use crate::energy::bending_measure::MeasuredSurface;
use crate::engine::force::{FlipProposal, ForceContext, ForceTerm};
use crate::engine::simulation::{Plugin, SimBuilder};
use crate::mesh::geometry::{Corners, vertex_curvature_terms};
use crate::util::parallel::Incidence;
use glam::DVec3;
use serde::{Deserialize, Serialize};

/// Reusable per-vertex buffers for [`bending`].
#[derive(Clone, Debug, Default)]
pub struct BendingScratch {
    areas: Vec<f64>,
    laplacians: Vec<DVec3>,
    normals: Vec<DVec3>,
    g_lap: Vec<DVec3>,
    g_area: Vec<f64>,
    /// Per-face pull-backs of the parallel form.
    face_gradients: Vec<(f64, [DVec3; 3])>,
    /// The gathered form's per-vertex energy and adjoints ∂H/∂L, ∂H/∂A
    /// (the energy is `None` for a boundary vertex, which has none).
    vertex_terms: Vec<(Option<f64>, DVec3, f64)>,
    /// The gathered form's per-face pull-backs.
    face_pull_backs: Vec<[DVec3; 3]>,
}

impl BendingScratch {
    /// Takes the vertex areas, Laplacians and normals of the face loops
    /// from a published measure of the same positions (the same sums).
    fn copy_measure(&mut self, areas: &[f64], laplacians: &[DVec3], normals: &[DVec3]) {
        self.areas.clear();
        self.areas.extend_from_slice(areas);
        self.laplacians.clear();
        self.laplacians.extend_from_slice(laplacians);
        self.normals.clear();
        self.normals.extend_from_slice(normals);
    }
}

/// Bending energy (Ē) for bending modulus `kappa` (Ē) and spontaneous
/// curvature `c0` (1/l̄) of a closed mesh with `n` vertices, from its faces
/// and their precomputed geometry. With `force = Some(f)`, adds −∇H to `f`.
#[allow(clippy::too_many_arguments)]
pub fn bending(
    n: usize,
    faces: &[[u32; 3]],
    geometry: &[Corners],
    kappa: f64,
    c0: f64,
    scratch: &mut BendingScratch,
    force: Option<&mut [DVec3]>,
) -> f64 {
    bending_open(n, faces, geometry, kappa, c0, None, scratch, force)
}

/// [`bending`] on a mesh that may be open: `boundary` (by vertex slot, or
/// `None` for a closed mesh) marks the boundary vertices, which carry no
/// energy of their own (see the module docs). With `None` the same bits as
/// [`bending`].
#[allow(clippy::too_many_arguments)]
pub fn bending_open(
    n: usize,
    faces: &[[u32; 3]],
    geometry: &[Corners],
    kappa: f64,
    c0: f64,
    boundary: Option<&[bool]>,
    scratch: &mut BendingScratch,
    force: Option<&mut [DVec3]>,
) -> f64 {
    bending_open_in(
        n, faces, geometry, kappa, c0, boundary, None, false, scratch, force,
    )
}

/// [`bending_open`], as a gather over the faces' `incidence` (from the
/// topology, [`crate::mesh::topology::Topology::face_incidence`]) when
/// one is given and the force is asked for: the same bits, every loop in
/// parallel. With `measured`, the face loops' vertex areas, Laplacians and
/// normals are already in the scratch ([`BendingScratch::copy_measure`]).
#[allow(clippy::too_many_arguments)]
fn bending_open_in(
    n: usize,
    faces: &[[u32; 3]],
    geometry: &[Corners],
    kappa: f64,
    c0: f64,
    boundary: Option<&[bool]>,
    incidence: Option<&Incidence>,
    measured: bool,
    scratch: &mut BendingScratch,
    mut force: Option<&mut [DVec3]>,
) -> f64 {
    if let Some(incidence) = incidence.filter(|i| i.elements() == n)
        && let Some(force) = force.as_deref_mut()
    {
        let terms = Gathered {
            faces,
            geometry,
            incidence,
            boundary,
        };
        return if c0 == 0.0 {
            terms.bending(scratch, force, false, |a, l, _| {
                let l2 = l.length_squared();
                let inv_a = 1.0 / a;
                (
                    kappa * l2 * 0.125 * inv_a,
                    l * (0.25 * kappa * inv_a),
                    -0.125 * kappa * l2 * inv_a * inv_a,
                )
            })
        } else {
            terms.bending(scratch, force, true, |a, l, nrm| {
                signed_vertex_terms(kappa, c0, a, l, nrm)
            })
        };
    }
    if c0 == 0.0 {
        let s = &mut *scratch;
        if !measured {
            vertex_curvature_terms(faces, geometry, &mut s.areas, &mut s.laplacians, None, n);
        }
        s.g_lap.resize(n, DVec3::ZERO);
        s.g_area.resize(n, 0.0);
        let mut energy = 0.0;
        for i in 0..n {
            if boundary.is_some_and(|b| b[i]) {
                s.g_lap[i] = DVec3::ZERO;
                s.g_area[i] = 0.0;
                continue;
            }
            let (a, l) = (s.areas[i], s.laplacians[i]);
            let l2 = l.length_squared();
            let inv_a = 1.0 / a;
            energy += kappa * l2 * 0.125 * inv_a;
            s.g_lap[i] = l * (0.25 * kappa * inv_a);
            s.g_area[i] = -0.125 * kappa * l2 * inv_a * inv_a;
        }
        if let Some(force) = force {
            pull_back(faces, geometry, s, force);
        }
        energy
    } else {
        if !measured {
            signed_terms(n, faces, geometry, scratch);
        }
        bending_measured(n, faces, geometry, kappa, |_| c0, boundary, scratch, force)
    }
}

/// Bending energy (Ē) with a spontaneous curvature per vertex,
/// H = Σ_i ½κ A_i (h_i − c0_i)² (`c0` by dense slot, 1/l̄): the energy of a
/// membrane whose proteins set its preferred curvature locally. With
/// `force = Some(f)`, adds −∇H to `f` (positions only; `c0` is held fixed).
pub fn bending_varying(
    faces: &[[u32; 3]],
    geometry: &[Corners],
    kappa: f64,
    c0: &[f64],
    scratch: &mut BendingScratch,
    force: Option<&mut [DVec3]>,
) -> f64 {
    signed_terms(c0.len(), faces, geometry, scratch);
    bending_measured(
        c0.len(),
        faces,
        geometry,
        kappa,
        |i| c0[i],
        None,
        scratch,
        force,
    )
}

/// The signed curvature h_i = s_i |K_i| of every vertex (1/l̄), with the
/// vertex areas A_i (l̄²), from the faces' geometry.
pub fn signed_curvatures(
    n: usize,
    faces: &[[u32; 3]],
    geometry: &[Corners],
    scratch: &mut BendingScratch,
) -> (Vec<f64>, Vec<f64>) {
    let s = scratch;
    signed_terms(n, faces, geometry, s);
    let h = (0..n)
        .map(|i| {
            let (a, l) = (s.areas[i], s.laplacians[i]);
            sign(l, s.normals[i]) * l.length() / (2.0 * a)
        })
        .collect();
    (h, s.areas.clone())
}

/// Fills the scratch's areas, Laplacians and vertex normals.
fn signed_terms(n: usize, faces: &[[u32; 3]], geometry: &[Corners], s: &mut BendingScratch) {
    vertex_curvature_terms(
        faces,
        geometry,
        &mut s.areas,
        &mut s.laplacians,
        Some(&mut s.normals),
        n,
    );
}

/// s_i = sign(K_i · N_i): +1 where the membrane curves like a sphere seen
/// from outside.
fn sign(laplacian: DVec3, normal: DVec3) -> f64 {
    if laplacian.dot(normal) < 0.0 {
        -1.0
    } else {
        1.0
    }
}

/// The signed-curvature form with spontaneous curvature `c0(i)` at vertex i,
/// on the scratch's areas, Laplacians and normals ([`signed_terms`]); the
/// `boundary` vertices (if any) carry no energy.
#[allow(clippy::too_many_arguments)]
fn bending_measured(
    n: usize,
    faces: &[[u32; 3]],
    geometry: &[Corners],
    kappa: f64,
    c0: impl Fn(usize) -> f64,
    boundary: Option<&[bool]>,
    scratch: &mut BendingScratch,
    force: Option<&mut [DVec3]>,
) -> f64 {
    let s = scratch;
    s.g_lap.resize(n, DVec3::ZERO);
    s.g_area.resize(n, 0.0);
    let mut energy = 0.0;
    for i in 0..n {
        if boundary.is_some_and(|b| b[i]) {
            s.g_lap[i] = DVec3::ZERO;
            s.g_area[i] = 0.0;
            continue;
        }
        let (a, l) = (s.areas[i], s.laplacians[i]);
        let len = l.length();
        let sign = sign(l, s.normals[i]);
        let h = sign * len / (2.0 * a);
        let dh = h - c0(i);
        energy += 0.5 * kappa * a * dh * dh;
        // |L| is not differentiable at 0: use the zero subgradient there.
        s.g_lap[i] = if len > 0.0 {
            l * (0.5 * kappa * dh * sign / len)
        } else {
            DVec3::ZERO
        };
        s.g_area[i] = 0.5 * kappa * dh * dh - kappa * dh * h;
    }
    if let Some(force) = force {
        pull_back(faces, geometry, s, force);
    }
    energy
}

/// A signed-curvature vertex's energy ½κA(h − c0)² and adjoints ∂H/∂L_i,
/// ∂H/∂A_i, from its area `a`, Laplacian `l` and normal `nrm` (the
/// expressions of [`bending_measured`]'s vertex loop).
#[inline(always)]
fn signed_vertex_terms(kappa: f64, c0: f64, a: f64, l: DVec3, nrm: DVec3) -> (f64, DVec3, f64) {
    let len = l.length();
    let sign = sign(l, nrm);
    let h = sign * len / (2.0 * a);
    let dh = h - c0;
    let energy = 0.5 * kappa * a * dh * dh;
    // |L| is not differentiable at 0: use the zero subgradient there.
    let g_lap = if len > 0.0 {
        l * (0.5 * kappa * dh * sign / len)
    } else {
        DVec3::ZERO
    };
    (energy, g_lap, 0.5 * kappa * dh * dh - kappa * dh * h)
}

/// The bending force as gathers: each vertex sums its faces' terms in
/// ascending face order ([`Incidence`]), which are the additions the face
/// loops make into it, in the same order, so the same bits as
/// [`bending_open`] and [`bending_measured`]; every pass runs in parallel and
/// only the energy is summed on one thread, in vertex order.
struct Gathered<'a> {
    faces: &'a [[u32; 3]],
    geometry: &'a [Corners],
    incidence: &'a Incidence,
    boundary: Option<&'a [bool]>,
}

impl Gathered<'_> {
    /// Σ over vertices of `vertex(A_i, L_i, N_i) = (energy, ∂H/∂L_i,
    /// ∂H/∂A_i)` (N_i is zero unless `normals`), adding −∇H to `force`.
    fn bending(
        &self,
        s: &mut BendingScratch,
        force: &mut [DVec3],
        normals: bool,
        vertex: impl Fn(f64, DVec3, DVec3) -> (f64, DVec3, f64) + Sync + Send,
    ) -> f64 {
        use crate::util::parallel::{fill_vec, gather};
        let (faces, geometry, incidence) = (self.faces, self.geometry, self.incidence);
        let boundary = self.boundary;
        // Each vertex's A_i, L_i (and N_i) from its faces' corners, formed
        // here rather than stored per face: the face loop's sums, from
        // zero, in face order.
        fill_vec(&mut s.vertex_terms, force.len(), |i| {
            if boundary.is_some_and(|b| b[i]) {
                return (None, DVec3::ZERO, 0.0);
            }
            let (mut a, mut l, mut nrm) = (0.0, DVec3::ZERO, DVec3::ZERO);
            for &e in incidence.of(i) {
                let (f, k) = ((e >> 2) as usize, (e & 3) as usize);
                let c = &geometry[f];
                a += c.mixed_area(k);
                l += c.laplacian_at(k);
                if normals {
                    nrm += c.n_hat * c.twice_area;
                }
            }
            let (energy, g_lap, g_area) = vertex(a, l, nrm);
            (Some(energy), g_lap, g_area)
        });
        let vertex_terms = &s.vertex_terms;
        let (energy, ()) = rayon::join(
            || {
                let mut energy = 0.0;
                for (e, _, _) in vertex_terms {
                    if let Some(e) = e {
                        energy += e;
                    }
                }
                energy
            },
            || {
                fill_vec(&mut s.face_pull_backs, faces.len(), |k| {
                    let [i0, i1, i2] = faces[k].map(|v| v as usize);
                    let [t0, t1, t2] = [vertex_terms[i0], vertex_terms[i1], vertex_terms[i2]];
                    geometry[k].backward([t0.1, t1.1, t2.1], [t0.2, t1.2, t2.2])
                })
            },
        );
        gather(incidence, &s.face_pull_backs, force, |f, g| *f -= g);
        energy
    }
}

/// Adds −(∂H/∂L · ∂L/∂r + ∂H/∂A · ∂A/∂r) to `force`, face by face (on a
/// large mesh the faces' pull-backs in parallel, added in face order).
fn pull_back(
    faces: &[[u32; 3]],
    geometry: &[Corners],
    s: &mut BendingScratch,
    force: &mut [DVec3],
) {
    if crate::util::parallel::splits(faces.len()) {
        let (g_lap, g_area) = (&s.g_lap, &s.g_area);
        let gradient = |k: usize| {
            let [i0, i1, i2] = faces[k].map(|v| v as usize);
            let g = geometry[k].backward(
                [g_lap[i0], g_lap[i1], g_lap[i2]],
                [g_area[i0], g_area[i1], g_area[i2]],
            );
            (0.0, g)
        };
        crate::util::parallel::accumulate(faces, force, &mut s.face_gradients, gradient, |f, g| {
            *f -= g
        });
        return;
    }
    for (f, c) in faces.iter().zip(geometry) {
        let (i0, i1, i2) = (f[0] as usize, f[1] as usize, f[2] as usize);
        let grad = c.backward(
            [s.g_lap[i0], s.g_lap[i1], s.g_lap[i2]],
            [s.g_area[i0], s.g_area[i1], s.g_area[i2]],
        );
        force[i0] -= grad[0];
        force[i1] -= grad[1];
        force[i2] -= grad[2];
    }
}

/// Bending energy ½κ A (h − C0)² of vertex `v` over the faces `ring` (those
/// containing v), with h = s|L|/(2A) as in [`bending`].
fn vertex_energy(p: &[DVec3], v: u32, ring: &[[u32; 3]], kappa: f64, c0: f64) -> f64 {
    let (mut area, mut lap, mut nrm) = (0.0, DVec3::ZERO, DVec3::ZERO);
    for f in ring {
        let k = f
            .iter()
            .position(|&x| x == v)
            .expect("ring face contains v");
        let c = Corners::new(p[f[0] as usize], p[f[1] as usize], p[f[2] as usize]);
        area += c.mixed_areas()[k];
        lap += c.laplacian()[k];
        nrm += c.n_hat * c.twice_area;
    }
    let len = lap.length();
    let sign = if lap.dot(nrm) < 0.0 { -1.0 } else { 1.0 };
    let h = sign * len / (2.0 * area);
    0.5 * kappa * area * (h - c0) * (h - c0)
}

/// The change of the cotangent bending energy when `flip` is taken at
/// `positions`: only the vertices a, b, c and d change their rings, so it
/// is the change of their four vertex energies (a boundary vertex of an
/// open mesh has none, and adds nothing). `c0` gives each vertex's
/// spontaneous curvature (1/l̄; a constant for [`bending`], a field for
/// [`bending_varying`]).
pub fn flip_energy_change(
    positions: &[DVec3],
    topology: &crate::mesh::topology::Topology,
    flip: &crate::mesh::flip::Flip,
    kappa: f64,
    c0: impl Fn(u32) -> f64,
) -> f64 {
    let (old, new) = (flip.old_faces(), flip.new_faces());
    let mut energy = 0.0;
    let mut ring = Vec::with_capacity(12);
    for v in [flip.a, flip.b, flip.c, flip.d] {
        if topology.is_boundary_vertex(v as usize) {
            continue;
        }
        ring.clear();
        ring.extend(
            topology
                .ring_faces_of(v as usize)
                .iter()
                .filter(|&&f| f != flip.faces[0] && f != flip.faces[1])
                .map(|&f| topology.faces[f as usize]),
        );
        let kept = ring.len();
        ring.extend(old.iter().filter(|f| f.contains(&v)));
        let before = vertex_energy(positions, v, &ring, kappa, c0(v));
        ring.truncate(kept);
        ring.extend(new.iter().filter(|f| f.contains(&v)));
        let after = vertex_energy(positions, v, &ring, kappa, c0(v));
        energy += after - before;
    }
    energy
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

/// The bending force system.
pub struct BendingForces {
    params: BendingParams,
    scratch: BendingScratch,
    dihedral: DihedralScratch,
    /// Boundary vertices by slot (empty on a closed mesh), for the
    /// topology of `boundary_for` (structure epoch; vertex, edge and face
    /// counts).
    boundary: Vec<bool>,
    boundary_for: Option<(u64, usize, usize, usize)>,
}

impl BendingForces {
    /// A bending system with the given modulus and spontaneous curvature.
    pub fn new(params: BendingParams) -> Self {
        Self {
            params,
            scratch: BendingScratch::default(),
            dihedral: DihedralScratch::default(),
            boundary: Vec::new(),
            boundary_for: None,
        }
    }
}

impl ForceTerm for BendingForces {
    fn name(&self) -> &str {
        "bending"
    }

    fn uses_face_geometry(&self) -> bool {
        true
    }

    /// The energy, and with `force` its negative gradient added to it.
    fn evaluate(&mut self, ctx: &ForceContext<'_>, force: Option<&mut [DVec3]>) -> f64 {
        let t = ctx.topology;
        let key = (t.epoch, t.vertex_count(), t.edges.len(), t.faces.len());
        if self.boundary_for != Some(key) {
            self.boundary_for = Some(key);
            self.boundary.clear();
            if t.is_open() {
                self.boundary = t.boundary_mask();
            }
        }
        let p = &self.params;
        // The force's face loops as gathers where the vertices split (the
        // gathers are loops over them; on a smaller mesh whose topology
        // changes every tick, flipped by Metropolis, rebuilding the
        // incidence would cost more than the gathers save).
        let incidence = (force.is_some() && crate::util::parallel::splits(t.vertex_count()))
            .then(|| t.face_incidence());
        // The tick's measure where a system has published it for these
        // positions (the same sums: the same bits).
        let published = ctx
            .inputs
            .get::<MeasuredSurface>()
            .filter(|m| m.is_of(ctx.positions, t.epoch, p.discretisation))
            .map(|m| &m.terms);
        match p.discretisation {
            BendingDiscretisation::Cotangent => {
                let measured = incidence.is_none()
                    && published
                        .and_then(|m| m.cotangent())
                        .map(|(a, l, n)| self.scratch.copy_measure(a, l, n))
                        .is_some();
                bending_open_in(
                    ctx.positions.len(),
                    &ctx.topology.faces,
                    ctx.face_geometry,
                    p.kappa,
                    p.c0,
                    (!self.boundary.is_empty()).then_some(&self.boundary[..]),
                    incidence.as_deref(),
                    measured,
                    &mut self.scratch,
                    force,
                )
            }
            BendingDiscretisation::Dihedral => {
                let published = published.map(|m| m.dihedral());
                if published.is_none() {
                    self.dihedral
                        .measure_mut()
                        .measure(ctx.positions, t, ctx.face_geometry);
                }
                bending_dihedral_measured(
                    ctx.positions,
                    t,
                    ctx.face_geometry,
                    p.kappa,
                    p.c0,
                    &mut self.dihedral,
                    published,
                    force,
                )
            }
        }
    }

    /// The cotangent form's change at the four vertices whose rings the
    /// flip changes; `None` for the dihedral form (priced whole).
    fn flip_energy_change(&mut self, proposal: &FlipProposal<'_>) -> Option<f64> {
        let p = &self.params;
        (p.discretisation == BendingDiscretisation::Cotangent).then(|| {
            crate::energy::bending::flip_energy_change(
                proposal.before.positions,
                proposal.before.topology,
                &proposal.flip,
                p.kappa,
                |_| p.c0,
            )
        })
    }
}

/// The bending rigidity κ (Ē) that bounds the explicit step where no V_in
/// does (inserted by [`plugin`]; the largest κ if several terms
/// insert one).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BendingRigidity(pub f64);

/// Helfrich bending.
pub fn plugin(params: BendingParams) -> impl Plugin {
    move |b: &mut SimBuilder| {
        b.add_force_term(BendingForces::new(params))?;
        // The stiffest bending term bounds the explicit step (without V_in).
        let kappa = b.resources().get::<BendingRigidity>().map_or(0.0, |k| k.0);
        b.insert_resource(BendingRigidity(kappa.max(params.kappa)));
        Ok(())
    }
}

impl crate::energy::builtin::BuiltinTerm for BendingParams {
    /// Both forms are correct on open meshes: boundary vertices carry no
    /// bending energy of their own (see the module docs and
    /// [`crate::energy::bending_dihedral`]).
    const CORRECT_ON_OPEN_MESHES: bool = true;

    fn plugin(&self, _context: crate::energy::builtin::TermContext) -> impl Plugin {
        plugin(*self)
    }

    /// Its κ (the Sobolev metric's scale, the adhered vesicle's κ).
    fn needs(&self) -> crate::energy::builtin::TermNeeds {
        crate::energy::builtin::TermNeeds {
            bending_rigidity: Some(self.kappa),
            ..Default::default()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::energy::bending_measure::{Surface, VertexTerms};
    use crate::engine::term_inputs::TermInputs;
    use crate::mesh::geometry::face_geometry;
    use crate::mesh::membrane::Membrane;

    /// With a published measure of the same positions the bending gives the
    /// same bits as measuring itself, in both forms (and the cotangent
    /// form with and without a spontaneous curvature, two paths); a measure
    /// of other positions, or in the other form, is not used.
    #[test]
    fn a_published_measure_is_read_for_its_own_positions_only() {
        let mesh = crate::fd::perturbed_icosphere(2, 5);
        let mut m = Membrane::from_mesh(&mesh, false).unwrap();
        let t = m.topology().unwrap().clone();
        let at = |positions: &[DVec3]| {
            let mut geometry = Vec::new();
            face_geometry(positions, &t.faces, &mut geometry);
            geometry
        };
        let geometry = at(&mesh.positions);
        let moved: Vec<DVec3> = mesh.positions.iter().map(|p| *p * 1.01).collect();
        let published = |positions: &[DVec3], form, label: &[DVec3]| {
            let geometry = at(positions);
            let mut rim = Vec::new();
            let mut terms = VertexTerms::default();
            terms.measure(Surface::new(positions, &t, &geometry, &mut rim), form);
            let mut inputs = TermInputs::default();
            inputs.insert(MeasuredSurface {
                positions: label.to_vec(),
                epoch: t.epoch,
                terms,
            });
            inputs
        };
        let (dihedral, cotangent) = (
            BendingDiscretisation::Dihedral,
            BendingDiscretisation::Cotangent,
        );
        for (form, c0) in [(dihedral, 0.3), (cotangent, 0.3), (cotangent, 0.0)] {
            let other_form = if form == dihedral {
                cotangent
            } else {
                dihedral
            };
            let evaluate = |inputs: &TermInputs| {
                let mut term = BendingForces::new(BendingParams {
                    kappa: 2.0,
                    c0,
                    discretisation: form,
                });
                let (e, force) = crate::fd::evaluate_with_inputs(
                    &mut term,
                    &m.world,
                    &t,
                    &mesh.positions,
                    &geometry,
                    inputs,
                );
                let mut bits = vec![e.to_bits()];
                bits.extend(force.iter().flat_map(|v| v.to_array().map(f64::to_bits)));
                bits
            };
            let own = evaluate(TermInputs::none());
            let same = published(&mesh.positions, form, &mesh.positions);
            assert_eq!(evaluate(&same), own, "{form:?}, C0 {c0}");
            assert_eq!(evaluate(&published(&moved, form, &moved)), own);
            let other = published(&mesh.positions, other_form, &mesh.positions);
            assert_eq!(evaluate(&other), own);
            // Were the other positions' measure used, the result would differ.
            let mislabeled = published(&moved, form, &mesh.positions);
            assert_ne!(evaluate(&mislabeled), own, "{form:?}, C0 {c0}");
        }
    }
}
