//! Geometry kernels on dense arrays: face areas, cotangents, mixed Voronoi
//! areas, cotangent curvature vectors, volume, and their reverse-mode
//! derivatives.
//!
//! Mixed areas follow Meyer et al. (2003) exactly (piecewise): a non-obtuse
//! triangle gives each corner its Voronoi area, an obtuse one gives the obtuse
//! corner half the triangle and the others a quarter. The areas are
//! continuous across the switch and differentiable away from right angles,
//! which is where forces are evaluated in practice; their sum over a closed
//! mesh always equals the total triangle area.
//!
//! Conventions for a face (p0, p1, p2): edge e_k is opposite corner k,
//! e0 = p2 − p1, e1 = p0 − p2, e2 = p1 − p0 (so e0 + e1 + e2 = 0), the normal
//! is n = e1 × e2 = (p1 − p0) × (p2 − p0), and cot_k = −(e_{k+1}·e_{k+2}) / |n|.
//! Kernels are written out per corner (no closures over `[0, 1, 2]`): array
//! maps in these loops compile to out-of-line calls that cost ~5× here.

use glam::DVec3;

/// Per-face quantities of triangle (p0, p1, p2): everything the face-based
/// energy terms need, so each face pays its square root and division once.
#[derive(Clone, Copy, Debug, Default)]
pub struct Corners {
    /// Edge vectors opposite each corner: p2 − p1, p0 − p2, p1 − p0.
    pub e: [DVec3; 3],
    /// Unit outward normal n̂ = n/|n|, n = (p1 − p0) × (p2 − p0).
    pub n_hat: DVec3,
    /// Twice the face area, |n|.
    pub twice_area: f64,
    /// 1 / |n|.
    pub inv_twice_area: f64,
    /// Cotangent of the interior angle at each corner.
    pub cot: [f64; 3],
}

impl Corners {
    /// Computes edges, normal, area and corner cotangents.
    #[inline(always)]
    pub fn new(p0: DVec3, p1: DVec3, p2: DVec3) -> Self {
        let e0 = p2 - p1;
        let e1 = p0 - p2;
        let e2 = p1 - p0;
        let n = e1.cross(e2);
        let twice_area = n.length();
        let inv = 1.0 / twice_area;
        let cot = [-e1.dot(e2) * inv, -e2.dot(e0) * inv, -e0.dot(e1) * inv];
        Self {
            e: [e0, e1, e2],
            n_hat: n * inv,
            twice_area,
            inv_twice_area: inv,
            cot,
        }
    }

    /// Face area.
    #[inline(always)]
    pub fn area(&self) -> f64 {
        0.5 * self.twice_area
    }

    /// Index of the obtuse corner, if any (cotangent < 0).
    #[inline(always)]
    pub fn obtuse_corner(&self) -> Option<usize> {
        if self.cot[0] < 0.0 {
            Some(0)
        } else if self.cot[1] < 0.0 {
            Some(1)
        } else if self.cot[2] < 0.0 {
            Some(2)
        } else {
            None
        }
    }

    /// Mixed (Meyer) area contribution of this face to each corner.
    #[inline(always)]
    pub fn mixed_areas(&self) -> [f64; 3] {
        match self.obtuse_corner() {
            None => {
                let s0 = self.cot[0] * self.e[0].length_squared();
                let s1 = self.cot[1] * self.e[1].length_squared();
                let s2 = self.cot[2] * self.e[2].length_squared();
                [0.125 * (s1 + s2), 0.125 * (s2 + s0), 0.125 * (s0 + s1)]
            }
            Some(o) => {
                let quarter = 0.125 * self.twice_area;
                let mut a = [quarter; 3];
                a[o] = 2.0 * quarter;
                a
            }
        }
    }

