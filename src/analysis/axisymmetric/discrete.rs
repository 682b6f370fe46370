//! The discrete problem: the energy, area and reduced volume of a
//! polyline and their gradients, the KKT system, and the Newton/SQP solve.

use super::*;

pub(super) fn validate(reduced_volume: f64, segments: usize) -> Result<(), SolveError> {
    if !reduced_volume.is_finite() || reduced_volume <= 0.5 || reduced_volume > 1.0 {
        return Err(SolveError::InvalidReducedVolume(reduced_volume));
    }
    if !(MIN_SEGMENTS..=MAX_SEGMENTS).contains(&segments) {
        return Err(SolveError::InvalidSegments(segments));
    }
    Ok(())
}

/// Order-2 Richardson extrapolation with the error rule of [`Extrapolated`].
pub(super) fn richardson(q: &[f64]) -> Extrapolated {
    let r = |k: usize| q[k] + (q[k] - q[k - 1]) / 3.0;
    let m = q.len();
    let value = r(m - 1);
    let error = (value - r(m - 2)).abs() + 1e-12;
    Extrapolated { value, error }
}

/// Observed order from the three finest levels of a doubling ladder.
pub(super) fn observed_order_of(q: &[f64]) -> f64 {
    let m = q.len();
    let ratio = (q[m - 3] - q[m - 2]) / (q[m - 2] - q[m - 1]);
    if ratio.is_finite() && ratio > 0.0 {
        ratio.log2()
    } else {
        f64::NAN
    }
}

// ---------------------------------------------------------------------------
// Discrete functionals and their analytic gradients.
// ---------------------------------------------------------------------------

/// Tangent angle at node `k` given the interior unknowns `x = (ψ_1 … ψ_{N−1})`.
pub(super) fn node_angle(x: &[f64], k: usize) -> f64 {
    let n = x.len() + 1;
    if k == 0 {
        0.0
    } else if k == n {
        PI
    } else {
        x[k - 1]
    }
}

/// Values and gradients (w.r.t. the interior angles) of the scale-free sums.
pub(super) struct Evaluation {
    /// `E / κ`.
    pub(super) energy: f64,
    /// `S1 = Σ ρ_i` (so `A = 2π h² S1`).
    pub(super) s1: f64,
    /// `S2 = Σ ρ_i² sin φ_i` (so `V = π h³ S2`).
    pub(super) s2: f64,
    /// `C = Σ cos φ_i` (so `r_N = h C`).
    pub(super) closure_sum: f64,
    pub(super) grad_energy: Vec<f64>,
    pub(super) grad_s1: Vec<f64>,
    pub(super) grad_s2: Vec<f64>,
    pub(super) grad_closure_sum: Vec<f64>,
}

/// Evaluates the discrete functionals; `None` if some midpoint has `r ≤ 0`.
pub(super) fn evaluate(x: &[f64]) -> Option<Evaluation> {
    let n = x.len() + 1;
    let mut sin = vec![0.0; n];
    let mut cos = vec![0.0; n];
    let mut d = vec![0.0; n];
    let mut rho = vec![0.0; n];
    let mut csum = 0.0;
    for i in 0..n {
        let a = node_angle(x, i);
        let b = node_angle(x, i + 1);
        let (s, c) = (0.5 * (a + b)).sin_cos();
        sin[i] = s;
        cos[i] = c;
        d[i] = b - a;
        let r = csum + 0.5 * c;
        if r <= 0.0 || !r.is_finite() {
            return None;
        }
        rho[i] = r;
        csum += c;
    }
    // Per-segment partial derivatives of f_i = (ρ d + s)² / ρ.
    let mut e_rho = vec![0.0; n];
    let mut e_d = vec![0.0; n];
    let mut e_phi = vec![0.0; n];
    let (mut energy, mut s1, mut s2) = (0.0, 0.0, 0.0);
    for i in 0..n {
        let (s, c, dd, r) = (sin[i], cos[i], d[i], rho[i]);
        let q = r * dd + s;
        energy += q * q / r;
        s1 += r;
        s2 += r * r * s;
        e_rho[i] = dd * dd - s * s / (r * r);
        e_d[i] = 2.0 * q;
        e_phi[i] = 2.0 * c * (dd + s / r);
    }
    // Derivatives w.r.t. the midpoint angles φ_j; ρ_i depends on φ_j (j ≤ i)
    // through ∂ρ_i/∂φ_j = −sin φ_j (j < i), −sin φ_j / 2 (j = i).
    let mut gphi_e = vec![0.0; n];
    let mut gphi_1 = vec![0.0; n];
    let mut gphi_2 = vec![0.0; n];
    let (mut tail_e, mut tail_1, mut tail_2) = (0.0, 0.0, 0.0);
    for j in (0..n).rev() {
        let s = sin[j];
        let r = rho[j];
        let s2_rho = 2.0 * r * s;
        gphi_e[j] = e_phi[j] - s * (0.5 * e_rho[j] + tail_e);
        gphi_1[j] = -s * (0.5 + tail_1);
        gphi_2[j] = r * r * cos[j] - s * (0.5 * s2_rho + tail_2);
        tail_e += e_rho[j];
        tail_1 += 1.0;
        tail_2 += s2_rho;
    }
    // Chain rule to the interior node angles: φ_{k−1}, φ_k and d_{k−1}, d_k
    // depend on ψ_k.
    let m = n - 1;
    let mut grad_energy = vec![0.0; m];
    let mut grad_s1 = vec![0.0; m];
    let mut grad_s2 = vec![0.0; m];
    let mut grad_closure_sum = vec![0.0; m];
    for k in 1..n {
        grad_energy[k - 1] = PI * (0.5 * (gphi_e[k - 1] + gphi_e[k]) + e_d[k - 1] - e_d[k]);
        grad_s1[k - 1] = 0.5 * (gphi_1[k - 1] + gphi_1[k]);
        grad_s2[k - 1] = 0.5 * (gphi_2[k - 1] + gphi_2[k]);
        grad_closure_sum[k - 1] = -0.5 * (sin[k - 1] + sin[k]);
    }
    Some(Evaluation {
        energy: PI * energy,
        s1,
        s2,
        closure_sum: csum,
        grad_energy,
        grad_s1,
        grad_s2,
        grad_closure_sum,
    })
}

