//! The Sobolev metric that preconditions the minimiser: directions
//! d = P⁻¹F instead of F, with P close to the energy's Hessian, so that
//! the number of iterations hardly grows with the resolution
//! (`../shared/reference/fast-equilibrium.md`; Schumacher 2017, Repulsive
//! Surfaces 2021, Packwood et al. 2016).
//!
//! Bending is a fourth-order operator: for normal displacements u its
//! Hessian is, to leading order, κ L M⁻¹ L, with L the cotangent Laplacian
//! (a stiffness matrix) and M the lumped (barycentric) vertex areas. So a
//! force is split at every vertex into its normal component f_n and its
//! tangential part f_t, and
//!
//! - the normal part is preconditioned by the H² operator
//!   P_n = s_n (L + εM) M⁻¹ (L + εM) = s_n (L M⁻¹ L + 2εL + ε²M),
//!   applied as s_n⁻¹ A⁻¹ M A⁻¹ with A = L + εM (two solves with one
//!   factor, as Repulsive Surfaces does);
//! - the tangential part, which in the fluid model carries only V_in's
//!   in-plane springs (a second-order operator), by the H¹ operator
//!   P_t = s_t A, one solve per Cartesian component, and is then
//!   returned to the tangent plane.
//!
//! ε = 4π/A (A the membrane's area: 1/R² on a sphere) makes A positive
//! definite and sets the scale beyond which the metric is L² (a vesicle's
//! size). A term much stiffer than bending where it acts (a contact
//! potential, a wall) adds its normal stiffness S_i
//! ([`ForceTerm::normal_stiffness`](crate::engine::force::ForceTerm::normal_stiffness))
//! to the diagonal: εM becomes EM with E_ii = ε + √(S_i / (s_n M_i)), so
//! that s_n A M⁻¹ A gains S_i at vertex i (its other new terms, s_n (L E +
//! E L), only stiffen the metric further there). The adhered vesicle then
//! converges in about 1100 iterations instead of 33 000.
//!
//! On a free closed membrane the normal block would move the normal
//! components of rigid motions (n·e, n·(e × (x − c)): three translations,
//! three rotations) almost for free: A is weakest on such smooth fields.
//! Moved along its normal alone, such a pattern is no rigid motion but one
//! plus a slide of the vertices in their planes, which V_in resists with a
//! stiffness that grows as 1/h² while the metric's stays. At 40962
//! vertices the direction then carried a translation-like pattern that
//! flipped sign every iteration and grew (the minimiser's uphill steps in
//! the last phase of the oblate; benches/RESULTS.md, 2026-12-07). With
//! [`SobolevMetric::stiffen_rigid_patterns`] the normal block becomes
//! P_n + β U Uᵀ, U the six patterns (M-weighted, normalised), β =
//! [`RIGID_PATTERN_STIFFNESS`] s_t ε: still positive definite (its fixed
//! point is still F = 0), applied by the Woodbury identity with the same
//! factor (six more columns solved at each build). The normal
//! component of a rigid motion changes no shape to first order, so nothing
//! the shape needs is slowed.
//!
//! Weights are |cot|/2 per face corner (capped at [`COT_CAP`]): an
//! obtuse corner would otherwise give a negative weight, and P need not
//! equal the Hessian, only be close to it and positive definite.
//!
//! A is factorised by faer's sparse Cholesky (fill-reducing ordering;
//! from [`SPLIT_FROM`](super::cholesky::SPLIT_FROM) vertices with solves
//! split over two subtrees, [`super::cholesky`], the same bits on any
//! thread count); the symbolic factor is kept while the topology's epoch
//! stays the same, the numeric one is rebuilt by the caller's schedule (a
//! stale metric is still a valid metric).
//!
//! [`SobolevMetric::direction`] keeps the exact constraints in the same
//! metric: with W = P⁻¹Jᵀ (J the rows ∇A, ∇V of the active constraints) it
//! returns d = P⁻¹F − Wμ with μ chosen so that J d = 0. A Euclidean
//! projection of P⁻¹F would break the constraints to first order.

use super::cholesky::{Factor, SymbolicFactor};
use crate::constraint::{ConstraintTargets, Gradients};
use crate::mesh::topology::Topology;
use faer::sparse::{SparseColMat, Triplet};
use glam::DVec3;
use std::time::{Duration, Instant};