    /// This face's contribution to the cotangent Laplacian
    /// L_k = Σ (cot α + cot β)(p_k − p_j) of each corner: with w_k = cot_k e_k,
    /// L0 = w1 − w2, L1 = w2 − w0, L2 = w0 − w1.
    #[inline(always)]
    pub fn laplacian(&self) -> [DVec3; 3] {
        let w0 = self.cot[0] * self.e[0];
        let w1 = self.cot[1] * self.e[1];
        let w2 = self.cot[2] * self.e[2];
        [w1 - w2, w2 - w0, w0 - w1]
    }

    /// ∫ x dA over corner `k`'s part of the mixed (Meyer) cell of the
    /// triangle `p` (whose geometry this is): the Voronoi quadrilateral (corner, edge
    /// midpoints, circumcentre) of a non-obtuse triangle; in an obtuse one the
    /// corner triangle of the two edge midpoints (a quarter of the area), and
    /// the rest for the obtuse corner (half). Its area is
    /// [`Corners::mixed_area`]'s (up to round-off).
    pub fn mixed_cell_moment(&self, p: [DVec3; 3], k: usize) -> DVec3 {
        let tri =
            |a: DVec3, b: DVec3, d: DVec3| 0.5 * (b - a).cross(d - a).length() * (a + b + d) / 3.0;
        let (a, b) = ((k + 1) % 3, (k + 2) % 3);
        let (ma, mb) = (0.5 * (p[k] + p[a]), 0.5 * (p[k] + p[b]));
        match self.obtuse_corner() {
            None => {
                let (u, v) = (p[1] - p[0], p[2] - p[0]);
                let n = u.cross(v);
                let o = p[0]
                    + (u.length_squared() * v.cross(n) + v.length_squared() * n.cross(u))
                        / (2.0 * n.length_squared());
                tri(p[k], ma, o) + tri(p[k], o, mb)
            }
            Some(o) if o == k => {
                let corner = |j: usize| {
                    let (x, y) = ((j + 1) % 3, (j + 2) % 3);
                    tri(p[j], 0.5 * (p[j] + p[x]), 0.5 * (p[j] + p[y]))
                };
                tri(p[0], p[1], p[2]) - corner(a) - corner(b)
            }
            Some(_) => tri(p[k], ma, mb),
        }
    }

    /// Corner `k`'s entry of [`Corners::mixed_areas`], by the same
    /// expressions (the same bits) without the other two.
    #[inline(always)]
    pub fn mixed_area(&self, k: usize) -> f64 {
        match self.obtuse_corner() {
            None => {
                let (a, b) = ((k + 1) % 3, (k + 2) % 3);
                let sa = self.cot[a] * self.e[a].length_squared();
                let sb = self.cot[b] * self.e[b].length_squared();
                // (Addition commutes exactly: s2 + s0 is s0 + s2.)
                0.125 * (sa + sb)
            }
            Some(o) => {
                let quarter = 0.125 * self.twice_area;
                if o == k { 2.0 * quarter } else { quarter }
            }
        }
    }

    /// Corner `k`'s entry of [`Corners::laplacian`], by the same
    /// expressions: w_{k+1} − w_{k+2}.
    #[inline(always)]
    pub fn laplacian_at(&self, k: usize) -> DVec3 {
        let (a, b) = ((k + 1) % 3, (k + 2) % 3);
        self.cot[a] * self.e[a] - self.cot[b] * self.e[b]
    }

