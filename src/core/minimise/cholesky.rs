//! The sparse Cholesky factor of the Sobolev metric, with triangular solves
//! that split over two subtrees of the elimination tree.
//!
//! A triangular solve of a supernodal factor walks its supernodes in
//! order; two supernodes in disjoint subtrees of the elimination tree
//! touch disjoint rows, except the rows of their common ancestors, where
//! both subtract their updates. So the factor's supernodes are cut into
//! [`GROUPS`] groups of whole subtrees, balanced by the number of values
//! they hold, and the *top*: every other supernode (the subtrees'
//! ancestors, the top separators of the mesh, and what did not fit). A
//! solve then runs
//! - forward: each group on its own rows, its updates to the top's rows
//!   summed into its own buffer (the groups on as many threads as the pool
//!   has), then the buffers subtracted in group order, then the top;
//! - backward: the top, then each group, reading the top's rows.
//!
//! The top's few supernodes are the mesh's top separators, dense blocks
//! that hold about a fifth of the values (24 % at 10242 vertices, 22 % at
//! 40962): its columns are solved in two fixed halves, again one per
//! thread.
//!
//! The groups depend on the sparsity pattern alone and every group (and
//! half) is solved by the same sequential code, so the bits do not depend
//! on the thread count. Below [`SPLIT_FROM`] vertices the factor is faer's
//! own (a solve there costs about what waking a thread does), with faer's
//! bits. Measured: `benches/minimiser.rs`, `benches/RESULTS.md`.

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::matmul::matmul;
use faer::linalg::solvers::Solve;
use faer::linalg::triangular_solve::{
    solve_lower_triangular_in_place, solve_upper_triangular_in_place,
};
use faer::reborrow::{Reborrow, ReborrowMut};
use faer::sparse::linalg::SupernodalThreshold;
use faer::sparse::linalg::cholesky::supernodal::{SupernodalLltRef, SymbolicSupernodalCholesky};
use faer::sparse::linalg::cholesky::{
    CholeskySymbolicParams, SymbolicCholesky, SymbolicCholeskyRaw, SymmetricOrdering,
    factorize_symbolic_cholesky,
};
use faer::sparse::linalg::solvers::{Llt, SymbolicLlt};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Accum, MatMut, MatRef, Par, Side, Spec};

/// The number of groups a split factor's solves run in (fixed, so the bits
/// do not depend on the thread count).
pub const GROUPS: usize = 2;

/// Matrices of at least this order get a split factor.
pub const SPLIT_FROM: usize = 2000;

/// The symbolic analysis: the ordering, the supernodes and, for a split
/// factor, its groups.
#[derive(Clone, Debug)]
pub enum SymbolicFactor {
    /// faer's own (below [`SPLIT_FROM`]).
    Plain(SymbolicLlt<usize>),
    /// A supernodal factor with its groups.
    Split(std::sync::Arc<SplitPlan>),
}

/// A numeric factor.
#[derive(Debug)]
pub enum Factor {
    /// faer's own.
    Plain(Llt<usize, f64>),
    /// A supernodal factor whose solves split (see the module docs).
    Split {
        /// The analysis it was made with.
        plan: std::sync::Arc<SplitPlan>,
        /// The supernodes' values, as faer lays them out.
        values: Vec<f64>,
        /// The solves' buffers, kept from one solve to the next.
        scratch: Scratch,
    },
}

/// The buffers of a split solve: one part per group, the top's, and
/// the update buffer of the top's second half of columns.
#[derive(Debug, Default)]
pub struct Scratch {
    parts: Vec<Part>,
    top: Part,
    right_update: Vec<f64>,
}

/// The groups of a split factor.
#[derive(Debug)]
pub struct SplitPlan {
    symbolic: SymbolicCholesky<usize>,
    /// Supernodes of each group, ascending.
    groups: [Vec<usize>; GROUPS],
    /// The other supernodes, ascending.
    top: Vec<usize>,
    /// Rows (in the factor's order) of each group, ascending.
    group_rows: [Vec<usize>; GROUPS],
    /// Rows of the top, ascending.
    top_rows: Vec<usize>,
    /// By row: its index among its group's (or the top's) rows.
    local: Vec<u32>,
    /// The largest pattern of a supernode (rows below its diagonal block).
    largest_pattern: usize,
    /// Each supernode's pattern as indices among its group's rows, or
    /// among the top's rows with [`TOP`] set (laid out as faer's row
    /// indices).
    mapped: Vec<u32>,
}