/// Largest |cot| of a corner in the metric's Laplacian.
pub const COT_CAP: f64 = 100.0;

/// γ in β = γ s_t ε, the stiffness the metric gives the normal patterns
/// of rigid motions (per unit of their M-norm). A slide of the vertices
/// by a rigid motion's tangential part costs about 4 s_t ε in the
/// tangential block. Measured (benches/RESULTS.md, 2026-12-07): on the
/// oblate at 40962 vertices γ = 4, 40 and 400 gave the same iterations
/// (762 to the force tolerance against 1023 without); on the 642-vertex
/// prolate flow with remeshing γ = 0.4, 1, 4 and 40 took 498, 378, 393
/// and 613 iterations (485 without), the last stopped by the energy change.
pub const RIGID_PATTERN_STIFFNESS: f64 = 4.0;

/// The normal patterns of the six rigid motions in the metric
/// (the Woodbury form of P_n + β U Uᵀ).
#[derive(Default)]
struct RigidPatterns {
    /// U: six columns of n values, M p_k / |p_k|_M.
    columns: Vec<f64>,
    /// Y = A⁻¹ M A⁻¹ U (s_n P_n⁻¹ U).
    solved: Vec<f64>,
    /// G⁻¹ with G = (s_n/β) I + Uᵀ Y.
    inverse: [[f64; 6]; 6],
    /// β (Ē/l̄² per unit of M-norm).
    stiffness: f64,
}

impl RigidPatterns {
    /// y ← y − Y G⁻¹ Uᵀ y for one normal column y (in units of
    /// A⁻¹ M A⁻¹ f): P_n⁻¹ becomes (P_n + β U Uᵀ)⁻¹.
    fn correct(&self, y: &mut [f64]) {
        let n = y.len();
        let mut r = [0.0; 6];
        for (k, rk) in r.iter_mut().enumerate() {
            *rk = dot_slices(&self.columns[k * n..(k + 1) * n], y);
        }
        for k in 0..6 {
            let c: f64 = (0..6).map(|j| self.inverse[k][j] * r[j]).sum();
            for (x, w) in y.iter_mut().zip(&self.solved[k * n..(k + 1) * n]) {
                *x -= c * w;
            }
        }
    }

    /// β U Uᵀ u added to `out`, with u_i = `u(i)` the normal components
    /// (by vertex slot).
    fn apply(&self, u: impl Fn(usize) -> f64, out: &mut [f64]) {
        let n = out.len();
        for k in 0..6 {
            let column = &self.columns[k * n..(k + 1) * n];
            let c = self.stiffness
                * column
                    .iter()
                    .enumerate()
                    .map(|(i, w)| w * u(i))
                    .sum::<f64>();
            for (o, w) in out.iter_mut().zip(column) {
                *o += c * w;
            }
        }
    }
}

/// Σ a_i b_i in index order.
fn dot_slices(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// The two scales of the metric.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct MetricScales {
    /// s_n, the normal block's scale (Ē): the bending rigidity.
    pub normal: f64,
    /// s_t, the tangential block's scale (Ē/l̄²): the in-plane stiffness.
    pub tangential: f64,
}

/// Why the metric could not be built.
#[derive(Debug, thiserror::Error)]
pub enum MetricError {
    /// The sparse Cholesky factorisation failed (not positive definite, or
    /// out of memory).
    #[error("the Sobolev metric could not be factorised: {0}")]
    Factor(String),
}