    /// Reverse-mode derivative: given adjoints `g_lap[k]` of the corner
    /// Laplacian contributions and `g_area[k]` of the corner mixed areas,
    /// returns ∂/∂p_k of Φ = Σ_k (`g_lap[k]`·L_k + `g_area[k]`·A_k).
    ///
    /// With G_k = g_lap[k+2] − g_lap[k+1] and, for a non-obtuse face,
    /// H_k = (g_area[k+1] + g_area[k+2]) / 8: Φ = Σ_k cot_k (G_k·e_k + H_k|e_k|²)
    /// (+ the face-area share for an obtuse face).
    #[inline(always)]
    pub fn backward(&self, g_lap: [DVec3; 3], g_area: [f64; 3]) -> [DVec3; 3] {
        let [e0, e1, e2] = self.e;
        let [c0, c1, c2] = self.cot;
        let g0 = g_lap[2] - g_lap[1];
        let g1 = g_lap[0] - g_lap[2];
        let g2 = g_lap[1] - g_lap[0];
        let obtuse = self.obtuse_corner();
        let (h0, h1, h2, g_face_area) = match obtuse {
            None => (
                0.125 * (g_area[1] + g_area[2]),
                0.125 * (g_area[2] + g_area[0]),
                0.125 * (g_area[0] + g_area[1]),
                0.0,
            ),
            Some(o) => (
                0.0,
                0.0,
                0.0,
                0.25 * (g_area[0] + g_area[1] + g_area[2] + g_area[o]),
            ),
        };
        // Adjoints of the cotangents and the direct edge gradients.
        let gc0 = g0.dot(e0) + h0 * e0.length_squared();
        let gc1 = g1.dot(e1) + h1 * e1.length_squared();
        let gc2 = g2.dot(e2) + h2 * e2.length_squared();
        let mut ge0 = c0 * (g0 + 2.0 * h0 * e0);
        let mut ge1 = c1 * (g1 + 2.0 * h1 * e1);
        let mut ge2 = c2 * (g2 + 2.0 * h2 * e2);
        // cot_k = −(a·b)/|a × b| with a = e_{k+1}, b = e_{k+2}:
        // ∂cot_k/∂a = −(b + cot_k b × n̂)/|n|, ∂cot_k/∂b = −(a − cot_k a × n̂)/|n|;
        // only the three q_j = e_j × n̂ are needed.
        let inv = self.inv_twice_area;
        let n_hat = self.n_hat;
        let (q0, q1, q2) = (e0.cross(n_hat), e1.cross(n_hat), e2.cross(n_hat));
        let (s0, s1, s2) = (gc0 * inv, gc1 * inv, gc2 * inv);
        ge0 -= s1 * (e2 - c1 * q2) + s2 * (e1 + c2 * q1);
        ge1 -= s0 * (e2 + c0 * q2) + s2 * (e0 - c2 * q0);
        ge2 -= s0 * (e1 - c0 * q1) + s1 * (e0 + c1 * q0);
        // e0 = p2 − p1, e1 = p0 − p2, e2 = p1 − p0.
        let mut grad = [ge1 - ge2, ge2 - ge0, ge0 - ge1];
        if g_face_area != 0.0 {
            // ∂(area)/∂p_k = ½ n̂ × e_k = −½ q_k.
            let s = -0.5 * g_face_area;
            grad[0] += s * q0;
            grad[1] += s * q1;
            grad[2] += s * q2;
        }
        grad
    }
}

impl Corners {
    /// Reverse-mode derivative of Φ = Σ_k `g_cot[k]`·cot_k: returns ∂Φ/∂p_k
    /// (the cotangents' part of [`Corners::backward`], for energies that
    /// weight the cotangents by something other than the Laplacian and the
    /// mixed areas, e.g. a Dirichlet energy Σ ½cot_k (φ_a − φ_b)²).
    #[inline]
    pub fn cot_backward(&self, g_cot: [f64; 3]) -> [DVec3; 3] {
        let [e0, e1, e2] = self.e;
        let [c0, c1, c2] = self.cot;
        let inv = self.inv_twice_area;
        let n_hat = self.n_hat;
        let (q0, q1, q2) = (e0.cross(n_hat), e1.cross(n_hat), e2.cross(n_hat));
        let (s0, s1, s2) = (g_cot[0] * inv, g_cot[1] * inv, g_cot[2] * inv);
        // As in `backward`: ∂cot_k/∂e_{k+1} = −(e_{k+2} + cot_k e_{k+2} × n̂)/|n|,
        // ∂cot_k/∂e_{k+2} = −(e_{k+1} − cot_k e_{k+1} × n̂)/|n|.
        let ge0 = -(s1 * (e2 - c1 * q2) + s2 * (e1 + c2 * q1));
        let ge1 = -(s0 * (e2 + c0 * q2) + s2 * (e0 - c2 * q0));
        let ge2 = -(s0 * (e1 - c0 * q1) + s1 * (e0 + c1 * q0));
        [ge1 - ge2, ge2 - ge0, ge0 - ge1]
    }
}