/// The flag of a mapped pattern entry in the top's rows.
const TOP: u32 = 1 << 31;

impl SplitPlan {
    /// Supernode `s`'s mapped pattern.
    fn pattern(&self, s: usize) -> &[u32] {
        let sn = self.supernodal();
        let at = sn.col_ptr_for_row_idx()[s];
        &self.mapped[at..at + sn.supernode(s).pattern().len()]
    }

    /// The share of the factor's values in the top (run on one thread).
    pub fn top_share(&self) -> f64 {
        let sn = self.supernodal();
        let values = |s: &usize| {
            let r = sn.supernode(*s);
            let size = sn.supernode_end()[*s] - sn.supernode_begin()[*s];
            (size * (size + r.pattern().len())) as f64
        };
        let top: f64 = self.top.iter().map(values).sum();
        let all: f64 = (0..sn.n_supernodes()).map(|s| values(&s)).sum();
        top / all.max(1.0)
    }

    fn supernodal(&self) -> &SymbolicSupernodalCholesky<usize> {
        match self.symbolic.raw() {
            SymbolicCholeskyRaw::Supernodal(s) => s,
            SymbolicCholeskyRaw::Simplicial(_) => unreachable!("forced supernodal"),
        }
    }

    /// Groups the supernodes of `symbolic` (see the module docs): starting
    /// from the roots, the subtree holding the most values is moved to the
    /// top (its children become candidates) while the estimated cost
    /// (top + the larger group, by values) falls; the candidates are packed
    /// into the groups largest first, each to the lightest group.
    fn new(symbolic: SymbolicCholesky<usize>) -> Self {
        let (groups, top, largest_pattern) = {
            let SymbolicCholeskyRaw::Supernodal(sn) = symbolic.raw() else {
                unreachable!("forced supernodal")
            };
            let count = sn.n_supernodes();
            let begin = sn.supernode_begin();
            let end = sn.supernode_end();
            let mut super_of_row = vec![0usize; sn.nrows()];
            for s in 0..count {
                super_of_row[begin[s]..end[s]].fill(s);
            }
            let mut parent = vec![usize::MAX; count];
            let mut children: Vec<Vec<usize>> = vec![Vec::new(); count];
            let mut weight = vec![0.0f64; count];
            let mut largest_pattern = 0;
            for s in 0..count {
                let pattern = sn.supernode(s).pattern();
                let size = end[s] - begin[s];
                weight[s] = (size * (size + pattern.len())) as f64;
                largest_pattern = largest_pattern.max(pattern.len());
                if let Some(&first) = pattern.first() {
                    parent[s] = super_of_row[first];
                    children[parent[s]].push(s);
                }
            }
            // Postorder: children before parents, so subtree sums go up.
            let mut subtree = weight.clone();
            for s in 0..count {
                if parent[s] != usize::MAX {
                    subtree[parent[s]] += subtree[s];
                }
            }
            let pack = |candidates: &[usize]| -> ([f64; GROUPS], Vec<(usize, usize)>) {
                let mut order: Vec<usize> = candidates.to_vec();
                order.sort_by(|a, b| subtree[*b].total_cmp(&subtree[*a]).then(a.cmp(b)));
                let mut load = [0.0f64; GROUPS];
                let mut assigned = Vec::with_capacity(order.len());
                for c in order {
                    let g = (0..GROUPS)
                        .min_by(|x, y| load[*x].total_cmp(&load[*y]).then(x.cmp(y)))
                        .expect("GROUPS > 0");
                    load[g] += subtree[c];
                    assigned.push((c, g));
                }
                (load, assigned)
            };
            let cost =
                |top: f64, load: &[f64; GROUPS]| top + load.iter().copied().fold(0.0, f64::max);
            let mut candidates: Vec<usize> =
                (0..count).filter(|&s| parent[s] == usize::MAX).collect();
            let mut in_top = vec![false; count];
            let mut top_weight = 0.0;
            let (load, assigned) = pack(&candidates);
            let mut best = (cost(top_weight, &load), assigned, in_top.clone());
            // Each step opens the heaviest candidate; a few hundred steps
            // reach past the top separators of any mesh we run.
            for _ in 0..count.min(400) {
                let Some((at, &heaviest)) = candidates
                    .iter()
                    .enumerate()
                    .max_by(|a, b| subtree[*a.1].total_cmp(&subtree[*b.1]).then(b.1.cmp(a.1)))
                else {
                    break;
                };
                if children[heaviest].is_empty() {
                    break;
                }
                candidates.swap_remove(at);
                candidates.extend_from_slice(&children[heaviest]);
                in_top[heaviest] = true;
                top_weight += weight[heaviest];
                let (load, assigned) = pack(&candidates);
                let c = cost(top_weight, &load);
                if c < best.0 {
                    best = (c, assigned, in_top.clone());
                }
            }
            let (_, assigned, in_top) = best;
            // Every supernode below a candidate joins its group.
            let mut group_of = vec![usize::MAX; count];
            for (c, g) in assigned {
                group_of[c] = g;
            }
            for s in (0..count).rev() {
                if group_of[s] == usize::MAX && !in_top[s] && parent[s] != usize::MAX {
                    group_of[s] = group_of[parent[s]];
                }
            }
            let mut groups: [Vec<usize>; GROUPS] = Default::default();
            let mut top = Vec::new();
            for (s, &g) in group_of.iter().enumerate() {
                if g == usize::MAX {
                    top.push(s);
                } else {
                    groups[g].push(s);
                }
            }
            (groups, top, largest_pattern)
        };
        let SymbolicCholeskyRaw::Supernodal(sn) = symbolic.raw() else {
            unreachable!("forced supernodal")
        };
        let n = sn.nrows();
        let mut owner = vec![GROUPS as u8; n];
        let mut local = vec![0u32; n];
        let mut group_rows: [Vec<usize>; GROUPS] = Default::default();
        let mut top_rows = Vec::new();
        let rows = |s: usize| sn.supernode_begin()[s]..sn.supernode_end()[s];
        for (g, supernodes) in groups.iter().enumerate() {
            for &s in supernodes {
                for r in rows(s) {
                    owner[r] = g as u8;
                    local[r] = group_rows[g].len() as u32;
                    group_rows[g].push(r);
                }
            }
        }
        for &s in &top {
            for r in rows(s) {
                local[r] = top_rows.len() as u32;
                top_rows.push(r);
            }
        }
        let mut mapped = vec![0u32; sn.row_idx().len()];
        for s in 0..sn.n_supernodes() {
            let at = sn.col_ptr_for_row_idx()[s];
            let own = owner[sn.supernode_begin()[s]];
            for (idx, &r) in sn.supernode(s).pattern().iter().enumerate() {
                mapped[at + idx] = if owner[r] == own && (own as usize) < GROUPS {
                    local[r]
                } else {
                    local[r] | TOP
                };
            }
        }
        Self {
            symbolic,
            groups,
            top,
            group_rows,
            top_rows,
            local,
            largest_pattern,
            mapped,
        }
    }
}