/// The factorised metric and its scratch buffers.
#[derive(Default)]
pub struct SobolevMetric {
    /// Topology epoch and vertex count of the symbolic factor.
    key: Option<(u64, usize)>,
    symbolic: Option<SymbolicFactor>,
    factor: Option<Factor>,
    /// Whether the next [`build`](Self::build) stiffens the normal
    /// patterns of rigid motions (a free closed membrane; set by the
    /// caller, off by default).
    pub stiffen_rigid_patterns: bool,
    /// The stiffened patterns of the last build, if any.
    rigid: Option<RigidPatterns>,
    /// Lumped vertex areas at the build (l̄²).
    mass: Vec<f64>,
    scales: Option<MetricScales>,
    triplets: Vec<Triplet<usize, usize, f64>>,
    diagonal: Vec<f64>,
    /// E_ii, the diagonal shift at the build (ε plus the stiff terms' part).
    shifts: Vec<f64>,
    /// The columns being solved for: the normal components of the force
    /// and of the active constraints' gradients, then the force's
    /// tangential x, y and z components.
    rhs: Vec<f64>,
    normals: Vec<DVec3>,
    /// W_A, W_V: the preconditioned constraint gradients (normal parts).
    columns: [Vec<DVec3>; 2],
    /// [`apply`](Self::apply)'s products: A u, A M⁻¹ A u, and A of the
    /// tangential x, y, z components.
    products: [Vec<f64>; 5],
    /// Factorisations since creation (numeric).
    pub factorisations: u64,
    /// Symbolic analyses since creation (after each topology change).
    pub analyses: u64,
    /// Wall time spent in [`build`](Self::build) (assembly, analysis,
    /// factorisation and the constraint speeds).
    pub factor_time: Duration,
    /// Wall time spent in the triangular solves of
    /// [`direction`](Self::direction).
    pub solve_time: Duration,
}

impl std::fmt::Debug for SobolevMetric {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SobolevMetric")
            .field("key", &self.key)
            .field("scales", &self.scales)
            .field("factorisations", &self.factorisations)
            .finish()
    }
}

/// The cotangent of the corner at `o` of the triangle (o, a, b).
fn cot(o: DVec3, a: DVec3, b: DVec3) -> f64 {
    let (u, v) = (a - o, b - o);
    let s = u.cross(v).length();
    if s > 0.0 { u.dot(v) / s } else { COT_CAP }
}

/// √(S / (s_n M)): the part of E_ii that gives a vertex of mass `mass`
/// the stiffness `stiffness` in the normal block (0 without either).
fn local_shift(stiffness: Option<f64>, mass: f64, scales: MetricScales) -> f64 {
    match stiffness {
        Some(k) if k > 0.0 && mass > 0.0 => (k / (scales.normal * mass)).sqrt(),
        _ => 0.0,
    }
}

/// The active constraints of `gradients` (area, volume).
fn active(gradients: Option<(&Gradients, ConstraintTargets)>) -> [bool; 2] {
    gradients.map_or([false, false], |(_, t)| {
        [t.area.is_some(), t.volume.is_some()]
    })
}

impl SobolevMetric {
    /// Whether a factor has been built.
    pub fn is_built(&self) -> bool {
        self.factor.is_some()
    }

    /// Assembles A = L + EM at `positions` and factorises it (the symbolic
    /// analysis only when the topology changed since the last build).
    /// `stiffness` is the force terms' normal stiffness S by vertex slot
    /// (Ē/l̄², [`crate::engine::force::ForceTerm::normal_stiffness`]; empty
    /// for none): E_ii = ε + √(S_i / (s_n M_i)), so that the normal block's
    /// s_n E M E adds S_i at vertex i.
    pub fn build(
        &mut self,
        positions: &[DVec3],
        topology: &Topology,
        scales: MetricScales,
        stiffness: &[f64],
    ) -> Result<(), MetricError> {
        let start = Instant::now();
        let n = positions.len();
        let faces = &topology.faces;
        self.mass.clear();
        self.mass.resize(n, 0.0);
        self.diagonal.clear();
        self.diagonal.resize(n, 0.0);
        self.triplets.clear();
        let mut area = 0.0;
        // Off-diagonal weights, one entry per face edge (summed by faer in
        // this order), and the diagonal accumulated densely.
        for f in faces {
            let x = f.map(|v| positions[v as usize]);
            let a = 0.5 * (x[1] - x[0]).cross(x[2] - x[0]).length();
            area += a;
            for k in 0..3 {
                let (i, j, o) = (f[(k + 1) % 3] as usize, f[(k + 2) % 3] as usize, k);
                let w = 0.5 * cot(x[o], x[(k + 1) % 3], x[(k + 2) % 3]).abs().min(COT_CAP);
                let (hi, lo) = if i > j { (i, j) } else { (j, i) };
                self.triplets.push(Triplet::new(hi, lo, -w));
                self.diagonal[i] += w;
                self.diagonal[j] += w;
                self.mass[f[k] as usize] += a / 3.0;
            }
        }
        let shift = if area > 0.0 {
            4.0 * std::f64::consts::PI / area
        } else {
            1.0
        };
        self.shifts.clear();
        for (i, d) in self.diagonal.iter().enumerate() {
            let m = self.mass[i];
            let e = shift + local_shift(stiffness.get(i).copied(), m, scales);
            self.shifts.push(e);
            self.triplets.push(Triplet::new(i, i, d + e * m));
        }
        let matrix = SparseColMat::<usize, f64>::try_new_from_triplets(n, n, &self.triplets)
            .map_err(|e| MetricError::Factor(format!("{e:?}")))?;
        let key = (topology.epoch, n);
        if self.key != Some(key) || self.symbolic.is_none() {
            let symbolic = SymbolicFactor::new(matrix.symbolic()).map_err(MetricError::Factor)?;
            self.symbolic = Some(symbolic);
            self.key = Some(key);
            self.analyses += 1;
        }
        let symbolic = self.symbolic.as_ref().expect("analysed above");
        let mut factor = symbolic
            .factorise(matrix.as_ref())
            .map_err(MetricError::Factor)?;
        self.rigid = match self.stiffen_rigid_patterns && !topology.is_open() {
            true => Some(self.rigid_patterns(positions, topology, &mut factor, scales, shift)),
            false => None,
        };
        self.scales = Some(scales);
        self.factorisations += 1;
        self.factor = Some(factor);
        self.factor_time += start.elapsed();
        Ok(())
    }