/// ∂(area)/∂p_k of triangle `p` with unit normal `n_hat`:
/// ½ n̂ × (p_{k+2} − p_{k+1}).
#[inline]
pub fn face_area_gradient(p: &[DVec3; 3], n_hat: DVec3) -> [DVec3; 3] {
    [
        0.5 * n_hat.cross(p[2] - p[1]),
        0.5 * n_hat.cross(p[0] - p[2]),
        0.5 * n_hat.cross(p[1] - p[0]),
    ]
}

#[inline(always)]
fn corners(positions: &[DVec3], f: &[u32; 3]) -> (DVec3, DVec3, DVec3) {
    (
        positions[f[0] as usize],
        positions[f[1] as usize],
        positions[f[2] as usize],
    )
}

/// Total triangle area of a mesh.
pub fn total_area(positions: &[DVec3], faces: &[[u32; 3]]) -> f64 {
    let mut twice = 0.0;
    for f in faces {
        let (a, b, c) = corners(positions, f);
        twice += (b - a).cross(c - a).length();
    }
    0.5 * twice
}

/// Enclosed volume of a closed, outward-oriented mesh (sum of signed
/// tetrahedra against `origin`; any origin gives the same value up to
/// round-off, a nearby one is better conditioned).
pub fn enclosed_volume(positions: &[DVec3], faces: &[[u32; 3]], origin: DVec3) -> f64 {
    let mut six = 0.0;
    for f in faces {
        let (a, b, c) = corners(positions, f);
        six += (a - origin).dot((b - origin).cross(c - origin));
    }
    six / 6.0
}

/// Reduced volume v = 6√π V / A^{3/2} (1 for a sphere).
pub fn reduced_volume(volume: f64, area: f64) -> f64 {
    6.0 * std::f64::consts::PI.sqrt() * volume / area.powf(1.5)
}

/// Computes the [`Corners`] of every face into `out` (resized), in
/// parallel.
pub fn face_geometry(positions: &[DVec3], faces: &[[u32; 3]], out: &mut Vec<Corners>) {
    crate::util::parallel::fill_vec(out, faces.len(), |k| {
        let (p0, p1, p2) = corners(positions, &faces[k]);
        Corners::new(p0, p1, p2)
    });
}

/// Per-vertex mixed Voronoi areas A_i and cotangent Laplacians L_i, and,
/// with `normals = Some`, area-weighted normals N_i (unnormalised),
/// accumulated from the faces' precomputed [`Corners`]. Buffers are resized
/// and overwritten.
pub fn vertex_curvature_terms(
    faces: &[[u32; 3]],
    geometry: &[Corners],
    areas: &mut Vec<f64>,
    laplacians: &mut Vec<DVec3>,
    normals: Option<&mut Vec<DVec3>>,
    vertex_count: usize,
) {
    accumulate_curvature_terms(
        faces,
        |k| geometry[k],
        areas,
        laplacians,
        normals,
        vertex_count,
    );
}

/// [`vertex_curvature_terms`] with each face's [`Corners`] computed from
/// `corners(k)` as the faces are visited, in face order (the same sums,
/// bit for bit, whether the geometry is stored or computed on the fly).
fn accumulate_curvature_terms(
    faces: &[[u32; 3]],
    corners: impl Fn(usize) -> Corners,
    areas: &mut Vec<f64>,
    laplacians: &mut Vec<DVec3>,
    mut normals: Option<&mut Vec<DVec3>>,
    vertex_count: usize,
) {
    areas.clear();
    areas.resize(vertex_count, 0.0);
    laplacians.clear();
    laplacians.resize(vertex_count, DVec3::ZERO);
    if let Some(nb) = normals.as_deref_mut() {
        nb.clear();
        nb.resize(vertex_count, DVec3::ZERO);
    }
    for (k, f) in faces.iter().enumerate() {
        let c = corners(k);
        let a = c.mixed_areas();
        let l = c.laplacian();
        let (i0, i1, i2) = (f[0] as usize, f[1] as usize, f[2] as usize);
        areas[i0] += a[0];
        areas[i1] += a[1];
        areas[i2] += a[2];
        laplacians[i0] += l[0];
        laplacians[i1] += l[1];
        laplacians[i2] += l[2];
        if let Some(nb) = normals.as_deref_mut() {
            let n = c.n_hat * c.twice_area;
            nb[i0] += n;
            nb[i1] += n;
            nb[i2] += n;
        }
    }
}