/// Why an analysis or a factorisation failed.
pub type FactorError = String;

impl SymbolicFactor {
    /// Analyses the lower triangle of `matrix`.
    pub fn new(matrix: SymbolicSparseColMatRef<'_, usize>) -> Result<Self, FactorError> {
        if matrix.nrows() < SPLIT_FROM {
            return SymbolicLlt::try_new(matrix, Side::Lower)
                .map(Self::Plain)
                .map_err(|e| format!("{e:?}"));
        }
        let params = CholeskySymbolicParams {
            supernodal_flop_ratio_threshold: SupernodalThreshold::FORCE_SUPERNODAL,
            ..Default::default()
        };
        let symbolic =
            factorize_symbolic_cholesky(matrix, Side::Lower, SymmetricOrdering::Amd, params)
                .map_err(|e| format!("{e:?}"))?;
        Ok(Self::Split(std::sync::Arc::new(SplitPlan::new(symbolic))))
    }

    /// Factorises `matrix` (its lower triangle; the pattern analysed).
    pub fn factorise(
        &self,
        matrix: SparseColMatRef<'_, usize, f64>,
    ) -> Result<Factor, FactorError> {
        match self {
            Self::Plain(symbolic) => {
                Llt::try_new_with_symbolic(symbolic.clone(), matrix, Side::Lower)
                    .map(Factor::Plain)
                    .map_err(|e| format!("{e:?}"))
            }
            Self::Split(plan) => {
                let symbolic = &plan.symbolic;
                let mut values = vec![0.0; symbolic.len_val()];
                let mut buffer = MemBuffer::try_new(
                    symbolic.factorize_numeric_llt_scratch::<f64>(Par::Seq, Spec::default()),
                )
                .map_err(|e| format!("{e:?}"))?;
                symbolic
                    .factorize_numeric_llt(
                        &mut values,
                        matrix,
                        Side::Lower,
                        Default::default(),
                        Par::Seq,
                        MemStack::new(&mut buffer),
                        Spec::default(),
                    )
                    .map_err(|e| format!("{e:?}"))?;
                Ok(Factor::Split {
                    plan: plan.clone(),
                    values,
                    scratch: Scratch::default(),
                })
            }
        }
    }
}