/// Segment length `h` that makes the area exactly `4π`.
pub(super) fn segment_length(ev: &Evaluation) -> f64 {
    (2.0 / ev.s1).sqrt()
}

/// Reduced volume of the discrete shape.
pub(super) fn reduced_volume_of(ev: &Evaluation) -> f64 {
    REDUCED_VOLUME_FACTOR * ev.s2 / ev.s1.powf(1.5)
}

/// The constrained problem: closure always, reduced volume unless `None`.
/// With `adhesion: Some(w)` the vesicle instead lies on a flat substrate
/// with reduced adhesion `w = W R0²/κ` (see [`super::adhered`]): the profile
/// ends on the substrate at `r_N = h C`, which closes with a flat contact
/// disc of radius `r_N` (no bending energy, no volume), the energy gains
/// `−W π r_N²`, the area `π r_N²`, and there is no closure constraint; the
/// volume constraint is then always present.
#[derive(Clone, Copy)]
pub(super) struct Problem {
    pub(super) target: Option<f64>,
    pub(super) adhesion: Option<f64>,
}

/// Gradient of the Lagrangian, constraint values and constraint Jacobian.
pub(super) struct Kkt {
    pub(super) ev: Evaluation,
    pub(super) grad: Vec<f64>,
    pub(super) constraints: Vec<f64>,
    pub(super) jacobian: Vec<Vec<f64>>,
}

impl Problem {
    /// The free vesicle: closure, and the reduced volume unless `None`.
    pub(super) fn closed(target: Option<f64>) -> Self {
        Problem {
            target,
            adhesion: None,
        }
    }

    pub(super) fn constraint_count(&self) -> usize {
        if self.adhesion.is_some() {
            1
        } else if self.target.is_some() {
            2
        } else {
            1
        }
    }

    /// `E / κ` and its gradient: the bending energy, and with adhesion `w`
    /// the contact term `−w π r_N² = −4π w C² / (2 S1 + C²)` (at `A = 4π`,
    /// `h² = 4 / (2 S1 + C²)`).
    pub(super) fn energy(&self, ev: &Evaluation) -> (f64, Vec<f64>) {
        let Some(w) = self.adhesion else {
            return (ev.energy, ev.grad_energy.clone());
        };
        let c = ev.closure_sum;
        let q = 2.0 * ev.s1 + c * c;
        let energy = ev.energy - 4.0 * PI * w * c * c / q;
        let grad = (0..ev.grad_energy.len())
            .map(|i| {
                let gc = ev.grad_closure_sum[i];
                let gq = 2.0 * ev.grad_s1[i] + 2.0 * c * gc;
                ev.grad_energy[i] - 4.0 * PI * w * (2.0 * c * gc / q - c * c * gq / (q * q))
            })
            .collect();
        (energy, grad)
    }

