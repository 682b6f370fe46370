//! Continuation in the reduced volume along a branch, the ladder of
//! grids, and the finished shape's measures.

use super::*;

/// Natural-parameter continuation in `v` on a fixed grid: secant predictor
/// from the last two solutions, Newton corrector, steps growing by 1.5
/// (up to [`MAX_CONTINUATION_STEP`]) after a success and halving after a
/// failure.
pub(super) struct Walker {
    /// Reduced volume of `solution`.
    pub(super) v: f64,
    /// The last converged solution.
    pub(super) solution: Solution,
    /// The solution before it, for the secant predictor.
    pub(super) previous: Option<(f64, Vec<f64>)>,
    /// Next step in `v`.
    pub(super) step: f64,
}

impl Walker {
    pub(super) fn new(v: f64, solution: Solution) -> Self {
        Walker {
            v,
            solution,
            previous: None,
            step: INITIAL_CONTINUATION_STEP,
        }
    }

    /// Walks to `target`. On failure the walker stays at the last solution
    /// reached and the error says where the walk stopped.
    pub(super) fn advance(&mut self, target: f64, branch: Branch) -> Result<(), SolveError> {
        let n = self.solution.x.len() + 1;
        let fail = |v: f64, msg: String| {
            let hint = match branch {
                Branch::Stomatocyte => {
                    "; the stomatocyte branch ends in a fold near v ≈ 0.6608 (and the \
                     continuation keeps to constrained minima)"
                }
                _ => "",
            };
            SolveError::NotConverged(format!(
                "continuation at v = {v:.6} ({n} segments): {msg}{hint}"
            ))
        };
        let down = target < self.v;
        while if down {
            self.v > target
        } else {
            self.v < target
        } {
            let v_next = if down {
                (self.v - self.step).max(target)
            } else {
                (self.v + self.step).min(target)
            };
            let x = &self.solution.x;
            let guess: Vec<f64> = match &self.previous {
                Some((vp, xp)) => {
                    let w = (v_next - self.v) / (self.v - vp);
                    x.iter().zip(xp).map(|(a, b)| a + w * (a - b)).collect()
                }
                None => x.clone(),
            };
            let problem = Problem::closed(Some(v_next));
            let attempt = newton(problem, guess).and_then(|sol| {
                // The stomatocyte branch folds back at its upper end into an
                // unstable twin; a step must not jump onto it.
                if branch == Branch::Stomatocyte && !is_strict_minimum(problem, &sol) {
                    Err(NewtonError::NotMinimum)
                } else {
                    Ok(sol)
                }
            });
            match attempt {
                Ok(sol) => {
                    let old = std::mem::replace(&mut self.solution, sol);
                    self.previous = Some((self.v, old.x));
                    self.v = v_next;
                    self.step = (self.step * 1.5).min(MAX_CONTINUATION_STEP);
                }
                Err(e) => {
                    self.step *= 0.5;
                    if self.step < MIN_CONTINUATION_STEP {
                        return Err(fail(v_next, e.to_string()));
                    }
                }
            }
        }
        Ok(())
    }
}

/// Continuation in `v` along `branch` from its starting shape to `target`
/// on `n` segments: for the oblate and prolate branches from a spheroid at
/// `max(target, 0.95)` downwards, for the stomatocyte from the cup of
/// [`stomatocyte_guess`], converged at its own reduced volume (about 0.61),
/// in whichever direction `target` lies.
pub(super) fn continuation(target: f64, n: usize, branch: Branch) -> Result<Solution, SolveError> {
    let fail = |v: f64, msg: String| {
        SolveError::NotConverged(format!("continuation at v = {v:.6} ({n} segments): {msg}"))
    };
    let (v_start, start) = match branch {
        Branch::Oblate | Branch::Prolate => {
            let family = if branch == Branch::Oblate {
                Spheroid::Oblate
            } else {
                Spheroid::Prolate
            };
            let v0 = target.max(CONTINUATION_START);
            (v0, spheroid_guess(v0, n, family))
        }
        Branch::Stomatocyte => {
            let x = stomatocyte_guess(n);
            let ev =
                evaluate(&x).ok_or_else(|| fail(target, "stomatocyte seed has r <= 0".into()))?;
            (reduced_volume_of(&ev), x)
        }
    };
    let solution =
        newton(Problem::closed(Some(v_start)), start).map_err(|e| fail(v_start, e.to_string()))?;
    let mut walker = Walker::new(v_start, solution);
    walker.advance(target, branch)?;
    Ok(walker.solution)
}

/// Solves at each resolution of `ladder` (ascending), reusing the previous
/// level as the starting guess of the next.
pub(super) fn solve_ladder(
    v: f64,
    ladder: &[usize],
    branch: Branch,
) -> Result<Vec<AxisymmetricShape>, SolveError> {
    Ok(solve_ladder_raw(v, ladder, branch)?
        .into_iter()
        .map(|(shape, _)| shape)
        .collect())
}

