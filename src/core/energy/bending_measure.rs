//! The bending's measure of a surface: each vertex's area A_i and signed
//! total curvature h_i in the discretisation of the membrane's bending
//! ([`crate::energy::bending::BendingDiscretisation`]). The protein species
//! feel the surface through it, so that their coupling κ/2 (h − c φ)²
//! modifies the same curvature the bending term measures.
//!
//! - Cotangent: h_i = s|L_i|/(2A_i), L_i the cotangent Laplacian, A_i the
//!   mixed Voronoi area, s the sign of L_i against the vertex normal.
//! - Dihedral (Jülicher): h_i = 2M_i/A_i, M_i = ¼ Σ_{e∋i} ℓ_e θ_e, A_i the
//!   barycentric area ([`crate::energy::bending_dihedral`]).
//!
//! [`VertexTerms::pull_back`] turns the adjoints of a per-vertex energy
//! A_i f(h_i, …) into forces on the positions in either form.
//!
//! A system that measures the tick's positions publishes the measure in the
//! term inputs ([`MeasuredSurface`]: the species' relaxation does); the
//! species term and the dihedral bending then read it for the same
//! positions instead of measuring again.

use crate::energy::bending::BendingDiscretisation;
use crate::energy::bending_dihedral::{DihedralBuffers, DihedralMeasure};
use crate::mesh::geometry::{Corners, vertex_curvature_terms};
use crate::mesh::topology::Topology;
use glam::DVec3;

/// A fixed surface: what the species' free energy and the relaxation of
/// the fields read.
#[derive(Clone, Copy)]
pub struct Surface<'a> {
    /// The vertex positions by dense slot.
    pub positions: &'a [DVec3],
    /// The topology (faces by dense vertex slot, edges, rings).
    pub topology: &'a Topology,
    /// Per-face geometry at the positions.
    pub geometry: &'a [Corners],
    /// The rim vertices of an open mesh (no bending), or `None`.
    pub boundary: Option<&'a [bool]>,
}

impl<'a> Surface<'a> {
    /// The surface of `positions` on `topology` with its per-face
    /// `geometry`; an open mesh's rim is marked in `rim` (a buffer the
    /// caller keeps between calls), a closed mesh has none.
    pub fn new(
        positions: &'a [DVec3],
        topology: &'a Topology,
        geometry: &'a [Corners],
        rim: &'a mut Vec<bool>,
    ) -> Self {
        rim.clear();
        if topology.is_open() {
            *rim = topology.boundary_mask();
        }
        let rim: &'a Vec<bool> = rim;
        Self {
            positions,
            topology,
            geometry,
            boundary: (!rim.is_empty()).then_some(&rim[..]),
        }
    }

    /// The number of vertices.
    pub fn vertex_count(&self) -> usize {
        self.positions.len()
    }

    /// The faces by dense vertex slot.
    pub fn faces(&self) -> &[[u32; 3]] {
        &self.topology.faces
    }

    /// Whether vertex `i` carries the coupled bending (not on a rim).
    pub fn is_interior(&self, i: usize) -> bool {
        !self.boundary.is_some_and(|b| b[i])
    }
}

/// The signed total curvature h = s|L|/(2A) of a vertex with cotangent
/// Laplacian `l`, area-weighted normal `normal` and area `area`, with the
/// sign s (negative where L points against the normal) and |L|.
pub(crate) fn signed_curvature(l: DVec3, normal: DVec3, area: f64) -> (f64, f64, f64) {
    let len = l.length();
    let sign = if l.dot(normal) < 0.0 { -1.0 } else { 1.0 };
    (sign * len / (2.0 * area), sign, len)
}

/// The vertex areas A_i (l̄²) of the faces `geometry` in `form`: mixed
/// Voronoi (cotangent) or barycentric (dihedral).
pub fn vertex_areas(
    faces: &[[u32; 3]],
    geometry: &[Corners],
    n: usize,
    form: BendingDiscretisation,
) -> Vec<f64> {
    match form {
        BendingDiscretisation::Cotangent => {
            let (mut areas, mut laplacians) = (Vec::new(), Vec::new());
            vertex_curvature_terms(faces, geometry, &mut areas, &mut laplacians, None, n);
            areas
        }
        BendingDiscretisation::Dihedral => {
            let mut twice = vec![0.0; n];
            for (face, c) in faces.iter().zip(geometry) {
                for v in face {
                    twice[*v as usize] += c.twice_area;
                }
            }
            twice.into_iter().map(|t| t / 6.0).collect()
        }
    }
}

