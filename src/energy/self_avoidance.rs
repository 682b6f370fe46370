//! Self-avoidance: a short-range repulsion between vertices that are not
//! 1-ring neighbours, so that two regions of the membrane pressed together
//! cannot pass through each other.
//!
//! E = Σ_{i<j, j ∉ ring(i), r_ij < d0} k (d0 − r_ij)³ / (3 d0), a cubic
//! overlap penalty: zero with its force and the force's derivative at
//! r = d0 (C², so finite differences and the integrator see no kink);
//! F_i = k (d0 − r_ij)² / d0 · r̂_ij pushes i away from j. Pairs are found with a uniform cell list of cell
//! size d0 (27 cells per vertex), visited in a fixed order (vertex slots,
//! then cells, then slots within a cell), so the sums are reproducible.

use glam::DVec3;

/// Reusable buffers of the cell list: a dense grid over the bounding box,
/// vertices counting-sorted by cell (slot order within a cell).
#[derive(Clone, Debug, Default)]
pub struct CellList {
    start: Vec<u32>,
    members: Vec<u32>,
    cell_of: Vec<u32>,
}

/// Most grid cells per vertex before the cells are made coarser (a
/// stretched shape's bounding box can be mostly empty).
const MAX_CELLS_PER_VERTEX: f64 = 32.0;

/// The self-avoidance energy (Ē) with stiffness `k` (Ē/l̄²) and range `d0`
/// (l̄); with `force`, adds −∇E. `ring_offsets`/`ring` are the 1-rings
/// (CSR by vertex slot) whose pairs are excluded.
pub fn self_avoidance(
    positions: &[DVec3],
    ring_offsets: &[u32],
    ring: &[u32],
    k: f64,
    d0: f64,
    cells: &mut CellList,
    mut force: Option<&mut [DVec3]>,
) -> f64 {
    let n = positions.len();
    if n == 0 {
        return 0.0;
    }
    let lo = positions.iter().copied().fold(DVec3::INFINITY, DVec3::min);
    let hi = positions
        .iter()
        .copied()
        .fold(DVec3::NEG_INFINITY, DVec3::max);
    // Cells no smaller than d0, so the 27 cells around a vertex hold every
    // vertex within d0 of it.
    let extent = hi - lo;
    let mut size = d0;
    let dims = |size: f64| (extent / size).floor().as_uvec3() + glam::UVec3::ONE;
    while {
        let d = dims(size).as_dvec3();
        d.x * d.y * d.z > MAX_CELLS_PER_VERTEX * n as f64 + 27.0
    } {
        size *= 1.5;
    }
    let d = dims(size);
    let index = |c: glam::UVec3| ((c.x * d.y + c.y) * d.z + c.z) as usize;
    let cell = |p: DVec3| {
        ((p - lo) / size)
            .floor()
            .as_uvec3()
            .min(d - glam::UVec3::ONE)
    };
    let total = (d.x * d.y * d.z) as usize;
    cells.start.clear();
    cells.start.resize(total + 1, 0);
    cells.cell_of.clear();
    for &p in positions {
        let c = index(cell(p)) as u32;
        cells.cell_of.push(c);
        cells.start[c as usize + 1] += 1;
    }
    for c in 0..total {
        cells.start[c + 1] += cells.start[c];
    }
    cells.members.clear();
    cells.members.resize(n, 0);
    let mut fill = cells.start.clone();
    for (i, &c) in cells.cell_of.iter().enumerate() {
        cells.members[fill[c as usize] as usize] = i as u32;
        fill[c as usize] += 1;
    }
    let d0_sq = d0 * d0;
    let mut energy = 0.0;
    for (i, &p) in positions.iter().enumerate() {
        let c = cell(p).as_ivec3();
        let neighbours = &ring[ring_offsets[i] as usize..ring_offsets[i + 1] as usize];
        for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    let q = c + glam::IVec3::new(dx, dy, dz);
                    if q.min_element() < 0 || q.cmpge(d.as_ivec3()).any() {
                        continue;
                    }
                    let q = index(q.as_uvec3());
                    let members =
                        &cells.members[cells.start[q] as usize..cells.start[q + 1] as usize];
                    for &j in members {
                        if j as usize <= i || neighbours.contains(&j) {
                            continue;
                        }
                        let d = p - positions[j as usize];
                        let r_sq = d.length_squared();
                        if r_sq >= d0_sq {
                            continue;
                        }
                        let r = r_sq.sqrt();
                        let overlap = d0 - r;
                        energy += k * overlap * overlap * overlap / (3.0 * d0);
                        if let Some(f) = force.as_deref_mut()
                            && r > 0.0
                        {
                            let push = d * (k * overlap * overlap / (d0 * r));
                            f[i] += push;
                            f[j as usize] -= push;
                        }
                    }
                }
            }
        }
    }
    energy
}

/// The same energy by checking every pair (O(N²); a reference for tests).
pub fn self_avoidance_brute_force(
    positions: &[DVec3],
    ring_offsets: &[u32],
    ring: &[u32],
    k: f64,
    d0: f64,
) -> f64 {
    let mut energy = 0.0;
    for i in 0..positions.len() {
        let neighbours = &ring[ring_offsets[i] as usize..ring_offsets[i + 1] as usize];
        for j in i + 1..positions.len() {
            if neighbours.contains(&(j as u32)) {
                continue;
            }
            let r = positions[i].distance(positions[j]);
            if r < d0 {
                energy += k * (d0 - r).powi(3) / (3.0 * d0);
            }
        }
    }
    energy
}
