//! A uniform grid over the vertices' bounding box with the vertices
//! counting-sorted by cell (slot order within a cell), rebuilt in O(N) per
//! use: the spatial index behind self-avoidance's pair search and the
//! control points' nearest-vertex search.

use glam::{DVec3, IVec3, UVec3};

/// Most grid cells per vertex before the cells are made coarser (a
/// stretched shape's bounding box can be mostly empty).
const MAX_CELLS_PER_VERTEX: f64 = 32.0;

/// The grid and its reusable buffers.
#[derive(Clone, Debug, Default)]
pub struct CellList {
    start: Vec<u32>,
    members: Vec<u32>,
    cell_of: Vec<u32>,
    fill: Vec<u32>,
    lo: DVec3,
    size: f64,
    dims: UVec3,
}

impl CellList {
    /// Sorts `positions` into cells no smaller than `min_size` (l̄); cells
    /// grow by 1.5× while the grid would exceed 32 cells per vertex.
    pub fn build(&mut self, positions: &[DVec3], min_size: f64) {
        let n = positions.len();
        let lo = positions.iter().copied().fold(DVec3::INFINITY, DVec3::min);
        let hi = positions
            .iter()
            .copied()
            .fold(DVec3::NEG_INFINITY, DVec3::max);
        let extent = if n == 0 { DVec3::ZERO } else { hi - lo };
        let mut size = min_size;
        let dims = |size: f64| (extent / size).floor().as_uvec3() + UVec3::ONE;
        while {
            let d = dims(size).as_dvec3();
            d.x * d.y * d.z > MAX_CELLS_PER_VERTEX * n as f64 + 27.0
        } {
            size *= 1.5;
        }
        self.lo = if n == 0 { DVec3::ZERO } else { lo };
        self.size = size;
        self.dims = dims(size);
        let total = self.cell_count();
        self.start.clear();
        self.start.resize(total + 1, 0);
        self.cell_of.clear();
        for &p in positions {
            let c = self.index(self.cell(p)) as u32;
            self.cell_of.push(c);
            self.start[c as usize + 1] += 1;
        }
        for c in 0..total {
            self.start[c + 1] += self.start[c];
        }
        self.members.clear();
        self.members.resize(n, 0);
        self.fill.clear();
        self.fill.extend_from_slice(&self.start);
        for (i, &c) in self.cell_of.iter().enumerate() {
            self.members[self.fill[c as usize] as usize] = i as u32;
            self.fill[c as usize] += 1;
        }
    }

    /// Cell edge length (l̄).
    pub fn size(&self) -> f64 {
        self.size
    }

    fn cell_count(&self) -> usize {
        (self.dims.x * self.dims.y * self.dims.z) as usize
    }

    fn index(&self, c: UVec3) -> usize {
        ((c.x * self.dims.y + c.y) * self.dims.z + c.z) as usize
    }

    /// The cell holding `p` (points outside the box go to the nearest
    /// boundary cell).
    pub fn cell(&self, p: DVec3) -> UVec3 {
        ((p - self.lo) / self.size)
            .max(DVec3::ZERO)
            .floor()
            .as_uvec3()
            .min(self.dims - UVec3::ONE)
    }

    /// The vertices in cell `c` + `offset`, in slot order (empty outside
    /// the grid).
    pub fn members(&self, c: UVec3, offset: IVec3) -> &[u32] {
        let q = c.as_ivec3() + offset;
        if q.min_element() < 0 || q.cmpge(self.dims.as_ivec3()).any() {
            return &[];
        }
        let q = self.index(q.as_uvec3());
        &self.members[self.start[q] as usize..self.start[q + 1] as usize]
    }

    /// The vertex nearest to `point` by squared distance, ties to the
    /// lowest slot: exactly the brute-force scan's answer. `guess` is any
    /// vertex (e.g. the last answer); every vertex no farther than it lies
    /// in the cells of the box around `point` that the search visits.
    pub fn nearest(&self, positions: &[DVec3], point: DVec3, guess: usize) -> usize {
        // (A hair wider than the guess's distance, so rounding in the square
        // root cannot leave an equally near vertex outside.)
        let reach = positions[guess].distance_squared(point).sqrt() * (1.0 + 1e-9);
        let (a, b) = (self.cell(point - reach), self.cell(point + reach));
        let span = (b - a + UVec3::ONE).as_dvec3();
        if span.x * span.y * span.z > positions.len() as f64 {
            // The box covers more cells than there are vertices: scan.
            return nearest_by_scan(positions, point);
        }
        let mut best = (positions[guess].distance_squared(point), guess);
        for x in a.x..=b.x {
            for y in a.y..=b.y {
                for z in a.z..=b.z {
                    for &j in self.members(UVec3::new(x, y, z), IVec3::ZERO) {
                        let d = positions[j as usize].distance_squared(point);
                        if d < best.0 || (d == best.0 && (j as usize) < best.1) {
                            best = (d, j as usize);
                        }
                    }
                }
            }
        }
        best.1
    }
}

/// Index of the vertex nearest to `point` (ties: lowest index), by
/// checking every vertex.
pub fn nearest_by_scan(positions: &[DVec3], point: DVec3) -> usize {
    let mut best = (f64::INFINITY, 0);
    for (i, p) in positions.iter().enumerate() {
        let d = p.distance_squared(point);
        if d < best.0 {
            best = (d, i);
        }
    }
    best.1
}
