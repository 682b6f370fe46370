//! The transfer of density fields ([`TransferPolicy::Density`]) through an
//! edit: a field whose value is an amount at a vertex and whose amount per
//! vertex area (its density, e.g. a protein fraction) is the smooth field
//! on the surface, each vertex's value the average over its mixed cell.
//!
//! The patch is every vertex whose cell the edit changes: the vertices of
//! its removed and added faces, and the neighbours of a vertex it moves (a
//! merge's survivor deforms the faces the edit keeps around it too); no
//! other cell changes. Over the patch the density is fitted as a linear
//! field (least squares in the patch's plane, at the old cells' centroids).
//! A vertex that stays keeps its density, shifted along the fit to its new
//! cell's centroid; a new or moved vertex takes the fit at its cell's
//! centroid; then the patch's amounts are scaled so that their sum is what
//! it was. The sum over the mesh is kept to round-off, and a smooth field
//! stays smooth under splits, merges and flips on any triangulation
//! (unlike [`TransferPolicy::Conserve`]'s fixed shares, which hold the
//! density only on regular meshes).

use super::PatchEdit;
use crate::mesh::components::Position;
use crate::mesh::geometry::Corners;
use crate::mesh::membrane::Membrane;
use crate::mesh::topology::NO_SLOT;
use crate::mesh::vertex_field::TransferPolicy;
use glam::DVec3;
use hecs::Entity;

/// The density fields' values at the vertices of a patch before its edit.
pub(super) struct DensitySnapshot {
    /// The density fields, by index in the membrane's field list.
    fields: Vec<usize>,
    /// The vertices whose cells the edit changes: those of the removed
    /// faces and of the faces around a moved vertex.
    vertices: Vec<Entity>,
    /// Their amounts, by field then vertex.
    amounts: Vec<Vec<f64>>,
    /// Their mixed areas (l̄²).
    areas: Vec<f64>,
    /// The centroids of their cells.
    centroids: Vec<DVec3>,
    /// The patch's normal (area-weighted, of the removed faces).
    normal: DVec3,
}

/// The mixed Voronoi area of `v` (l̄²) and the centroid of its cell, from
/// its faces in the cached topology ((0, 0) for a vertex not in it).
fn vertex_cell(m: &Membrane, v: Entity) -> (f64, DVec3) {
    let t = m.cached_topology();
    let Some(slot) = t.vertex_slot(v) else {
        return (0.0, DVec3::ZERO);
    };
    let position = |s: u32| {
        let e = t.vertex_entities[s as usize];
        m.world.get::<&Position>(e).map_or(DVec3::ZERO, |p| p.0)
    };
    let (mut area, mut moment) = (0.0, DVec3::ZERO);
    for &f in t.ring_faces_of(slot as usize) {
        if f == NO_SLOT {
            continue;
        }
        let tri = t.faces[f as usize];
        let k = tri
            .iter()
            .position(|&s| s == slot)
            .expect("a ring face holds its vertex");
        let p = tri.map(position);
        let c = Corners::new(p[0], p[1], p[2]);
        area += c.mixed_area(k);
        moment += c.mixed_cell_moment(p, k);
    }
    (
        area,
        if area > 0.0 {
            moment / area
        } else {
            DVec3::ZERO
        },
    )
}

/// The least-squares gradient (in the plane normal to `normal`) of the
/// densities `rho` at the points `at` weighted by `weights`, about their
/// weighted means; zero when the points do not span the plane.
fn fitted_gradient(rho: &[f64], at: &[DVec3], weights: &[f64], normal: DVec3) -> DVec3 {
    let (t1, t2) = normal.normalize_or_zero().any_orthonormal_pair();
    let w: f64 = weights.iter().sum();
    let mean_x = at.iter().zip(weights).map(|(x, w)| *x * *w).sum::<DVec3>() / w;
    let mean_r = rho.iter().zip(weights).map(|(r, w)| r * w).sum::<f64>() / w;
    let (mut m, mut r) = ([0.0; 3], [0.0; 2]);
    for ((x, rho), w) in at.iter().zip(rho).zip(weights) {
        let d = *x - mean_x;
        let (u, v) = (d.dot(t1), d.dot(t2));
        m[0] += w * u * u;
        m[1] += w * u * v;
        m[2] += w * v * v;
        r[0] += w * (rho - mean_r) * u;
        r[1] += w * (rho - mean_r) * v;
    }
    let det = m[0] * m[2] - m[1] * m[1];
    if det <= 1e-12 * (m[0] * m[2]).max(f64::MIN_POSITIVE) {
        return DVec3::ZERO;
    }
    let gu = (m[2] * r[0] - m[1] * r[1]) / det;
    let gv = (m[0] * r[1] - m[1] * r[0]) / det;
    gu * t1 + gv * t2
}

