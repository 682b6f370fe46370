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

use glam::DVec3;

/// Per-face quantities at the three corners of triangle (p0, p1, p2).
#[derive(Clone, Copy, Debug)]
pub struct Corners {
    /// Positions of the three corners.
    pub p: [DVec3; 3],
    /// Unnormalised normal (p1 − p0) × (p2 − p0); its length is twice the area.
    pub n: DVec3,
    /// Twice the face area.
    pub twice_area: f64,
    /// Cotangent of the interior angle at each corner.
    pub cot: [f64; 3],
}

impl Corners {
    /// Computes normal, area and corner cotangents.
    #[inline]
    pub fn new(p0: DVec3, p1: DVec3, p2: DVec3) -> Self {
        let p = [p0, p1, p2];
        let n = (p1 - p0).cross(p2 - p0);
        let twice_area = n.length();
        let cot = [0, 1, 2].map(|k| {
            let u = p[(k + 1) % 3] - p[k];
            let v = p[(k + 2) % 3] - p[k];
            u.dot(v) / twice_area
        });
        Self {
            p,
            n,
            twice_area,
            cot,
        }
    }

    /// Face area.
    #[inline]
    pub fn area(&self) -> f64 {
        0.5 * self.twice_area
    }

    /// Mixed (Meyer) area contribution of this face to each corner.
    #[inline]
    pub fn mixed_areas(&self) -> [f64; 3] {
        let obtuse = self.obtuse_corner();
        [0, 1, 2].map(|k| match obtuse {
            None => {
                let (i, j) = ((k + 1) % 3, (k + 2) % 3);
                0.125
                    * (self.cot[j] * self.p[k].distance_squared(self.p[i])
                        + self.cot[i] * self.p[k].distance_squared(self.p[j]))
            }
            Some(o) if o == k => 0.5 * self.area(),
            Some(_) => 0.25 * self.area(),
        })
    }

    /// Index of the obtuse corner, if any (cotangent < 0).
    #[inline]
    pub fn obtuse_corner(&self) -> Option<usize> {
        (0..3).find(|&k| self.cot[k] < 0.0)
    }

    /// This face's contribution to the cotangent Laplacian
    /// L_k = Σ (cot α + cot β)(p_k − p_j) of each corner.
    #[inline]
    pub fn laplacian(&self) -> [DVec3; 3] {
        [0, 1, 2].map(|k| {
            let (i, j) = ((k + 1) % 3, (k + 2) % 3);
            self.cot[j] * (self.p[k] - self.p[i]) + self.cot[i] * (self.p[k] - self.p[j])
        })
    }

    /// Reverse-mode derivative: given adjoints `g_lap[k]` of the corner
    /// Laplacian contributions and `g_area[k]` of the corner mixed areas,
    /// returns ∂/∂p_k of Σ_k (g_lap[k]·L_k + g_area[k]·A_k).
    #[inline]
    pub fn backward(&self, g_lap: [DVec3; 3], g_area: [f64; 3]) -> [DVec3; 3] {
        let p = &self.p;
        let mut grad = [DVec3::ZERO; 3];
        let mut g_cot = [0.0f64; 3];
        let mut g_face_area = 0.0;
        let obtuse = self.obtuse_corner();
        for k in 0..3 {
            let (i, j) = ((k + 1) % 3, (k + 2) % 3);
            let d_ki = p[k] - p[i];
            let d_kj = p[k] - p[j];
            // Laplacian: L_k = cot_j d_ki + cot_i d_kj.
            let gl = g_lap[k];
            g_cot[j] += gl.dot(d_ki);
            g_cot[i] += gl.dot(d_kj);
            grad[k] += gl * (self.cot[j] + self.cot[i]);
            grad[i] -= gl * self.cot[j];
            grad[j] -= gl * self.cot[i];
            // Mixed area.
            let ga = g_area[k];
            match obtuse {
                None => {
                    g_cot[j] += 0.125 * ga * d_ki.length_squared();
                    g_cot[i] += 0.125 * ga * d_kj.length_squared();
                    let a = 0.25 * ga * self.cot[j] * d_ki;
                    let b = 0.25 * ga * self.cot[i] * d_kj;
                    grad[k] += a + b;
                    grad[i] -= a;
                    grad[j] -= b;
                }
                Some(o) if o == k => g_face_area += 0.5 * ga,
                Some(_) => g_face_area += 0.25 * ga,
            }
        }
        let n_hat = self.n / self.twice_area;
        // Cotangents: cot_k = (u·v)/|u×v|, u = p_{k+1} − p_k, v = p_{k+2} − p_k.
        for k in 0..3 {
            if g_cot[k] == 0.0 {
                continue;
            }
            let (i, j) = ((k + 1) % 3, (k + 2) % 3);
            let u = p[i] - p[k];
            let v = p[j] - p[k];
            let c = self.twice_area;
            let cot = self.cot[k];
            let d_u = (v - cot * v.cross(n_hat)) / c;
            let d_v = (u - cot * n_hat.cross(u)) / c;
            grad[i] += g_cot[k] * d_u;
            grad[j] += g_cot[k] * d_v;
            grad[k] -= g_cot[k] * (d_u + d_v);
        }
        if g_face_area != 0.0 {
            let g = face_area_gradient(p, n_hat);
            for k in 0..3 {
                grad[k] += g_face_area * g[k];
            }
        }
        grad
    }
}