    /// Constraint values and gradients: `r_N` (units of `R0`) and `v(ψ) − v`.
    pub(super) fn constraints(&self, ev: &Evaluation) -> (Vec<f64>, Vec<Vec<f64>>) {
        if self.adhesion.is_some() {
            // v = 6 S2 / q^{3/2} with q = 2 S1 + C² (A = 4π, V = π h³ S2).
            let v0 = self.target.unwrap_or(1.0);
            let c = ev.closure_sum;
            let q = 2.0 * ev.s1 + c * c;
            let a = 6.0 / q.powf(1.5);
            let b = 9.0 * ev.s2 / q.powf(2.5);
            let grad = (0..ev.grad_s2.len())
                .map(|i| {
                    a * ev.grad_s2[i] - b * (2.0 * ev.grad_s1[i] + 2.0 * c * ev.grad_closure_sum[i])
                })
                .collect();
            return (vec![a * ev.s2 - v0], vec![grad]);
        }
        let h = segment_length(ev);
        // r_N = h C with h = sqrt(2/S1): ∇r_N = h ∇C − C h/(2 S1) ∇S1.
        let closure = h * ev.closure_sum;
        let f = ev.closure_sum * h / (2.0 * ev.s1);
        let grad_closure: Vec<f64> = ev
            .grad_closure_sum
            .iter()
            .zip(&ev.grad_s1)
            .map(|(gc, g1)| h * gc - f * g1)
            .collect();
        let mut values = vec![closure];
        let mut grads = vec![grad_closure];
        if let Some(v0) = self.target {
            let a = REDUCED_VOLUME_FACTOR / ev.s1.powf(1.5);
            let b = 1.5 * REDUCED_VOLUME_FACTOR * ev.s2 / ev.s1.powf(2.5);
            values.push(reduced_volume_of(ev) - v0);
            grads.push(
                ev.grad_s2
                    .iter()
                    .zip(&ev.grad_s1)
                    .map(|(g2, g1)| a * g2 - b * g1)
                    .collect(),
            );
        }
        (values, grads)
    }

    pub(super) fn kkt(&self, x: &[f64], lambda: &[f64]) -> Option<Kkt> {
        let ev = evaluate(x)?;
        let (constraints, jacobian) = self.constraints(&ev);
        let (_, mut grad) = self.energy(&ev);
        for (l, row) in lambda.iter().zip(&jacobian) {
            for (g, j) in grad.iter_mut().zip(row) {
                *g += l * j;
            }
        }
        Some(Kkt {
            ev,
            grad,
            constraints,
            jacobian,
        })
    }

    /// Least-squares multipliers: minimise `|∇E + Jᵀλ|`.
    pub(super) fn least_squares_multipliers(&self, x: &[f64]) -> Option<Vec<f64>> {
        let ev = evaluate(x)?;
        let (_, jac) = self.constraints(&ev);
        let m = jac.len();
        let mut normal = DMatrix::<f64>::zeros(m, m);
        let mut rhs = DVector::<f64>::zeros(m);
        for a in 0..m {
            for b in 0..m {
                normal[(a, b)] = dot(&jac[a], &jac[b]);
            }
            rhs[a] = -dot(&jac[a], &self.energy(&ev).1);
        }
        let sol = normal.lu().solve(&rhs)?;
        Some(sol.iter().copied().collect())
    }

    /// Hessian of the Lagrangian (fixed `λ`) by central differences of the
    /// analytic gradient, symmetrised.
    pub(super) fn hessian(&self, x: &[f64], lambda: &[f64]) -> Option<DMatrix<f64>> {
        let dim = x.len();
        let mut h = DMatrix::<f64>::zeros(dim, dim);
        let mut xp = x.to_vec();
        for k in 0..dim {
            xp[k] = x[k] + HESSIAN_STEP;
            let gp = self.kkt(&xp, lambda)?.grad;
            xp[k] = x[k] - HESSIAN_STEP;
            let gm = self.kkt(&xp, lambda)?.grad;
            xp[k] = x[k];
            for i in 0..dim {
                h[(i, k)] = (gp[i] - gm[i]) / (2.0 * HESSIAN_STEP);
            }
        }
        let ht = h.transpose();
        Some((h + ht) * 0.5)
    }
}

pub(super) fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

pub(super) fn max_abs(a: &[f64]) -> f64 {
    a.iter().fold(0.0, |m, v| m.max(v.abs()))
}

/// Euclidean norm of the KKT residual (the line-search merit function).
pub(super) fn merit(k: &Kkt) -> f64 {
    (dot(&k.grad, &k.grad) + dot(&k.constraints, &k.constraints)).sqrt()
}

/// A converged Newton solve.
pub(super) struct Solution {
    pub(super) x: Vec<f64>,
    pub(super) lambda: Vec<f64>,
    pub(super) iterations: usize,
}