    /// U, Y and G⁻¹ of the six rigid normal patterns at `positions`, with
    /// the numeric `factor` of A just built and ε = `shift`.
    fn rigid_patterns(
        &mut self,
        positions: &[DVec3],
        topology: &Topology,
        factor: &mut Factor,
        scales: MetricScales,
        shift: f64,
    ) -> RigidPatterns {
        let n = positions.len();
        crate::fluid::vertex_normals(positions, topology, &mut self.normals);
        let normals = &self.normals;
        let centre = positions.iter().copied().sum::<DVec3>() / n.max(1) as f64;
        let mut columns = vec![0.0; 6 * n];
        for (k, column) in columns.chunks_mut(n).enumerate() {
            let e = [DVec3::X, DVec3::Y, DVec3::Z][k % 3];
            let mut norm2 = 0.0;
            for (i, c) in column.iter_mut().enumerate() {
                let motion = if k < 3 {
                    e
                } else {
                    e.cross(positions[i] - centre)
                };
                let p = normals[i].dot(motion);
                *c = self.mass[i] * p;
                norm2 += self.mass[i] * p * p;
            }
            let scale = 1.0 / norm2.max(f64::MIN_POSITIVE).sqrt();
            column.iter_mut().for_each(|c| *c *= scale);
        }
        let mut solved = columns.clone();
        factor.solve_in_place(&mut solved, 6);
        for column in solved.chunks_mut(n) {
            for (x, m) in column.iter_mut().zip(&self.mass) {
                *x *= m;
            }
        }
        factor.solve_in_place(&mut solved, 6);
        let stiffness = RIGID_PATTERN_STIFFNESS * scales.tangential * shift;
        let g = faer::Mat::<f64>::from_fn(6, 6, |a, b| {
            let diagonal = if a == b {
                scales.normal / stiffness
            } else {
                0.0
            };
            diagonal + dot_slices(&columns[a * n..(a + 1) * n], &solved[b * n..(b + 1) * n])
        });
        let inverse = {
            use faer::linalg::solvers::DenseSolveCore;
            g.partial_piv_lu().inverse()
        };
        RigidPatterns {
            columns,
            solved,
            inverse: std::array::from_fn(|a| std::array::from_fn(|b| inverse[(a, b)])),
            stiffness,
        }
    }

    /// Whether `stiffness` (by vertex slot, as given to
    /// [`build`](Self::build)) asks at some vertex for more than twice the
    /// diagonal shift the factor was built with: a vertex that has come
    /// within a stiff term's range since the build, where the metric's
    /// steps would be far too long (on the paper model's adhered vesicle
    /// such a step carried a vertex through the wall). Always false
    /// without a factor or with another vertex count.
    pub fn underestimates(&self, stiffness: &[f64]) -> bool {
        let Some(scales) = self.scales else {
            return false;
        };
        if self.factor.is_none() || stiffness.len() != self.shifts.len() {
            return false;
        }
        stiffness
            .iter()
            .zip(&self.mass)
            .zip(&self.shifts)
            .any(|((&k, &m), &e)| local_shift(Some(k), m, scales) > 2.0 * e)
    }