/// The measure of the surface at the tick's positions, which a system
/// (the species' relaxation) publishes in the term inputs so that the terms
/// evaluated next at the same positions (the species term, the dihedral
/// bending) do not measure them again.
#[derive(Clone, Debug, Default)]
pub struct MeasuredSurface {
    /// The positions measured (by dense slot).
    pub positions: Vec<DVec3>,
    /// The topology's epoch at the measure.
    pub epoch: u64,
    /// The measure.
    pub terms: VertexTerms,
}

impl MeasuredSurface {
    /// Publishes `terms`, the measure of `positions` on a topology of
    /// `epoch`, in the term `inputs` (inserting the value the first time):
    /// the measure is swapped in, and the caller gets the last one's buffers
    /// back to measure into next.
    pub fn publish(
        inputs: &mut crate::engine::term_inputs::TermInputs,
        terms: &mut VertexTerms,
        positions: &[DVec3],
        epoch: u64,
    ) {
        if inputs.get::<MeasuredSurface>().is_none() {
            inputs.insert(MeasuredSurface::default());
        }
        let published = inputs.get_mut::<MeasuredSurface>().expect("inserted above");
        std::mem::swap(&mut published.terms, terms);
        published.positions.clear();
        published.positions.extend_from_slice(positions);
        published.epoch = epoch;
    }

    /// Whether this measure is of `positions` (to the bit) on a topology of
    /// `epoch`, in `form`.
    pub fn is_of(&self, positions: &[DVec3], epoch: u64, form: BendingDiscretisation) -> bool {
        self.epoch == epoch
            && self.terms.form == form
            && self.positions.len() == positions.len()
            && self
                .positions
                .iter()
                .zip(positions)
                .all(|(a, b)| a.to_array().map(f64::to_bits) == b.to_array().map(f64::to_bits))
    }
}

/// Each vertex's area and curvature, with what the pull-back needs.
#[derive(Clone, Debug, Default)]
pub struct VertexTerms {
    /// A_i (l̄²).
    pub areas: Vec<f64>,
    /// h_i (1/l̄), 0 on a rim.
    pub curvature: Vec<f64>,
    form: BendingDiscretisation,
    /// Cotangent: L_i, N_i, and per vertex (s, |L|).
    laplacians: Vec<DVec3>,
    normals: Vec<DVec3>,
    signs: Vec<(f64, f64)>,
    dihedral: DihedralMeasure,
}

/// The buffers of [`VertexTerms::pull_back`], kept by its caller so that a
/// measure is only read.
#[derive(Clone, Debug, Default)]
pub struct PullBackBuffers {
    g_lap: Vec<DVec3>,
    g_m: Vec<f64>,
    g_a: Vec<f64>,
    dihedral: DihedralBuffers,
}

impl VertexTerms {
    /// The dihedral form's edge and vertex measure (empty in the cotangent
    /// form).
    pub fn dihedral(&self) -> &DihedralMeasure {
        &self.dihedral
    }

    /// The cotangent form's vertex areas, Laplacians L_i and area-weighted
    /// normals N_i (the sums of [`vertex_curvature_terms`]); `None` in the
    /// dihedral form.
    pub fn cotangent(&self) -> Option<(&[f64], &[DVec3], &[DVec3])> {
        (self.form == BendingDiscretisation::Cotangent).then_some((
            &self.areas[..],
            &self.laplacians[..],
            &self.normals[..],
        ))
    }

