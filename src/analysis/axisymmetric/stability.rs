//! The constrained-minimum check: the Hessian's smallest eigenvalue on
//! the tangent space of the constraints.

use super::*;

/// Smallest eigenvalue of the Hessian restricted to the null space of the
/// constraint Jacobian (Euclidean metric on the unknowns).
///
/// With `Q` an orthonormal basis of the Jacobian's row space and `P = I − QQᵀ`,
/// `M = PHP + σ QQᵀ` (σ ≥ spectral radius of `H`) has the tangent-space
/// spectrum of `H` plus `σ` on the normal space, so its smallest eigenvalue
/// is the one wanted. A successful Cholesky factorisation certifies
/// positivity; the value comes from inverse iteration. If Cholesky fails the
/// full symmetric eigen-decomposition gives the (negative) minimum.
pub(super) fn tangent_min_eigenvalue(h: &DMatrix<f64>, jacobian: &[Vec<f64>]) -> f64 {
    let dim = h.nrows();
    let m = tangent_shifted_hessian(h, jacobian);
    if let Some(chol) = m.clone().cholesky() {
        let mut x = DVector::from_fn(dim, |i, _| 1.0 + (1.3 * i as f64).sin());
        x /= x.norm();
        let mut mu = f64::INFINITY;
        for _ in 0..300 {
            let mut y = chol.solve(&x);
            y /= y.norm();
            let new_mu = y.dot(&(&m * &y));
            x = y;
            let done = (new_mu - mu).abs() <= 1e-13 * new_mu.abs();
            mu = new_mu;
            if done {
                break;
            }
        }
        mu
    } else {
        m.symmetric_eigen().eigenvalues.min()
    }
}

/// `true` when the Hessian of the Lagrangian at `sol` is positive definite
/// on the tangent space of the constraints (a strict constrained minimum),
/// certified by a Cholesky factorisation of [`tangent_shifted_hessian`].
pub(super) fn is_strict_minimum(problem: Problem, sol: &Solution) -> bool {
    let (Some(kkt), Some(hess)) = (
        problem.kkt(&sol.x, &sol.lambda),
        problem.hessian(&sol.x, &sol.lambda),
    ) else {
        return false;
    };
    tangent_shifted_hessian(&hess, &kkt.jacobian)
        .cholesky()
        .is_some()
}

/// `M = PHP + σ QQᵀ` of [`tangent_min_eigenvalue`].
pub(super) fn tangent_shifted_hessian(h: &DMatrix<f64>, jacobian: &[Vec<f64>]) -> DMatrix<f64> {
    let dim = h.nrows();
    let mut basis: Vec<DVector<f64>> = Vec::new();
    for row in jacobian {
        let mut v = DVector::from_column_slice(row);
        for u in &basis {
            let p = u.dot(&v);
            v -= u * p;
        }
        let norm = v.norm();
        if norm > 1e-300 {
            basis.push(v / norm);
        }
    }
    let q = DMatrix::from_columns(&basis);
    let hq = h * &q;
    let qthq = q.transpose() * &hq;
    let sigma = (0..dim)
        .map(|i| h.row(i).iter().map(|v| v.abs()).sum::<f64>())
        .fold(0.0, f64::max)
        + 1.0;
    h - &q * hq.transpose() - &hq * q.transpose()
        + &q * (qthq + DMatrix::identity(basis.len(), basis.len()) * sigma) * q.transpose()
}