/// [`solve_ladder`], also returning each level's Newton solution.
pub(super) fn solve_ladder_raw(
    v: f64,
    ladder: &[usize],
    branch: Branch,
) -> Result<Vec<(AxisymmetricShape, Solution)>, SolveError> {
    let sphere = v > 1.0 - SPHERE_WINDOW;
    if sphere && branch == Branch::Stomatocyte {
        return Err(SolveError::NotConverged(
            "the stomatocyte branch does not reach the sphere (v = 1); it ends in a fold \
             near v ≈ 0.6608"
                .into(),
        ));
    }
    let problem = Problem::closed(if sphere { None } else { Some(v) });
    let mut previous: Option<Vec<f64>> = if sphere {
        None
    } else {
        // Close to v = 1 the discrete problem is only feasible on fine grids
        // (the discrete sphere has v = 1 − O(h²)), so continue on the target grid.
        let coarse = match branch {
            Branch::Oblate | Branch::Prolate => CONTINUATION_SEGMENTS,
            Branch::Stomatocyte => STOMATOCYTE_CONTINUATION_SEGMENTS,
        };
        let n = if v > 0.99 {
            ladder[0]
        } else {
            ladder[0].min(coarse)
        };
        Some(continuation(v, n, branch)?.x)
    };
    let mut out = Vec::with_capacity(ladder.len());
    for &n in ladder {
        let guess = match &previous {
            Some(xp) if xp.len() + 1 == n => xp.clone(),
            Some(xp) => prolong(xp, n),
            None => (1..n).map(|i| PI * i as f64 / n as f64).collect(),
        };
        let sol = newton(problem, guess)
            .map_err(|e| SolveError::NotConverged(format!("v = {v} on {n} segments: {e}")))?;
        let shape = finish(problem, v, &sol, branch)?;
        previous = Some(sol.x.clone());
        out.push((shape, sol));
    }
    Ok(out)
}

// ---------------------------------------------------------------------------
// Post-processing: profile, shape measures, second-order check.
// ---------------------------------------------------------------------------

pub(super) fn finish(
    problem: Problem,
    v: f64,
    sol: &Solution,
    branch: Branch,
) -> Result<AxisymmetricShape, SolveError> {
    let n = sol.x.len() + 1;
    let kkt = problem
        .kkt(&sol.x, &sol.lambda)
        .ok_or_else(|| SolveError::NotConverged("solution left the valid domain".into()))?;
    let ev = &kkt.ev;
    let h = segment_length(ev);
    let (r, mut z) = nodes(&sol.x, h);
    check_embedded(&r, &z)?;
    let shift = 0.5 * (z[0] + z[n]);
    for zi in z.iter_mut() {
        *zi -= shift;
    }
    let centre_thickness = z[0] - z[n];
    let (i_rim, max_r) = widest(&r);
    let (max_thickness, biconcave) = match branch {
        Branch::Oblate => {
            let t = max_thickness(&r, &z, i_rim)?.max(centre_thickness);
            (t, t > centre_thickness * (1.0 + 1e-8))
        }
        Branch::Prolate | Branch::Stomatocyte => {
            let top = smooth_max(&z).1;
            let bottom = -smooth_max(&z.iter().map(|zi| -zi).collect::<Vec<_>>()).1;
            let t = top - bottom;
            let dimpled = |depth: f64| depth > 1e-8 * t;
            (t, dimpled(top - z[0]) && dimpled(z[n] - bottom))
        }
    };
    let hess = problem
        .hessian(&sol.x, &sol.lambda)
        .ok_or_else(|| SolveError::NotConverged("Hessian left the valid domain".into()))?;
    let min_eig = tangent_min_eigenvalue(&hess, &kkt.jacobian) / h;
    // The volume constraint's multiplier is the second (the first closes
    // the curve); there is none at v = 1.
    let lambda_v = if problem.constraint_count() == 2 {
        sol.lambda[1]
    } else {
        0.0
    };
    let pressure = -lambda_v * 3.0 / (4.0 * PI);
    Ok(AxisymmetricShape {
        branch,
        reduced_volume: v,
        energy_over_8pi_kappa: ev.energy / (8.0 * PI),
        diameter: 2.0 * max_r,
        max_thickness,
        centre_thickness,
        biconcave,
        segments: n,
        profile: r.iter().copied().zip(z.iter().copied()).collect(),
        contour_length: h * n as f64,
        area: 2.0 * PI * h * h * ev.s1,
        volume: PI * h * h * h * ev.s2,
        achieved_reduced_volume: reduced_volume_of(ev),
        closure_residual: h * ev.closure_sum,
        lagrangian_gradient_norm: max_abs(&kkt.grad),
        min_tangent_hessian_eigenvalue: min_eig,
        is_constrained_minimum: min_eig > 0.0,
        newton_iterations: sol.iterations,
        pressure,
        tension: pressure * v / 2.0,
    })
}