/// One group's (or the top's) rows of the right-hand sides, and its
/// buffers.
#[derive(Debug, Default)]
struct Part {
    /// Its rows, column-major (rows × k).
    x: Vec<f64>,
    /// Its updates to the top's rows (top rows × k); groups only.
    to_top: Vec<f64>,
    /// A supernode's update (largest pattern × k).
    update: Vec<f64>,
}

impl Factor {
    /// Solves A x = b in place for the `k` columns of `rhs` (column-major,
    /// n × k).
    pub fn solve_in_place(&mut self, rhs: &mut [f64], k: usize) {
        match self {
            Self::Plain(llt) => {
                let n = rhs.len() / k.max(1);
                llt.solve_in_place(MatMut::from_column_major_slice_mut(rhs, n, k));
            }
            Self::Split {
                plan,
                values,
                scratch,
            } => split_solve(plan, values, scratch, rhs, k),
        }
    }
}

fn split_solve(plan: &SplitPlan, values: &[f64], scratch: &mut Scratch, rhs: &mut [f64], k: usize) {
    let sn = plan.supernodal();
    let llt = SupernodalLltRef::<usize, f64>::new(sn, values);
    let n = sn.nrows();
    let t = plan.top_rows.len();
    let fwd = plan.symbolic.perm().map(|p| p.arrays().0);
    let source = |r: usize| fwd.map_or(r, |f| f[r]);
    // Gather each part's rows of the permuted right-hand sides (every
    // entry of `x` is written, `to_top` starts at zero).
    let gather = |part: &mut Part, rows: &[usize], with_top: bool| {
        let m = rows.len();
        part.x.resize(m * k, 0.0);
        for j in 0..k {
            for (i, &r) in rows.iter().enumerate() {
                part.x[j * m + i] = rhs[j * n + source(r)];
            }
        }
        part.to_top.clear();
        if with_top {
            part.to_top.resize(t * k, 0.0);
        }
        part.update.resize(plan.largest_pattern * k, 0.0);
    };
    let Scratch {
        parts,
        top,
        right_update,
    } = scratch;
    parts.resize_with(GROUPS, Part::default);
    for (part, rows) in parts.iter_mut().zip(&plan.group_rows) {
        gather(part, rows, true);
    }
    gather(top, &plan.top_rows, false);
    let forward = |g: usize, part: &mut Part| {
        let m = plan.group_rows[g].len();
        for &s in &plan.groups[g] {
            let node = llt.supernode(s);
            let size = sn.supernode_end()[s] - sn.supernode_begin()[s];
            let (diagonal, below) = node.val().split_at_row(size);
            let first = plan.local[node.start()] as usize;
            let mut x = MatMut::from_column_major_slice_mut(&mut part.x, m, k);
            let mut block = x.rb_mut().subrows_mut(first, size);
            solve_lower_triangular_in_place(diagonal, block.rb_mut(), Par::Seq);
            let p = node.pattern().len();
            let mut update = MatMut::from_column_major_slice_mut(&mut part.update[..p * k], p, k);
            matmul(
                update.rb_mut(),
                Accum::Replace,
                below,
                block.rb(),
                1.0,
                Par::Seq,
            );
            let pattern = plan.pattern(s);
            for j in 0..k {
                let update = &part.update[j * p..(j + 1) * p];
                let (x, to_top) = (
                    &mut part.x[j * m..(j + 1) * m],
                    &mut part.to_top[j * t..(j + 1) * t],
                );
                for (&l, u) in pattern.iter().zip(update) {
                    if l & TOP == 0 {
                        x[l as usize] -= u;
                    } else {
                        to_top[(l & !TOP) as usize] += u;
                    }
                }
            }
        }
    };
    run_groups(parts, &forward);
    for part in parts.iter() {
        for (x, u) in top.x.iter_mut().zip(&part.to_top) {
            *x -= u;
        }
    }
    // The top, forward and backward, on its own rows, its columns in two
    // fixed halves (each on its own thread when the pool has two).
    let first_half = k.div_ceil(2);
    let (left, right) = top.x.split_at_mut(first_half * t);
    right_update.resize(plan.largest_pattern * (k - first_half), 0.0);
    let mut halves = [
        (left, &mut top.update[..], first_half),
        (right, &mut right_update[..], k - first_half),
    ];
    let top_solve = |(x, update, kc): &mut (&mut [f64], &mut [f64], usize)| {
        if *kc > 0 {
            top_solve(&llt, sn, plan, x, update, *kc);
        }
    };
    if rayon::current_num_threads() > 1 {
        use rayon::prelude::*;
        halves.par_iter_mut().for_each(top_solve);
    } else {
        halves.iter_mut().for_each(top_solve);
    }
    let top_x = &top.x;
    let backward = |g: usize, part: &mut Part| {
        let m = plan.group_rows[g].len();
        for &s in plan.groups[g].iter().rev() {
            backward_node(
                &llt,
                sn,
                s,
                plan,
                &mut part.x,
                &mut part.update,
                m,
                k,
                |l, j, x| {
                    if l & TOP == 0 {
                        x[j * m + l as usize]
                    } else {
                        top_x[j * t + (l & !TOP) as usize]
                    }
                },
            );
        }
    };
    run_groups(parts, &backward);
    // Scatter back, undoing the permutation.
    let mut scatter = |rows: &[usize], x: &[f64]| {
        let m = rows.len();
        for j in 0..k {
            for (i, &r) in rows.iter().enumerate() {
                rhs[j * n + source(r)] = x[j * m + i];
            }
        }
    };
    for (rows, part) in plan.group_rows.iter().zip(parts.iter()) {
        scatter(rows, &part.x);
    }
    scatter(&plan.top_rows, &top.x);
}