    /// Whether the last build was for `topology` as it is now (the same
    /// epoch and vertex count).
    pub fn is_built_for(&self, topology: &Topology, n: usize) -> bool {
        self.factor.is_some() && self.key == Some((topology.epoch, n))
    }

    /// P v, the metric applied to `v` (by vertex slot) at the last build:
    /// s_n A M⁻¹ A (v·n) n + s_t (A v_t)_t with the normals at
    /// `positions`, written into `out`: the force whose preconditioned
    /// direction is `v` (sparse products, no solve). Only meaningful when
    /// [`is_built_for`](Self::is_built_for) the current topology.
    pub fn apply(
        &mut self,
        positions: &[DVec3],
        topology: &Topology,
        v: &[DVec3],
        out: &mut Vec<DVec3>,
    ) {
        let Some(scales) = self.scales else {
            panic!("SobolevMetric::apply before build");
        };
        let n = positions.len();
        crate::fluid::vertex_normals(positions, topology, &mut self.normals);
        let normals = &self.normals;
        // A as its lower triangle's triplets (duplicates summed by the
        // product as by the factorisation).
        let product = |x: &dyn Fn(usize) -> f64, y: &mut [f64]| {
            y.fill(0.0);
            for t in &self.triplets {
                let (i, j, w) = (t.row, t.col, t.val);
                if i == j {
                    y[i] += w * x(i);
                } else {
                    y[i] += w * x(j);
                    y[j] += w * x(i);
                }
            }
        };
        let [a, b, tx, ty, tz] = &mut self.products;
        for buffer in [&mut *a, &mut *b, &mut *tx, &mut *ty, &mut *tz] {
            buffer.resize(n, 0.0);
        }
        product(&|i| v[i].dot(normals[i]), a);
        for (x, m) in a.iter_mut().zip(&self.mass) {
            *x /= m.max(f64::MIN_POSITIVE);
        }
        product(&|i| a[i], b);
        if let Some(rigid) = &self.rigid {
            // b is s_n⁻¹ P_n u: add s_n⁻¹ β U Uᵀ u.
            rigid.apply(|i| v[i].dot(normals[i]) / scales.normal, b);
        }
        for (axis, column) in [&mut *tx, &mut *ty, &mut *tz].into_iter().enumerate() {
            product(
                &|i| (v[i] - v[i].dot(normals[i]) * normals[i])[axis],
                column,
            );
        }
        out.clear();
        out.extend((0..n).map(|i| {
            let nrm = normals[i];
            let t = DVec3::new(tx[i], ty[i], tz[i]);
            scales.normal * b[i] * nrm + scales.tangential * (t - t.dot(nrm) * nrm)
        }));
    }

    /// Forgets the factor (the next use must [`build`](Self::build)).
    pub fn clear(&mut self) {
        self.factor = None;
    }

    /// The constraint columns W_A, W_V of the last
    /// [`direction`](Self::direction) (empty when inactive).
    pub fn columns(&self) -> [&[DVec3]; 2] {
        [&self.columns[0], &self.columns[1]]
    }