/// The mixed Voronoi area A_i of every vertex of the mesh `faces` at
/// `positions` and the centroid of its cell (the point whose value a cell
/// average holds to second order).
pub fn vertex_cells(positions: &[DVec3], faces: &[[u32; 3]]) -> (Vec<f64>, Vec<DVec3>) {
    let n = positions.len();
    let (mut areas, mut moments) = (vec![0.0; n], vec![DVec3::ZERO; n]);
    for f in faces {
        let p = f.map(|v| positions[v as usize]);
        let c = Corners::new(p[0], p[1], p[2]);
        for k in 0..3 {
            areas[f[k] as usize] += c.mixed_area(k);
            moments[f[k] as usize] += c.mixed_cell_moment(p, k);
        }
    }
    let centroids = moments
        .iter()
        .zip(&areas)
        .map(|(m, a)| if *a > 0.0 { *m / *a } else { DVec3::ZERO })
        .collect();
    (areas, centroids)
}

/// Mean-curvature vector K_i = L_i / (2 A_i) of every vertex.
/// Each face's geometry is computed as its turn comes, not stored: a frame
/// of a large mesh does not hold a second copy of every face's [`Corners`].
pub fn curvature_vectors(positions: &[DVec3], faces: &[[u32; 3]]) -> Vec<DVec3> {
    let (mut a, mut l) = (Vec::new(), Vec::new());
    let corners_of = |k: usize| {
        let (p0, p1, p2) = corners(positions, &faces[k]);
        Corners::new(p0, p1, p2)
    };
    accumulate_curvature_terms(faces, corners_of, &mut a, &mut l, None, positions.len());
    l.iter().zip(&a).map(|(l, a)| *l / (2.0 * a)).collect()
}

/// One edge at the tick's positions: its vector d = r_b − r_a (l̄), its
/// length |d| (l̄) and the segment of a piecewise edge potential that the
/// length falls in (V_in's, [`crate::energy::vin::VinEdgeSamples`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct EdgeSample {
    /// r_b − r_a for the edge [a, b] (l̄).
    pub d: DVec3,
    /// |d| (l̄).
    pub length: f64,
    /// The potential's segment of the length
    /// ([`crate::energy::vin::Segmentation::segment_of`]).
    pub segment: u32,
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The three mixed cells partition the triangle: their moments add up
    /// to ∫ x dA = A (p0 + p1 + p2)/3, for an acute, a right and an obtuse
    /// triangle.
    #[test]
    fn the_mixed_cells_partition_the_triangle() {
        for p in [
            [
                DVec3::ZERO,
                DVec3::new(1.0, 0.1, 0.0),
                DVec3::new(0.4, 0.9, 0.2),
            ],
            [DVec3::ZERO, DVec3::X, DVec3::Y],
            [
                DVec3::ZERO,
                DVec3::new(2.0, 0.0, 0.0),
                DVec3::new(0.3, 0.2, 0.1),
            ],
        ] {
            let c = Corners::new(p[0], p[1], p[2]);
            let moment: DVec3 = (0..3).map(|k| c.mixed_cell_moment(p, k)).sum();
            let expected = c.area() * (p[0] + p[1] + p[2]) / 3.0;
            assert!(
                (moment - expected).length() <= 1e-14,
                "{moment:?} {expected:?}"
            );
        }
    }
}