    /// Measures `surface` in `form`.
    pub fn measure(&mut self, surface: Surface<'_>, form: BendingDiscretisation) {
        let n = surface.vertex_count();
        self.form = form;
        self.curvature.clear();
        self.curvature.resize(n, 0.0);
        match form {
            BendingDiscretisation::Cotangent => {
                vertex_curvature_terms(
                    surface.faces(),
                    surface.geometry,
                    &mut self.areas,
                    &mut self.laplacians,
                    Some(&mut self.normals),
                    n,
                );
                self.signs.clear();
                for i in 0..n {
                    let (h, sign, len) =
                        signed_curvature(self.laplacians[i], self.normals[i], self.areas[i]);
                    self.signs.push((sign, len));
                    if surface.is_interior(i) {
                        self.curvature[i] = h;
                    }
                }
            }
            BendingDiscretisation::Dihedral => {
                let d = &mut self.dihedral;
                d.measure(surface.positions, surface.topology, surface.geometry);
                self.areas.clear();
                self.areas.extend_from_slice(d.areas());
                for (i, (m, a)) in d.integrated_curvature().iter().zip(d.areas()).enumerate() {
                    if surface.is_interior(i) {
                        self.curvature[i] = 2.0 * m / a;
                    }
                }
            }
        }
    }

    /// Subtracts ∇E from `force` for E = Σ_i A_i f_i, given per vertex
    /// `df_dh` = ∂f_i/∂h_i (ignored on a rim) and `g_area` = ∂E/∂A_i at
    /// fixed h_i minus h_i ∂f_i/∂h_i (the total ∂E/∂A_i through h as well),
    /// and optionally per face the adjoints `cot_adjoints` of its
    /// cotangents. The state is the last [`VertexTerms::measure`]'s; the
    /// caller's `buffers` take the intermediate adjoints.
    #[allow(clippy::too_many_arguments)]
    pub fn pull_back(
        &self,
        surface: Surface<'_>,
        df_dh: &[f64],
        g_area: &[f64],
        cot_adjoints: &[[f64; 3]],
        buffers: &mut PullBackBuffers,
        force: &mut [DVec3],
    ) {
        let n = surface.vertex_count();
        match self.form {
            BendingDiscretisation::Cotangent => {
                // h = s|L|/(2A): ∂(A f)/∂L = ½ f'(h) s L/|L|.
                let g_lap = &mut buffers.g_lap;
                g_lap.clear();
                g_lap.resize(n, DVec3::ZERO);
                for i in 0..n {
                    let (sign, len) = self.signs[i];
                    if surface.is_interior(i) && len > 0.0 {
                        g_lap[i] = self.laplacians[i] * (0.5 * df_dh[i] * sign / len);
                    }
                }
                let g_lap = &buffers.g_lap;
                for (fi, (face, c)) in surface.faces().iter().zip(surface.geometry).enumerate() {
                    let [i0, i1, i2] = face.map(|v| v as usize);
                    let mut g = c.backward(
                        [g_lap[i0], g_lap[i1], g_lap[i2]],
                        [g_area[i0], g_area[i1], g_area[i2]],
                    );
                    if let Some(gc) = cot_adjoints.get(fi) {
                        let extra = c.cot_backward(*gc);
                        for k in 0..3 {
                            g[k] += extra[k];
                        }
                    }
                    force[i0] -= g[0];
                    force[i1] -= g[1];
                    force[i2] -= g[2];
                }
            }
            BendingDiscretisation::Dihedral => {
                // h = 2M/A: ∂(A f)/∂M = 2 f'(h).
                let (g_m, g_a) = (&mut buffers.g_m, &mut buffers.g_a);
                g_m.resize(n, 0.0);
                g_a.resize(n, 0.0);
                for i in 0..n {
                    g_m[i] = if surface.is_interior(i) {
                        2.0 * df_dh[i]
                    } else {
                        0.0
                    };
                    g_a[i] = g_area[i];
                }
                self.dihedral.pull_back(
                    g_m,
                    g_a,
                    &mut buffers.dihedral,
                    surface.positions,
                    surface.topology,
                    surface.geometry,
                    force,
                );
                for (face, (c, gc)) in surface
                    .faces()
                    .iter()
                    .zip(surface.geometry.iter().zip(cot_adjoints))
                {
                    let g = c.cot_backward(*gc);
                    for (k, &v) in face.iter().enumerate() {
                        force[v as usize] -= g[k];
                    }
                }
            }
        }
    }
}
