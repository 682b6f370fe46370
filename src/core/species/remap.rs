//! The fluid model's remap of the species under the mesh's slides (ALE).
//!
//! In the fluid model a vertex is not a material point: its tangential
//! motion (V_in's maintenance) slides the mesh over the membrane, and the
//! proteins stay where they are on the surface. Over a step each vertex i
//! moves by d_i; its tangential part t_i (the
//! part across the vertex normal) moves the boundary between the cells of
//! i and j, and the dual edge between them (of length w_ij ℓ_ij, w_ij the
//! cotangent weight) sweeps the area s_ij = w_ij (t_i + t_j)/2 · (x_j − x_i).
//! Where s_ij > 0 the cell of i has moved into what was j's: it takes
//! s_ij ρ_j (ρ = n/A, proteins per area, upwind), and j gives them; where
//! s_ij < 0 the reverse. What one cell gains another loses, so each count
//! holds to round-off; upwind keeps every amount positive while no cell
//! gives more than half of its area per pass (the remap is cut into as many
//! passes as that needs). Normal motion is the membrane's own and carries
//! its proteins; it is not remapped. (A remesh edit carries the amounts
//! of the cells it changes itself, as densities, and its relaxations of
//! the patch are not remapped.)

use crate::energy::bending::BendingDiscretisation;
use crate::energy::bending_measure::{Surface, vertex_areas};
use glam::DVec3;

/// The vertex positions at the start of a tick (written at the Gather
/// stage, read after the step to measure each vertex's displacement; the
/// remesh's edits, later in the tick, carry the amounts themselves).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SlideAnchors {
    /// The topology's epoch then: the positions are by its dense slots.
    pub epoch: u64,
    /// The positions (l̄).
    pub positions: Vec<DVec3>,
}

/// What a remap moved.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Remapped {
    /// Passes taken.
    pub passes: u32,
    /// The largest tangential displacement of a vertex (l̄).
    pub largest_slide: f64,
}

/// Remaps the `amounts` (proteins, by species then dense slot) on
/// `surface` (after the step) under the vertices' displacements
/// `displacement` over the step (l̄, by dense slot), the cells measured in
/// the bending's `form`.
pub fn remap_slides(
    surface: Surface<'_>,
    form: BendingDiscretisation,
    amounts: &mut [Vec<f64>],
    displacement: &[DVec3],
) -> Remapped {
    let n = surface.vertex_count();
    let t = surface.topology;
    let areas = vertex_areas(&t.faces, surface.geometry, n, form);
    // The tangential displacements, against the area-weighted normals.
    let mut normals = vec![DVec3::ZERO; n];
    for (face, c) in t.faces.iter().zip(surface.geometry) {
        for &v in face {
            normals[v as usize] += c.twice_area * c.n_hat;
        }
    }
    let slides: Vec<DVec3> = displacement
        .iter()
        .zip(&normals)
        .map(|(d, m)| {
            let m = m.normalize_or_zero();
            *d - d.dot(m) * m
        })
        .collect();
    let largest_slide = slides.iter().map(|s| s.length()).fold(0.0, f64::max);
    // The cotangent weight of each edge (`face_edges[f][k]` joins corners
    // k and k + 1, opposite corner k + 2), at least 0.
    let mut weights = vec![0.0; t.edges.len()];
    for (edges, c) in t.face_edges.iter().zip(surface.geometry) {
        for k in 0..3 {
            weights[edges[(k + 1) % 3] as usize] += 0.5 * c.cot[k];
        }
    }
    let swept: Vec<f64> = t
        .edges
        .iter()
        .zip(&weights)
        .map(|(&[i, j], w)| {
            let (i, j) = (i as usize, j as usize);
            let along = surface.positions[j] - surface.positions[i];
            w.max(0.0) * 0.5 * (slides[i] + slides[j]).dot(along)
        })
        .collect();
    // The area each cell gives over the whole remap.
    let mut given = vec![0.0; n];
    for (&[i, j], &s) in t.edges.iter().zip(&swept) {
        if s > 0.0 {
            given[j as usize] += s;
        } else {
            given[i as usize] -= s;
        }
    }
    let worst = given
        .iter()
        .zip(&areas)
        .map(|(g, a)| g / a)
        .fold(0.0, f64::max);
    let passes = (2.0 * worst).ceil().max(1.0) as u32;
    let share = 1.0 / f64::from(passes);
    // Each pass moves what the densities at its start give (all edges at
    // once, so no edge sees another's change).
    let mut moved = vec![0.0; t.edges.len()];
    for _ in 0..passes {
        for field in amounts.iter_mut() {
            for ((&[i, j], &s), m) in t.edges.iter().zip(&swept).zip(&mut moved) {
                let (i, j) = (i as usize, j as usize);
                let s = s * share;
                *m = match s > 0.0 {
                    true => s * field[j] / areas[j],
                    false => s * field[i] / areas[i],
                };
            }
            for (&[i, j], m) in t.edges.iter().zip(&moved) {
                field[i as usize] += m;
                field[j as usize] -= m;
            }
        }
    }
    Remapped {
        passes,
        largest_slide,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::geometry::face_geometry;
    use crate::mesh::membrane::Membrane;

    /// A field linear in x on a flat patch, its mesh slid rigidly along x
    /// by `shift`: the remapped amounts are those of the field at the moved
    /// cells (exact for a linear field, but for the upwind's error), and
    /// the count holds.
    #[test]
    fn a_rigid_slide_of_the_mesh_leaves_the_proteins_in_place() {
        let mesh = crate::mesh::disc(6.0, 1.0);
        let mut m = Membrane::from_mesh(&mesh, false).unwrap();
        let t = m.topology().unwrap().clone();
        let shift = DVec3::new(0.05, 0.0, 0.0);
        let moved: Vec<DVec3> = mesh.positions.iter().map(|p| *p + shift).collect();
        let mut geometry = Vec::new();
        face_geometry(&moved, &t.faces, &mut geometry);
        let boundary = t.boundary_mask();
        let surface = Surface {
            positions: &moved,
            topology: &t,
            geometry: &geometry,
            boundary: Some(&boundary),
        };
        let form = BendingDiscretisation::Cotangent;
        let areas = vertex_areas(&t.faces, &geometry, moved.len(), form);
        let field = |p: DVec3| 0.2 + 0.01 * p.x;
        // The amounts of the cells where they were (density at the old
        // cell centre), then the mesh moves on by `shift`.
        let mut amounts = vec![
            mesh.positions
                .iter()
                .zip(&areas)
                .map(|(p, a)| a * field(*p))
                .collect::<Vec<f64>>(),
        ];
        let count: f64 = amounts[0].iter().sum();
        let done = remap_slides(surface, form, &mut amounts, &vec![shift; moved.len()]);
        assert_eq!(done.passes, 1);
        assert!((done.largest_slide - 0.05).abs() < 1e-12);
        let after: f64 = amounts[0].iter().sum();
        assert!(((after - count) / count).abs() < 1e-14);
        // Inside (away from the rim, which gains and loses nothing), the
        // density is the field at the new position to within a fifth of
        // the error of dragging the proteins with the mesh (0.01 · 0.05).
        let worst = moved
            .iter()
            .enumerate()
            .filter(|(_, p)| p.length() < 4.0)
            .map(|(i, p)| (amounts[0][i] / areas[i] - field(*p)).abs())
            .fold(0.0, f64::max);
        assert!(worst < 0.2 * 5e-4, "{worst}");
    }
}
