//! Constant surface tension, E_σ = σ A with A = Σ face areas.
//!
//! Unlike the area penalty, whose tension 2 k_A (A − A_t)/A_t follows the
//! area, σ here is a fixed parameter: the membrane is in contact with a lipid
//! reservoir at tension σ (the setting of the tether-pulling theory,
//! Derényi, Jülicher & Prost, PRL 88, 238101 (2002)).

use crate::mesh::geometry::Corners;
use glam::DVec3;

/// Tension energy σA from the faces' precomputed geometry; with `force`,
/// adds −σ∇A.
pub fn surface_tension(
    faces: &[[u32; 3]],
    geometry: &[Corners],
    sigma: f64,
    force: Option<&mut [DVec3]>,
) -> f64 {
    let twice_area: f64 = geometry.iter().map(|c| c.twice_area).sum();
    let energy = sigma * 0.5 * twice_area;
    if let Some(force) = force {
        // ∂(2A_f)/∂p_k = n̂ × e_k with e_k the edge opposite corner k.
        let half_sigma = 0.5 * sigma;
        for (f, c) in faces.iter().zip(geometry) {
            for k in 0..3 {
                force[f[k] as usize] -= half_sigma * c.n_hat.cross(c.e[k]);
            }
        }
    }
    energy
}