/// Why the Newton iteration stopped without a solution.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub(super) enum NewtonError {
    /// A midpoint of the start point has r ≤ 0.
    #[error("start point has a midpoint with r <= 0")]
    StartRadius,
    /// The KKT system cannot be evaluated at the start point.
    #[error("invalid start point")]
    InvalidStart,
    /// The finite-difference Hessian left the valid domain.
    #[error("finite-difference Hessian left the valid domain")]
    HessianDomain,
    /// The KKT matrix is singular.
    #[error("singular KKT matrix")]
    SingularKkt,
    /// The Newton step is not finite.
    #[error("non-finite Newton step")]
    NonFiniteStep,
    /// The backtracking line search found no decrease.
    #[error("line search failed at iteration {iteration} (KKT residual {residual:.3e})")]
    LineSearch {
        /// The Newton iteration.
        iteration: usize,
        /// The merit (KKT residual) there.
        residual: f64,
    },
    /// No convergence within the iteration limit.
    #[error(
        "no convergence in {iterations} Newton iterations (|grad| {grad:.3e}, |c| {constraints:.3e})"
    )]
    NoConvergence {
        /// The iteration limit.
        iterations: usize,
        /// The largest gradient component at the end.
        grad: f64,
        /// The largest constraint violation at the end.
        constraints: f64,
    },
    /// The stationary point is not a constrained minimum.
    #[error("converged to a point that is not a constrained minimum")]
    NotMinimum,
}

/// Newton/SQP with backtracking on the KKT-residual norm.
pub(super) fn newton(problem: Problem, x0: Vec<f64>) -> Result<Solution, NewtonError> {
    let dim = x0.len();
    let m = problem.constraint_count();
    let mut x = x0;
    let mut lambda = problem
        .least_squares_multipliers(&x)
        .ok_or(NewtonError::StartRadius)?;
    let mut current = problem.kkt(&x, &lambda).ok_or(NewtonError::InvalidStart)?;
    // Once within TOLERANCE, one more (polishing) step is taken unless the
    // residual is already at the rounding level, so that the reported
    // quantities carry no solver error at the level of the error bars.
    let mut polishing = false;
    for iteration in 0..MAX_NEWTON_ITERATIONS {
        let residual = max_abs(&current.grad).max(max_abs(&current.constraints));
        if residual <= TOLERANCE && (polishing || residual <= POLISH_TOLERANCE) {
            return Ok(Solution {
                x,
                lambda,
                iterations: iteration,
            });
        }
        polishing = residual <= TOLERANCE;
        let hess = problem
            .hessian(&x, &lambda)
            .ok_or(NewtonError::HessianDomain)?;
        let size = dim + m;
        let mut kkt = DMatrix::<f64>::zeros(size, size);
        kkt.view_mut((0, 0), (dim, dim)).copy_from(&hess);
        let mut rhs = DVector::<f64>::zeros(size);
        for a in 0..m {
            for i in 0..dim {
                kkt[(i, dim + a)] = current.jacobian[a][i];
                kkt[(dim + a, i)] = current.jacobian[a][i];
            }
            rhs[dim + a] = -current.constraints[a];
        }
        for i in 0..dim {
            rhs[i] = -current.grad[i];
        }
        let step = kkt.lu().solve(&rhs).ok_or(NewtonError::SingularKkt)?;
        let p: Vec<f64> = step.rows(0, dim).iter().copied().collect();
        let dl: Vec<f64> = step.rows(dim, m).iter().copied().collect();
        let pmax = max_abs(&p);
        if !pmax.is_finite() {
            return Err(NewtonError::NonFiniteStep);
        }
        let mut alpha = if pmax > MAX_STEP {
            MAX_STEP / pmax
        } else {
            1.0
        };
        let m0 = merit(&current);
        loop {
            let xt: Vec<f64> = x.iter().zip(&p).map(|(a, b)| a + alpha * b).collect();
            let lt: Vec<f64> = lambda.iter().zip(&dl).map(|(a, b)| a + alpha * b).collect();
            if let Some(trial) = problem.kkt(&xt, &lt)
                && merit(&trial) <= (1.0 - 1e-4 * alpha) * m0
            {
                x = xt;
                lambda = lt;
                current = trial;
                break;
            }
            alpha *= 0.5;
            if polishing && alpha < 0.1 {
                // Rounding-limited: the point is already converged.
                return Ok(Solution {
                    x,
                    lambda,
                    iterations: iteration,
                });
            }
            if alpha < 1e-10 {
                return Err(NewtonError::LineSearch {
                    iteration,
                    residual: m0,
                });
            }
        }
    }
    Err(NewtonError::NoConvergence {
        iterations: MAX_NEWTON_ITERATIONS,
        grad: max_abs(&current.grad),
        constraints: max_abs(&current.constraints),
    })
}

// ---------------------------------------------------------------------------
// Starting shapes, continuation and prolongation.
// ---------------------------------------------------------------------------