/// ∂(area)/∂p_k of triangle `p` with unit normal `n_hat`:
/// ½ n̂ × (p_{k+2} − p_{k+1}).
#[inline]
pub fn face_area_gradient(p: &[DVec3; 3], n_hat: DVec3) -> [DVec3; 3] {
    [0, 1, 2].map(|k| 0.5 * n_hat.cross(p[(k + 2) % 3] - p[(k + 1) % 3]))
}

/// Total triangle area of a mesh.
pub fn total_area(positions: &[DVec3], faces: &[[u32; 3]]) -> f64 {
    faces
        .iter()
        .map(|f| {
            let [a, b, c] = f.map(|v| positions[v as usize]);
            0.5 * (b - a).cross(c - a).length()
        })
        .sum()
}

/// Enclosed volume of a closed, outward-oriented mesh (sum of signed
/// tetrahedra against `origin`; any origin gives the same value up to
/// round-off, a nearby one is better conditioned).
pub fn enclosed_volume(positions: &[DVec3], faces: &[[u32; 3]], origin: DVec3) -> f64 {
    faces
        .iter()
        .map(|f| {
            let [a, b, c] = f.map(|v| positions[v as usize] - origin);
            a.dot(b.cross(c))
        })
        .sum::<f64>()
        / 6.0
}

/// Reduced volume v = 6√π V / A^{3/2} (1 for a sphere).
pub fn reduced_volume(volume: f64, area: f64) -> f64 {
    6.0 * std::f64::consts::PI.sqrt() * volume / area.powf(1.5)
}

/// Per-vertex mixed Voronoi areas A_i, cotangent Laplacians L_i and
/// area-weighted normals N_i (unnormalised), accumulated face by face.
pub fn vertex_curvature_terms(
    positions: &[DVec3],
    faces: &[[u32; 3]],
    areas: &mut Vec<f64>,
    laplacians: &mut Vec<DVec3>,
    normals: &mut Vec<DVec3>,
) {
    let n = positions.len();
    areas.clear();
    areas.resize(n, 0.0);
    laplacians.clear();
    laplacians.resize(n, DVec3::ZERO);
    normals.clear();
    normals.resize(n, DVec3::ZERO);
    for f in faces {
        let c = Corners::new(
            positions[f[0] as usize],
            positions[f[1] as usize],
            positions[f[2] as usize],
        );
        let a = c.mixed_areas();
        let l = c.laplacian();
        for k in 0..3 {
            let v = f[k] as usize;
            areas[v] += a[k];
            laplacians[v] += l[k];
            normals[v] += c.n;
        }
    }
}

/// Mean-curvature vector K_i = L_i / (2 A_i) of every vertex.
pub fn curvature_vectors(positions: &[DVec3], faces: &[[u32; 3]]) -> Vec<DVec3> {
    let (mut a, mut l, mut n) = (Vec::new(), Vec::new(), Vec::new());
    vertex_curvature_terms(positions, faces, &mut a, &mut l, &mut n);
    l.iter().zip(&a).map(|(l, a)| *l / (2.0 * a)).collect()
}