/// Forward and backward solves of the top's supernodes for the `k`
/// columns of `x` (the top's rows, t × k).
fn top_solve(
    llt: &SupernodalLltRef<'_, usize, f64>,
    sn: &SymbolicSupernodalCholesky<usize>,
    plan: &SplitPlan,
    x: &mut [f64],
    update: &mut [f64],
    k: usize,
) {
    let t = plan.top_rows.len();
    for &s in &plan.top {
        let node = llt.supernode(s);
        let size = sn.supernode_end()[s] - sn.supernode_begin()[s];
        let (diagonal, below) = node.val().split_at_row(size);
        let first = plan.local[node.start()] as usize;
        let mut xs = MatMut::from_column_major_slice_mut(x, t, k);
        let mut block = xs.rb_mut().subrows_mut(first, size);
        solve_lower_triangular_in_place(diagonal, block.rb_mut(), Par::Seq);
        let p = node.pattern().len();
        let mut u = MatMut::from_column_major_slice_mut(&mut update[..p * k], p, k);
        matmul(u.rb_mut(), Accum::Replace, below, block.rb(), 1.0, Par::Seq);
        let pattern = plan.pattern(s);
        for j in 0..k {
            let u = &update[j * p..(j + 1) * p];
            let x = &mut x[j * t..(j + 1) * t];
            for (&l, u) in pattern.iter().zip(u) {
                x[(l & !TOP) as usize] -= u;
            }
        }
    }
    for &s in plan.top.iter().rev() {
        backward_node(llt, sn, s, plan, x, update, t, k, |l, j, x| {
            x[j * t + (l & !TOP) as usize]
        });
    }
}