    /// The preconditioned direction of `force`, tangent to the active
    /// constraints in the metric's sense: d = r(P⁻¹F) − Σ_c μ_c W_c with
    /// W_c = r(P⁻¹(n·∇C_c) n) and ∇C_c · d = 0 for every active constraint
    /// c (∇C from `gradients`, measured at `positions`), where `restrict`
    /// removes what the caller holds (pinned vertices). The columns W are
    /// kept for [`columns`](Self::columns).
    ///
    /// The columns W keep only their normal parts: with tangential ones
    /// the projection slid irregular vertices back and forth (a two-step
    /// cycle that held FIRE at its smallest step). They are solved for at
    /// every call: columns kept from the build (their normal speeds, along
    /// the current normals) slowed the h = 1/4 red blood cell from 285 to
    /// 4448 iterations, as the projection is then no longer orthogonal in
    /// the metric. All columns go through the factor together: one solve
    /// of [F·n, ∇A·n, ∇V·n, F_t,x, F_t,y, F_t,z], then one of the first
    /// three (a batch costs a third as much per column as single columns
    /// at 10242 vertices).
    pub fn direction(
        &mut self,
        positions: &[DVec3],
        topology: &Topology,
        force: &[DVec3],
        gradients: Option<(&Gradients, ConstraintTargets)>,
        restrict: &mut dyn FnMut(&mut [DVec3]),
        out: &mut Vec<DVec3>,
    ) {
        let (Some(factor), Some(scales)) = (&mut self.factor, self.scales) else {
            panic!("SobolevMetric::direction before build");
        };
        let n = positions.len();
        crate::fluid::vertex_normals(positions, topology, &mut self.normals);
        let normals = &self.normals;
        let active = active(gradients);
        let rows: [&[DVec3]; 2] = match gradients {
            Some((g, _)) => [&g.area_gradient, &g.volume_gradient],
            None => [&[], &[]],
        };
        // Columns: F·n, the active ∇C·n, then F_t's x, y, z.
        let normal_columns = 1 + active.iter().filter(|&&a| a).count();
        let columns = normal_columns + 3;
        self.rhs.clear();
        self.rhs.resize(columns * n, 0.0);
        // Each column filled by vertex (in parallel on a large mesh: a
        // map, so the same bits on any thread count).
        {
            use crate::util::parallel::fill;
            let (normal, tangent) = self.rhs.split_at_mut(normal_columns * n);
            let (first, constraints) = normal.split_at_mut(n);
            fill(first, |i| force[i].dot(normals[i]));
            for (axis, column) in tangent.chunks_mut(n).enumerate() {
                fill(column, |i| {
                    let (f, nrm) = (force[i], normals[i]);
                    (f - f.dot(nrm) * nrm)[axis]
                });
            }
            let mut columns = constraints.chunks_mut(n);
            for c in 0..2 {
                if active[c] {
                    let column = columns.next().expect("one column per active constraint");
                    let row = rows[c];
                    fill(column, |i| row[i].dot(normals[i]));
                }
            }
        }
        let start = Instant::now();
        factor.solve_in_place(&mut self.rhs, columns);
        let normal = &mut self.rhs[..normal_columns * n];
        for column in normal.chunks_mut(n) {
            for (x, m) in column.iter_mut().zip(&self.mass) {
                *x *= m;
            }
        }
        factor.solve_in_place(normal, normal_columns);
        if let Some(rigid) = &self.rigid {
            normal.chunks_mut(n).for_each(|y| rigid.correct(y));
        }
        self.solve_time += start.elapsed();
        let (sn, st) = (1.0 / scales.normal, 1.0 / scales.tangential);
        let rhs = &self.rhs;
        let tangent = &rhs[normal_columns * n..];
        crate::util::parallel::fill_vec(out, n, |i| {
            let nrm = normals[i];
            let t = DVec3::new(tangent[i], tangent[n + i], tangent[2 * n + i]);
            sn * rhs[i] * nrm + st * (t - t.dot(nrm) * nrm)
        });
        restrict(out);
        let mut next = 1;
        for c in 0..2 {
            let column = &mut self.columns[c];
            column.clear();
            if active[c] {
                let solved = &rhs[next * n..(next + 1) * n];
                column.extend(solved.iter().zip(normals).map(|(w, nrm)| sn * *w * *nrm));
                restrict(column);
                next += 1;
            }
        }
        let Some((g, t)) = gradients else {
            return;
        };
        let dot =
            |a: &[DVec3], b: &[DVec3]| -> f64 { a.iter().zip(b).map(|(x, y)| x.dot(*y)).sum() };
        let rows = [&g.area_gradient, &g.volume_gradient];
        let w = &self.columns;
        let mut m = [[0.0; 2]; 2];
        let mut r = [0.0; 2];
        for a in 0..2 {
            if !active[a] {
                continue;
            }
            r[a] = dot(rows[a], out);
            for b in 0..2 {
                if active[b] {
                    m[a][b] = dot(rows[a], &w[b]);
                }
            }
        }
        let mu = crate::constraint::solve_response(m, t, r);
        for c in 0..2 {
            if active[c] {
                for (d, x) in out.iter_mut().zip(&w[c]) {
                    *d -= mu[c] * *x;
                }
            }
        }
    }
}