impl DensitySnapshot {
    /// The snapshot before `edit` on `m` (whose topology cache is current),
    /// or `None` when no density field is registered.
    pub(super) fn before(m: &Membrane, edit: &PatchEdit) -> Option<Self> {
        let fields: Vec<usize> = (m.fields().iter().enumerate())
            .filter(|(_, f)| f.policy() == TransferPolicy::Density)
            .map(|(k, _)| k)
            .collect();
        if fields.is_empty() {
            return None;
        }
        let t = m.cached_topology();
        let mut vertices = Vec::with_capacity(16);
        for &f in &edit.remove_faces {
            let s = t.slot(f).expect("a checked edit removes existing faces") as usize;
            for v in t.faces[s] {
                let e = t.vertex_entities[v as usize];
                if !vertices.contains(&e) {
                    vertices.push(e);
                }
            }
        }
        // A moved vertex deforms every face around it, also those the edit
        // keeps: its neighbours' cells change too.
        for &(v, _) in &edit.move_vertices {
            if let Some(slot) = t.vertex_slot(v) {
                for &u in std::iter::once(&slot).chain(t.neighbours(slot as usize)) {
                    let e = t.vertex_entities[u as usize];
                    if !vertices.contains(&e) {
                        vertices.push(e);
                    }
                }
            }
        }
        let amounts = fields
            .iter()
            .map(|&k| {
                vertices
                    .iter()
                    .map(|&v| m.fields()[k].get(&m.world, v))
                    .collect()
            })
            .collect();
        let (areas, centroids) = vertices.iter().map(|&v| vertex_cell(m, v)).unzip();
        let position = |s: u32| {
            let e = t.vertex_entities[s as usize];
            m.world.get::<&Position>(e).map_or(DVec3::ZERO, |p| p.0)
        };
        let normal = edit
            .remove_faces
            .iter()
            .map(|&f| {
                let [a, b, c] = t.faces[t.slot(f).expect("checked") as usize].map(position);
                (b - a).cross(c - a)
            })
            .sum();
        Some(Self {
            fields,
            vertices,
            amounts,
            areas,
            centroids,
            normal,
        })
    }

    /// Sets the density fields on the patch of `edit`, now applied to `m`
    /// (its topology cache updated).
    pub(super) fn transfer(self, m: &mut Membrane, edit: &PatchEdit) {
        let mut after: Vec<Entity> = (self.vertices.iter())
            .filter(|v| !edit.remove_vertices.contains(v))
            .copied()
            .collect();
        for f in &edit.add_faces {
            for &v in f {
                if !after.contains(&v) {
                    after.push(v);
                }
            }
        }
        let (areas, centroids): (Vec<f64>, Vec<DVec3>) =
            after.iter().map(|&v| vertex_cell(m, v)).unzip();
        let before = |v: Entity| self.vertices.iter().position(|&u| u == v);
        let moved = |v: Entity| edit.move_vertices.iter().any(|&(u, _)| u == v);
        for (fi, &k) in self.fields.iter().enumerate() {
            let old = &self.amounts[fi];
            let rho: Vec<f64> = old
                .iter()
                .zip(&self.areas)
                .map(|(n, a)| if *a > 0.0 { n / a } else { 0.0 })
                .collect();
            let total: f64 = old.iter().sum();
            let area: f64 = self.areas.iter().sum();
            // The density as a linear field over the patch, fitted to the
            // cells' averages at their centroids (a cell average is the
            // value at the cell's centroid to second order).
            let g = fitted_gradient(&rho, &self.centroids, &self.areas, self.normal);
            let mean_x = self
                .centroids
                .iter()
                .zip(&self.areas)
                .map(|(x, a)| *x * *a)
                .sum::<DVec3>()
                / area;
            let linear = |x: DVec3| total / area + g.dot(x - mean_x);
            // A vertex that stays keeps its own density, moved to its new
            // cell's centroid along the gradient; a new or moved vertex
            // takes the linear field at its cell's centroid.
            let mut new: Vec<f64> = (0..after.len())
                .map(|i| {
                    let a = areas[i];
                    match before(after[i]) {
                        Some(j) if !moved(after[i]) => {
                            a * (rho[j] + g.dot(centroids[i] - self.centroids[j]))
                        }
                        _ => a * linear(centroids[i]),
                    }
                })
                .collect();
            // What round-off and the surface's curvature leave over is
            // spread by a common factor: the patch's sum is kept exactly.
            if new.iter().any(|&x| x <= 0.0) {
                // A steep gradient over a small cell: the first-order
                // transfer (each cell's density, new ones the patch mean).
                for (i, x) in new.iter_mut().enumerate() {
                    *x = areas[i]
                        * match before(after[i]) {
                            Some(j) if !moved(after[i]) => rho[j],
                            _ => total / area,
                        };
                }
            }
            let sum: f64 = new.iter().sum();
            if sum > 0.0 {
                new.iter_mut().for_each(|x| *x *= total / sum);
            }
            let field = std::sync::Arc::clone(&m.fields()[k]);
            for (&v, &x) in after.iter().zip(&new) {
                field.set(&mut m.world, v, x);
            }
        }
    }
}