/// Backward step of supernode `s` on `x` (its part's rows, m × k): the rows
/// of its pattern read through `read(mapped row, column, x)`.
#[allow(clippy::too_many_arguments)]
fn backward_node(
    llt: &SupernodalLltRef<'_, usize, f64>,
    sn: &SymbolicSupernodalCholesky<usize>,
    s: usize,
    plan: &SplitPlan,
    x: &mut [f64],
    update: &mut [f64],
    m: usize,
    k: usize,
    read: impl Fn(u32, usize, &[f64]) -> f64,
) {
    let node = llt.supernode(s);
    let size = sn.supernode_end()[s] - sn.supernode_begin()[s];
    let (diagonal, below) = node.val().split_at_row(size);
    let p = node.pattern().len();
    let pattern = plan.pattern(s);
    for j in 0..k {
        for (idx, &l) in pattern.iter().enumerate() {
            update[j * p + idx] = read(l, j, x);
        }
    }
    let first = plan.local[node.start()] as usize;
    let mut x = MatMut::from_column_major_slice_mut(x, m, k);
    let mut block = x.rb_mut().subrows_mut(first, size);
    let update = MatRef::from_column_major_slice(&update[..p * k], p, k);
    matmul(
        block.rb_mut(),
        Accum::Add,
        below.transpose(),
        update,
        -1.0,
        Par::Seq,
    );
    solve_upper_triangular_in_place(diagonal.transpose(), block.rb_mut(), Par::Seq);
}

/// Runs `body` on every group, on as many threads as the pool has.
fn run_groups(parts: &mut [Part], body: &(impl Fn(usize, &mut Part) + Sync)) {
    if rayon::current_num_threads() > 1 {
        use rayon::prelude::*;
        parts
            .par_iter_mut()
            .enumerate()
            .for_each(|(g, part)| body(g, part));
    } else {
        for (g, part) in parts.iter_mut().enumerate() {
            body(g, part);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::util::parallel::pool;
    use faer::sparse::{SparseColMat, Triplet};

    /// The 5-point Laplacian of a w × w grid plus a small shift (lower
    /// triangle), of order w².
    fn grid(w: usize) -> SparseColMat<usize, f64> {
        let mut t = Vec::new();
        let at = |i: usize, j: usize| i * w + j;
        for i in 0..w {
            for j in 0..w {
                t.push(Triplet::new(
                    at(i, j),
                    at(i, j),
                    4.0 + 1e-3 + 0.1 * ((i * 7 + j) % 5) as f64,
                ));
                if i + 1 < w {
                    t.push(Triplet::new(at(i + 1, j), at(i, j), -1.0));
                }
                if j + 1 < w {
                    t.push(Triplet::new(at(i, j + 1), at(i, j), -1.0));
                }
            }
        }
        SparseColMat::try_new_from_triplets(w * w, w * w, &t).unwrap()
    }

    #[test]
    fn a_split_solve_matches_faer_and_has_the_same_bits_on_any_thread_count() {
        let a = grid(60);
        let n = a.nrows();
        assert!(n >= SPLIT_FROM);
        let split = SymbolicFactor::new(a.symbolic()).unwrap();
        let SymbolicFactor::Split(plan) = &split else {
            panic!("a split factor from {SPLIT_FROM} rows")
        };
        let share = plan.top_share();
        assert!(share < 0.5, "top share {share}");
        assert!(plan.groups.iter().all(|g| !g.is_empty()));
        let mut factor = split.factorise(a.as_ref()).unwrap();
        let plain = Llt::try_new_with_symbolic(
            SymbolicLlt::try_new(a.symbolic(), Side::Lower).unwrap(),
            a.as_ref(),
            Side::Lower,
        )
        .unwrap();
        let k = 3;
        let b: Vec<f64> = (0..n * k)
            .map(|i| ((i * 7919) % 1013) as f64 / 1013.0 - 0.5)
            .collect();
        let mut expected = b.clone();
        plain.solve_in_place(MatMut::from_column_major_slice_mut(&mut expected, n, k));
        let mut first: Option<Vec<f64>> = None;
        for threads in [1, 2, 3] {
            let mut x = b.clone();
            pool(threads).install(|| factor.solve_in_place(&mut x, k));
            let scale = expected.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            let error = x
                .iter()
                .zip(&expected)
                .fold(0.0f64, |m, (p, q)| m.max((p - q).abs()));
            assert!(error <= 1e-12 * scale, "{threads} threads: error {error}");
            match &first {
                None => first = Some(x),
                Some(f) => assert!(
                    f.iter().zip(&x).all(|(p, q)| p.to_bits() == q.to_bits()),
                    "{threads} threads: other bits than on one"
                ),
            }
        }
        // Below the threshold the factor is faer's own, with its bits.
        let small = grid(20);
        let symbolic = SymbolicFactor::new(small.symbolic()).unwrap();
        assert!(matches!(symbolic, SymbolicFactor::Plain(_)));
    }
}
