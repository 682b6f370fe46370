//! Continuum reference solver for the Helfrich bending energy of an
//! axisymmetric closed vesicle (genus 0, zero spontaneous curvature) at fixed
//! area `A` and fixed volume `V`, on the three branches of the classical
//! shape diagram of Seifert, Berndl & Lipowsky, Phys. Rev. A 44, 1182 (1991):
//! prolate, oblate/discocyte and stomatocyte ([`Branch`]).
//!
//! [`adhered`] extends it to a vesicle bound to a flat substrate (a contact
//! segment: Seifert & Lipowsky's adhered vesicle), and [`contact_fit`]
//! measures a simulated adhered vesicle's contact curvature against that
//! family.
//!
//! This module is an *independent* reference: it uses only `std` and
//! `nalgebra` and nothing from the triangulated-mesh engine, so it can be used
//! to measure that engine's discretisation error.
//!
//! # Physics and units
//!
//! Lengths are in units of `R0 = sqrt(A / 4π)`, so `A = 4π` and
//! `V = v · 4π/3` with `v` the reduced volume. Energies are in units of the
//! bending rigidity `κ`; the reported energy is `E / (8πκ)` with
//! `E = (κ/2) ∮ (2H)² dA`, so a sphere gives exactly 1.
//!
//! The generating curve is parametrised by arc length `s ∈ [0, L]` from the
//! north pole to the south pole, with tangent angle `ψ(s)`:
//! `dr/ds = cos ψ`, `dz/ds = −sin ψ`, `r(0) = 0`, `ψ(0) = 0`, `ψ(L) = π`, and
//! closure `r(L) = 0`. The principal curvatures are `ψ'` and `sin ψ / r`, and
//!
//! * `E = πκ ∫ r (ψ' + sin ψ / r)² ds`,
//! * `A = 2π ∫ r ds`,
//! * `V = π ∫ r² sin ψ ds`.
//!
//! # Discretisation
//!
//! `N` equal segments of length `h = L/N`; unknown tangent angles `ψ_i` at the
//! nodes (`ψ_0 = 0`, `ψ_N = π` fixed). With the midpoint angle
//! `φ_i = (ψ_i + ψ_{i+1})/2`, the nodes follow `r_{i+1} = r_i + h cos φ_i`,
//! `z_{i+1} = z_i − h sin φ_i`, and every integral uses the midpoint rule per
//! segment with `r_{m,i} = (r_i + r_{i+1})/2 > 0` (no `0/0` at the poles) and
//! `ψ' ≈ (ψ_{i+1} − ψ_i)/h`. The scheme is symmetric, so its error expands in
//! even powers of `h`; the measured order is 2 (see the tests).
//!
//! Writing `r_{m,i} = h ρ_i` with `ρ_i = Σ_{j<i} cos φ_j + cos φ_i / 2` shows
//! that the discrete energy `E = π Σ (ρ_i d_i + sin φ_i)² / ρ_i`
//! (`d_i = ψ_{i+1} − ψ_i`) does not depend on `L` (scale invariance), while
//! `A = 2π h² Σ ρ_i` and `V = π h³ Σ ρ_i² sin φ_i`. The area constraint is
//! therefore solved exactly for `h` (`h = sqrt(2 / Σ ρ_i)`), which removes `L`
//! from the unknowns and turns the volume constraint into the scale-free
//! reduced-volume constraint `v(ψ) = 3 Σρ² sin φ / (√2 (Σρ)^{3/2}) = v`.
//! This is exactly equivalent to the `(ψ, L)` formulation with constraints
//! `A = 4π`, `V = v·4π/3`, and keeps the KKT system small and well scaled.
//! The remaining unknowns are `ψ_1 … ψ_{N−1}`; the equality constraints are the
//! closure `r_N = 0` (in units of `R0`) and `v(ψ) − v = 0`.
//!
//! # Solver
//!
//! Newton/SQP on the KKT system of the Lagrangian
//! `𝓛 = E + λ_r r_N + λ_v (v(ψ) − v)`, with exact analytic gradients (an
//! `O(N)` adjoint sweep) and the Hessian of `𝓛` from central finite
//! differences of the analytic gradient, a dense LU solve, and a backtracking
//! line search on the Euclidean norm of the KKT residual (the merit function),
//! with steps capped at 0.5 rad. Convergence means `max |∇𝓛| ≤ 1e-10` and
//! `max |c| ≤ 1e-10`, after which one more polishing step is taken unless the
//! residual is already below `1e-12`. Each branch is reached by continuation
//! in `v` from its starting shape (see [Branches](#branches)) on a coarse
//! grid (64 segments for the oblate and prolate branches, 128 for the
//! stomatocyte, or the target grid if it is coarser, and the target grid
//! when `v > 0.99`), with a secant predictor and adaptive steps (0.025 at
//! first, growing to at most 0.05, halved after a failed Newton solve, given
//! up below 1e-4); the coarse solution is then interpolated (cubic, in
//! `s/L`) onto the finer grids. [`branch_curve`] instead continues along the
//! branch on the target grid from one requested `v` to the next.
//! At `v = 1` the volume constraint is degenerate (the sphere maximises `v`,
//! so `∇v = 0` there); it is then dropped and `E` is minimised at fixed area
//! with closure only, which gives the discrete sphere.
//!
//! Every solution is checked to be a constrained minimum: the smallest
//! eigenvalue of the Hessian of `𝓛` restricted to the tangent space of the
//! constraints (in the metric `∫ δψ² ds`) must be positive. The check is made
//! in the full, not up-down-symmetric, space of axisymmetric shapes.
//!
//! # Branches
//!
//! * **Prolate** ([`Branch::Prolate`]): from a prolate spheroid at
//!   `v = 0.95`. Up-down symmetric and elongated; a waist (peanut, then
//!   dumbbell) appears below `v ≈ 0.896`. Exists and is a constrained minimum
//!   on the whole domain `(0.5, 1]`.
//! * **Oblate** ([`Branch::Oblate`]): from an oblate spheroid at `v = 0.95`.
//!   Up-down symmetric; biconcave (a discocyte) below `v ≈ 0.892`. A
//!   constrained minimum down to `v ≈ 0.51`; the poles touch near
//!   `v ≈ 0.503`.
//! * **Stomatocyte** ([`Branch::Stomatocyte`]): up-down asymmetric cups.
//!   Seed: a piecewise-circular cup (in units of its outer radius) made of
//!   an arc of an inner sphere of radius 0.5 from the north pole, along which
//!   `ψ` falls from 0 to −2.5 rad (the floor and undercut wall of the
//!   invagination), an arc of a rim torus of tube radius 0.2 (`ψ` rises from
//!   −2.5 rad to `β ≈ 0.55` rad), and the outer unit sphere down to the south
//!   pole (`β` to `π`), with `β` fixed by the radial closure, so `ψ(s)` is
//!   continuous and the curve closes. Newton at the seed's own reduced volume
//!   (≈ 0.612) converges in 8–12 iterations to a stomatocyte
//!   (`ψ_min ≈ −2.27`), from which the continuation goes up or down in `v`.
//!   The branch exists from below the domain (on 200 segments it continues,
//!   embedded and stable, at least to `v = 0.22`, where `E/8πκ = 1.9989`
//!   approaches 2, the energy of a sphere inside a sphere) up to a fold at
//!   `v ≈ 0.6608`,
//!   where the lowest constrained eigenvalue vanishes like `√(v_fold − v)`
//!   (from that law: 0.66044, 0.66069, 0.66075, 0.66077 on 100, 200, 400,
//!   800 segments). There it turns back into an unstable twin, a saddle of
//!   higher energy with a shallower invagination (`ψ_min ≈ −1.72`; at
//!   `v = 0.64`, `E/8πκ = 1.9775` against 1.9696 on 400 segments). The
//!   branch is a constrained minimum wherever it exists; its continuation
//!   rejects steps that land on non-minima, so it never jumps onto the twin.
//!   Within about `1e-3` below the fold the continuation grid's own fold may
//!   come first and the solver reports [`SolveError::NotConverged`]; above
//!   the fold it always does.
//!
//! The lowest-energy branch is the prolate one for `v > 0.651076`, the
//! oblate one for `0.591189 < v < 0.651076` and the stomatocyte below
//! `0.591189`. These crossings (from [`converged_on_branch`], found by
//! regula falsi to `|ΔE/8πκ| < 1e-11`; uncertain by about `1e-7` in `v`) are
//! at `E/8πκ = 1.823471` (prolate/oblate; Seifert, Berndl & Lipowsky put the
//! transition at `v ≈ 0.652`) and `E/8πκ = 1.978721` (oblate/stomatocyte;
//! they quote `v_s ≈ 0.59`).
//!
//! Converged `E/8πκ` on each branch (from [`converged_on_branch`], ladder
//! 100/200/400/800; ± the error bar of [`Extrapolated`]; — where the branch
//! does not exist):
//!
//! | v    | prolate                  | oblate                   | stomatocyte            |
//! |------|--------------------------|--------------------------|------------------------|
//! | 0.95 | 1.0955648796 ± 1.4e-9    | 1.1061146407 ± 9.2e-10   | —                      |
//! | 0.9  | 1.1896440329 ± 3.4e-10   | 1.2178602610 ± 1.1e-9    | —                      |
//! | 0.85 | 1.2856759620 ± 6.3e-10   | 1.3335426712 ± 1.1e-9    | —                      |
//! | 0.8  | 1.3874404323 ± 1.7e-9    | 1.4525386286 ± 1.0e-9    | —                      |
//! | 0.75 | 1.5018343939 ± 2.6e-9    | 1.5744801170 ± 9.0e-10   | —                      |
//! | 0.7  | 1.6432704255 ± 2.3e-9    | 1.6991110500 ± 8.0e-10   | —                      |
//! | 0.65 | 1.8279298736 ± 7.2e-9    | 1.8262334457 ± 6.9e-10   | 1.966801266 ± 1.3e-8   |
//! | 0.6  | 2.0602931869 ± 2.7e-9    | 1.9556802671 ± 5.8e-10   | 1.977381352 ± 3.7e-8   |
//! | 0.55 | 2.3567839149 ± 1.4e-8    | 2.0872981747 ± 4.8e-10   | 1.983834219 ± 7.0e-8   |
//!
//! Every entry is a strict constrained minimum at every level of the ladder.
//! The observed order of the energy is 1.99–2.01 everywhere except on the
//! prolate branch at `v = 0.65`, where the `h²` coefficient of the energy
//! changes sign (the levels agree to `3e-7` and the order estimate is
//! meaningless; the error bar is still `7e-9`). The stomatocyte's error bars
//! are larger, and the observed orders of its other measures are 1.97–2.00:
//! the `O(h⁴)` terms are relatively larger there. At `v = 0.55` the
//! stomatocyte has diameter
//! `D = 1.7840695(4)`, height (`max_thickness`) 1.586962(1), floor thickness
//! (`centre_thickness`) 0.326807(3) and pressure `Δp = −0.634 κ/R0³`.
//!
//! # Reference values on the oblate branch (from [`converged`], ladder 100/200/400/800)
//!
//! | v     | E/8πκ              | D/R0              | max thickness     | centre thickness |
//! |-------|--------------------|-------------------|-------------------|------------------|
//! | 0.6   | 1.9556802671(6)    | 2.4792044189(8)   | 0.6631855684(3)   | 0.25025245(1)    |
//! | 0.665 | 1.7878454584(7)    | 2.4670985566(4)   | 0.7170333405(1)   | 0.42252899(1)    |
//!
//! (last digit ± the error bar of [`Extrapolated`]). Both are biconcave
//! discocytes and strict constrained minima. The observed order is 2.000 for
//! the energy, diameter and max thickness and 2.00–2.03 for the centre
//! thickness. As a check against Seifert, Berndl & Lipowsky, Phys. Rev. A 44,
//! 1182 (1991), the oblate and prolate branches computed here have equal
//! energy at `v = 0.6511` (E/8πκ = 1.8235, see [Branches](#branches)), where
//! that paper puts the prolate/oblate transition (`v ≈ 0.652`). On the oblate
//! branch `E/8πκ` rises monotonically from 1 at `v = 1` (1.218 at `v = 0.9`),
//! so values of 1.2–1.3 belong to convex oblate shapes near `v = 0.9`, not to
//! the discocyte at `v = 0.6`.
//!
//! # Limits
//!
//! * All branches accept `v ∈ (0.5, 1]` only (the prolate and stomatocyte
//!   branches continue below; the oblate branch ends there).
//! * "Constrained minimum" refers to axisymmetric perturbations only;
//!   non-axisymmetric instabilities are not checked.
//! * Reduced volumes within about `1/N²` of 1 are infeasible (or nearly so) on
//!   an `N`-segment grid, because the discrete sphere has `v = 1 − O(h²)`;
//!   the solver then returns [`SolveError::NotConverged`]. `v = 1` itself is
//!   handled as described above.
//! * Below `v ≈ 0.51` the oblate branch loses stability against an
//!   axisymmetric mode (`is_constrained_minimum` becomes `false`), and near
//!   `v ≈ 0.503` the poles touch; self-intersecting profiles are reported as
//!   [`SolveError::UnexpectedShape`]. On every branch a returned profile is
//!   checked to be embedded: interior nodes off the axis, the north pole
//!   above the south pole, and no two segments of the node polygon crossing
//!   or touching (the discrete equations do not see self-contact: below the
//!   domain, a deep cup converges to a stationary profile whose invagination
//!   has pierced the floor, which is rejected).

use nalgebra::{DMatrix, DVector};
use std::f64::consts::PI;
use std::fmt;

pub mod adhered;
#[cfg(test)]
mod branch_tests;
pub mod contact_fit;
mod continuation;
mod discrete;
mod geometry;
mod seeds;
mod stability;
#[cfg(test)]
mod tests;

use continuation::*;
use discrete::*;
use geometry::*;
use seeds::*;
use stability::*;

/// Smallest number of segments accepted by [`solve`].
pub const MIN_SEGMENTS: usize = 16;
/// Largest number of segments accepted by [`solve`] (the dense KKT solve costs
/// `O(N³)` per Newton step).
pub const MAX_SEGMENTS: usize = 2000;
/// Resolutions (numbers of segments) used by [`converged`], finest last; each
/// is twice the previous one, as Richardson extrapolation requires.
pub const CONVERGED_LADDER: [usize; 4] = [100, 200, 400, 800];
/// Tolerance on the max-norm of the gradient of the Lagrangian (in units of
/// `κ` per radian) and of the constraints (`r_N` in units of `R0`, and the
/// reduced volume).
pub const TOLERANCE: f64 = 1e-10;

/// Residual below which no polishing Newton step is taken.
const POLISH_TOLERANCE: f64 = 1e-12;
/// Segments of the grid on which the continuation in `v` runs.
const CONTINUATION_SEGMENTS: usize = 64;
/// Segments of the grid on which the continuation of the stomatocyte branch
/// runs (finer than for the symmetric branches: its neck and rim are narrow).
const STOMATOCYTE_CONTINUATION_SEGMENTS: usize = 128;
/// Reduced volume of the spheroid start of the continuation of the oblate
/// and prolate branches.
const CONTINUATION_START: f64 = 0.95;
/// `(a, b, α)` of the stomatocyte seed ([`stomatocyte_guess`]): radius of the
/// invagination and tube radius of the rim in units of the outer radius, and
/// the angle (radians) swept by the invagination's wall. Its converged
/// reduced volume is about 0.612, inside the branch's range.
const STOMATOCYTE_SEED: (f64, f64, f64) = (0.5, 0.2, 2.5);
/// [`branch_curve`] walks the stomatocyte branch up from this reduced volume
/// for the points at or above it, and down for the others (about the seed's).
const STOMATOCYTE_SEED_REDUCED_VOLUME: f64 = 0.61;
/// First step in `v` of a continuation.
const INITIAL_CONTINUATION_STEP: f64 = 0.025;
/// Largest step in `v` of a continuation.
const MAX_CONTINUATION_STEP: f64 = 0.05;
/// A continuation gives up when its step in `v` falls below this.
const MIN_CONTINUATION_STEP: f64 = 1e-4;
/// Reduced volumes above `1 − SPHERE_WINDOW` are treated as the sphere.
const SPHERE_WINDOW: f64 = 1e-12;
/// `3/√2`: `v = K Σρ² sin φ / (Σρ)^{3/2}`.
const REDUCED_VOLUME_FACTOR: f64 = 3.0 / std::f64::consts::SQRT_2;
/// Finite-difference step (radians) for the Hessian of the Lagrangian.
const HESSIAN_STEP: f64 = 1e-6;
/// Largest change of any tangent angle in one Newton step (radians).
const MAX_STEP: f64 = 0.5;
/// Newton iterations before giving up.
const MAX_NEWTON_ITERATIONS: usize = 60;

/// Why [`solve`], [`solve_on_branch`], [`converged`], [`converged_on_branch`]
/// or [`branch_curve`] could not produce a shape.
#[derive(Debug, Clone, PartialEq)]
pub enum SolveError {
    /// The reduced volume is not a finite number in `(0.5, 1]`.
    InvalidReducedVolume(f64),
    /// The number of segments is outside `[MIN_SEGMENTS, MAX_SEGMENTS]`.
    InvalidSegments(usize),
    /// The continuation or the Newton iteration did not converge; the message
    /// says where. This is also the answer for a reduced volume at which the
    /// requested branch does not exist (e.g. a stomatocyte above its fold,
    /// see [`Branch::Stomatocyte`]).
    NotConverged(String),
    /// The converged profile is not an embedded surface (the generating curve
    /// crosses or touches itself, reaches the axis at an interior node, or has
    /// its poles in the wrong order along the axis), or, on the
    /// [`Branch::Oblate`] branch, its upper and lower halves are not graphs
    /// over `r`, so its thicknesses are undefined.
    UnexpectedShape(String),
}

impl fmt::Display for SolveError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SolveError::InvalidReducedVolume(v) => {
                write!(f, "reduced volume {v} is not a finite number in (0.5, 1]")
            }
            SolveError::InvalidSegments(n) => write!(
                f,
                "{n} segments is outside the accepted range [{MIN_SEGMENTS}, {MAX_SEGMENTS}]"
            ),
            SolveError::NotConverged(msg) => write!(f, "solver did not converge: {msg}"),
            SolveError::UnexpectedShape(msg) => write!(f, "unexpected shape: {msg}"),
        }
    }
}

impl std::error::Error for SolveError {}

/// Family of axisymmetric shapes (a branch of stationary shapes of the
/// Helfrich energy at `c0 = 0`, parametrised by the reduced volume `v`), as in
/// the phase diagram of Seifert, Berndl & Lipowsky, Phys. Rev. A 44, 1182
/// (1991). Existence ranges are those found by this solver within the
/// accepted domain `v ∈ (0.5, 1]` (see the module documentation).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
pub enum Branch {
    /// Up-down symmetric shapes flattened along the axis: oblate
    /// ellipsoid-like near `v = 1`, biconcave discocytes (red-blood-cell
    /// shapes) below `v ≈ 0.892`. Reached from an oblate spheroid; exists on
    /// the whole domain, is a constrained minimum down to `v ≈ 0.51`, and its
    /// poles touch near `v ≈ 0.503`. Lowest-energy branch for
    /// `0.5912 < v < 0.6511`.
    Oblate,
    /// Up-down symmetric shapes elongated along the axis: prolate
    /// ellipsoid-like near `v = 1`, peanut then dumbbell shapes with a waist
    /// below `v ≈ 0.896`. Reached from a prolate spheroid; exists and is a
    /// constrained minimum on the whole domain. Lowest-energy branch for
    /// `v > 0.6511`.
    Prolate,
    /// Up-down asymmetric cup shapes (stomatocytes): a sphere-like outer wall
    /// with a deep invagination at the north pole, whose wall is undercut
    /// (`ψ` reaches −2.1 to −2.5 rad, so the profile is not a graph over `r`).
    /// Reached from a piecewise-circular cup (see the module documentation).
    /// Exists on the domain for `v` below a fold at `v ≈ 0.6608` (where it
    /// turns back into an unstable twin) and continues below the domain's
    /// lower end 0.5; it is a constrained minimum wherever it exists.
    /// Lowest-energy branch for `v < 0.5912`.
    Stomatocyte,
}

impl fmt::Display for Branch {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Branch::Oblate => "oblate",
            Branch::Prolate => "prolate",
            Branch::Stomatocyte => "stomatocyte",
        })
    }
}

/// A converged discrete minimiser at one resolution. Lengths are in units of
/// `R0 = sqrt(A/4π)`, energies in units of `κ` unless stated.
#[derive(Debug, Clone, PartialEq)]
pub struct AxisymmetricShape {
    /// Branch the shape was continued along.
    pub branch: Branch,
    /// Requested reduced volume `v = 3V / (4π R0³)` (dimensionless).
    pub reduced_volume: f64,
    /// Bending energy `E / (8πκ)` of the discrete shape (dimensionless; 1 for
    /// a sphere).
    pub energy_over_8pi_kappa: f64,
    /// Diameter `2 max r` (units of `R0`), from a degree-6 polynomial through
    /// the 7 nodes around the widest node (so it is a smooth function of the
    /// resolution, as Richardson extrapolation needs).
    pub diameter: f64,
    /// Maximal thickness along the axis (units of `R0`).
    ///
    /// * [`Branch::Oblate`]: the largest distance, along the axis, between
    ///   the upper and lower surface at the same radius:
    ///   `max_r (z_upper(r) − z_lower(r))`. The upper (lower) surface is the
    ///   part of the curve from the north (south) pole to the widest point.
    ///   Equal to `centre_thickness` for a convex oblate shape; larger for a
    ///   discocyte.
    /// * [`Branch::Prolate`] and [`Branch::Stomatocyte`], whose halves need
    ///   not be graphs over `r`: the axial extent `max z − min z` of the
    ///   whole profile (smooth extrema from local interpolants, so it is a
    ///   smooth function of the resolution). For an up-down symmetric shape
    ///   the two definitions agree. On the prolate branch the poles are the
    ///   extremes, so it equals `centre_thickness`; for a stomatocyte it is
    ///   the height of the cup, from its bottom (the south pole) to the top of
    ///   its rim, and `max_thickness − centre_thickness` is the depth of the
    ///   invagination.
    pub max_thickness: f64,
    /// Distance between the poles, `z(0) − z(L)` (units of `R0`). For a
    /// stomatocyte the north pole is the bottom of the invagination, so this
    /// is the thickness of the cup's floor along the axis.
    pub centre_thickness: f64,
    /// `true` when both poles are dimpled (concave from outside).
    ///
    /// * [`Branch::Oblate`]: `max_thickness > centre_thickness · (1 + 1e-8)`
    ///   (the discocyte is up-down symmetric, so both poles dimple together).
    /// * Other branches: the north pole lies below the highest point and the
    ///   south pole above the lowest point of the profile, each by more than
    ///   `1e-8 · max_thickness`. Always `false` on the prolate branch, and
    ///   `false` for a stomatocyte, which is dimpled at the north pole only.
    pub biconcave: bool,
    /// Number of segments `N` of the discretisation.
    pub segments: usize,
    /// `(r, z)` at the `N + 1` nodes from the north pole to the south pole
    /// (units of `R0`), shifted so that the poles sit at `z = ±centre_thickness/2`.
    pub profile: Vec<(f64, f64)>,
    /// Length `L` of the generating curve (units of `R0`; `π` for a sphere).
    pub contour_length: f64,
    /// Area `2π ∫ r ds` of the discrete shape (units of `R0²`; target `4π`).
    pub area: f64,
    /// Volume `π ∫ r² sin ψ ds` of the discrete shape (units of `R0³`; target
    /// `v · 4π/3`, except at `v = 1` where the volume is not constrained).
    pub volume: f64,
    /// Reduced volume of the discrete shape (dimensionless).
    pub achieved_reduced_volume: f64,
    /// Closure residual `r_N` (units of `R0`; target 0).
    pub closure_residual: f64,
    /// Max-norm of the gradient of the Lagrangian at the solution (units of `κ`
    /// per radian of `ψ_i`).
    pub lagrangian_gradient_norm: f64,
    /// Smallest eigenvalue of the Hessian of the Lagrangian restricted to the
    /// tangent space of the constraints, in the metric `∫ δψ² ds` (i.e. the
    /// Euclidean eigenvalue divided by `h`); units of `κ / R0`. Positive means
    /// a strict constrained local minimum among axisymmetric shapes (no
    /// up-down symmetry imposed).
    pub min_tangent_hessian_eigenvalue: f64,
    /// `true` when `min_tangent_hessian_eigenvalue > 0`.
    pub is_constrained_minimum: bool,
    /// Newton iterations spent at this resolution (after continuation; for
    /// [`branch_curve`], those of the last continuation step).
    pub newton_iterations: usize,
    /// Pressure difference Δp = p_in − p_out that holds the volume (units
    /// of `κ / R0³`): Δp = ∂E/∂V at fixed area, from the volume
    /// constraint's multiplier λ_v (`𝓛 = E + λ_r r_N + λ_v (v(ψ) − v)`, so
    /// dE/dv = −λ_v and Δp = −λ_v · 3/(4π)). 0 at `v = 1`, where the volume
    /// is not constrained (a sphere under bending alone needs no pressure).
    pub pressure: f64,
    /// Tension σ that holds the area (units of `κ / R0²`). The bending
    /// energy is scale-invariant, so a uniform dilation changes nothing:
    /// 2σA = 3ΔpV, σ = Δp · v / 2. With these signs the equilibrium is
    /// −∇E = σ∇A − Δp∇V, the convention of the engine's constraints
    /// ([`crate::constraint`]).
    pub tension: f64,
}

/// A Richardson-extrapolated quantity with an error bar.
///
/// Rule: with values `q_k` at resolutions `N_k = N_0 2^k`, the order-2
/// Richardson values are `R_k = q_k + (q_k − q_{k−1}) / 3`. `value` is the
/// finest `R`, and `error` is `|R_finest − R_next-to-finest| + 1e-12`, a
/// conservative bound when the next error term is `O(h⁴)` (it overestimates the
/// error of `R_finest` about 16-fold) and the floor covers solver noise.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Extrapolated {
    /// Extrapolated continuum value (same units as the quantity).
    pub value: f64,
    /// Error bar (same units as the quantity).
    pub error: f64,
}

/// Continuum values from solves at the resolutions of [`CONVERGED_LADDER`].
#[derive(Debug, Clone, PartialEq)]
pub struct ConvergedShape {
    /// Branch the shapes were continued along.
    pub branch: Branch,
    /// Requested reduced volume (dimensionless).
    pub reduced_volume: f64,
    /// Extrapolated `E / (8πκ)` (dimensionless).
    pub energy_over_8pi_kappa: Extrapolated,
    /// Extrapolated diameter `2 max r` (units of `R0`).
    pub diameter: Extrapolated,
    /// Extrapolated maximal thickness (see [`AxisymmetricShape::max_thickness`]
    /// for its meaning on each branch; units of `R0`).
    pub max_thickness: Extrapolated,
    /// Extrapolated distance between the poles (see
    /// [`AxisymmetricShape::centre_thickness`]; units of `R0`).
    pub centre_thickness: Extrapolated,
    /// Observed convergence orders `p = log2((q_0 − q_1)/(q_1 − q_2))` from the
    /// three finest levels, for energy, diameter, max thickness and centre
    /// thickness in that order (`NaN` where the differences vanish or change
    /// sign, e.g. for the exact zero-width dimple of a convex shape).
    pub observed_order: [f64; 4],
    /// `true` when every level is biconcave (see
    /// [`AxisymmetricShape::biconcave`]).
    pub biconcave: bool,
    /// `true` when every level is a constrained minimum.
    pub is_constrained_minimum: bool,
    /// The individual solves, coarsest first.
    pub levels: Vec<AxisymmetricShape>,
}

/// Solves for the minimiser on the oblate/discocyte branch at reduced volume
/// `reduced_volume ∈ (0.5, 1]` with `segments` segments; the same as
/// [`solve_on_branch`] with [`Branch::Oblate`].
///
/// Returns an error (never panics) for a reduced volume outside `(0.5, 1]`,
/// a segment count outside `[MIN_SEGMENTS, MAX_SEGMENTS]`, a failed
/// continuation (e.g. near self-contact of the poles as `v → 0.5`, or a
/// reduced volume so close to 1 that it is infeasible at this resolution), or
/// a shape whose halves are not graphs over `r`.
pub fn solve(reduced_volume: f64, segments: usize) -> Result<AxisymmetricShape, SolveError> {
    solve_on_branch(reduced_volume, segments, Branch::Oblate)
}

/// Solves for the stationary shape on `branch` at reduced volume
/// `reduced_volume ∈ (0.5, 1]` with `segments` segments, by continuation in
/// `v` from the branch's starting shape (a spheroid at `v = 0.95` for the
/// oblate and prolate branches, the stomatocyte seed at `v ≈ 0.61`) on a
/// coarse grid, then Newton on the requested grid.
///
/// Errors (never panics): [`SolveError::InvalidReducedVolume`],
/// [`SolveError::InvalidSegments`], [`SolveError::NotConverged`] when the
/// continuation fails (in particular when the branch does not exist at this
/// `v`, e.g. a stomatocyte above its fold at `v ≈ 0.6608`, or at `v = 1`), and
/// [`SolveError::UnexpectedShape`] for a self-intersecting profile.
pub fn solve_on_branch(
    reduced_volume: f64,
    segments: usize,
    branch: Branch,
) -> Result<AxisymmetricShape, SolveError> {
    validate(reduced_volume, segments)?;
    let mut levels = solve_ladder(reduced_volume, &[segments], branch)?;
    Ok(levels.remove(0))
}

/// Solves at the resolutions of [`CONVERGED_LADDER`], measures the observed
/// convergence order and Richardson-extrapolates (formal order 2) the energy,
/// diameter, maximal and centre thickness, with the error rule of
/// [`Extrapolated`]. The same as [`converged_on_branch`] with
/// [`Branch::Oblate`].
pub fn converged(reduced_volume: f64) -> Result<ConvergedShape, SolveError> {
    converged_on_branch(reduced_volume, Branch::Oblate)
}

/// [`converged`] on any branch: solves on `branch` at the resolutions of
/// [`CONVERGED_LADDER`] (each level starting from the previous one) and
/// Richardson-extrapolates the measures. Errors as [`solve_on_branch`].
pub fn converged_on_branch(
    reduced_volume: f64,
    branch: Branch,
) -> Result<ConvergedShape, SolveError> {
    validate(reduced_volume, CONVERGED_LADDER[0])?;
    let levels = solve_ladder(reduced_volume, &CONVERGED_LADDER, branch)?;
    let series = |f: fn(&AxisymmetricShape) -> f64| -> Vec<f64> { levels.iter().map(f).collect() };
    let quantities = [
        series(|s| s.energy_over_8pi_kappa),
        series(|s| s.diameter),
        series(|s| s.max_thickness),
        series(|s| s.centre_thickness),
    ];
    let extrapolated: Vec<Extrapolated> = quantities.iter().map(|q| richardson(q)).collect();
    let mut observed_order = [f64::NAN; 4];
    for (o, q) in observed_order.iter_mut().zip(quantities.iter()) {
        *o = observed_order_of(q);
    }
    Ok(ConvergedShape {
        branch,
        reduced_volume,
        energy_over_8pi_kappa: extrapolated[0],
        diameter: extrapolated[1],
        max_thickness: extrapolated[2],
        centre_thickness: extrapolated[3],
        observed_order,
        biconcave: levels.iter().all(|s| s.biconcave),
        is_constrained_minimum: levels.iter().all(|s| s.is_constrained_minimum),
        levels,
    })
}

/// Solves `branch` at every reduced volume of `reduced_volumes` on
/// `segments` segments, walking along the branch by continuation on that
/// grid: each solution (with a secant predictor from the previous two) is
/// the starting guess of the next, with adaptive sub-steps in `v` where a
/// step is too large. Only the first point of each walk is reached from the
/// branch's starting shape, as [`solve_on_branch`] does.
///
/// The points are visited in the branch's natural order (from high to low
/// `v` for the oblate and prolate branches, which start near the sphere;
/// outwards from the seed `v ≈ 0.61` in both directions for the stomatocyte),
/// and the results are returned in the order of `reduced_volumes`. Each
/// result is the same discrete solution as [`solve_on_branch`] at that `v`
/// (to the Newton tolerance), at a fraction of the cost for a whole curve.
/// A point that fails (invalid `v`, or past the end of the branch) gets its
/// error and the walk goes on from the last solution.
pub fn branch_curve(
    branch: Branch,
    reduced_volumes: &[f64],
    segments: usize,
) -> Vec<Result<AxisymmetricShape, SolveError>> {
    // Every valid point is visited below and overwrites its placeholder.
    let mut results: Vec<Result<AxisymmetricShape, SolveError>> = reduced_volumes
        .iter()
        .map(|&v| {
            validate(v, segments)?;
            Err(SolveError::NotConverged(format!("v = {v} was not visited")))
        })
        .collect();
    let mut chained = Vec::new();
    for (i, &v) in reduced_volumes.iter().enumerate() {
        if validate(v, segments).is_err() {
            continue;
        }
        if v > 1.0 - SPHERE_WINDOW {
            // The sphere is degenerate (both symmetric branches bifurcate
            // from it): solved on its own, never continued from.
            results[i] = solve_on_branch(v, segments, branch);
        } else {
            chained.push(i);
        }
    }
    let descending = |a: &usize, b: &usize| reduced_volumes[*b].total_cmp(&reduced_volumes[*a]);
    let walks: Vec<Vec<usize>> = match branch {
        Branch::Oblate | Branch::Prolate => {
            chained.sort_by(descending);
            vec![chained]
        }
        Branch::Stomatocyte => {
            let (mut up, mut down): (Vec<usize>, Vec<usize>) = chained
                .into_iter()
                .partition(|&i| reduced_volumes[i] >= STOMATOCYTE_SEED_REDUCED_VOLUME);
            up.sort_by(|a, b| descending(b, a));
            down.sort_by(descending);
            vec![up, down]
        }
    };
    for walk in walks {
        let mut walker: Option<Walker> = None;
        // Once a walk has stopped (e.g. at the fold that ends the stomatocyte
        // branch), the points further along cannot be reached either.
        let mut stopped: Option<SolveError> = None;
        for i in walk {
            let v = reduced_volumes[i];
            let problem = Problem::closed(Some(v));
            if let Some(e) = &stopped {
                results[i] = Err(SolveError::NotConverged(format!(
                    "v = {v} lies beyond the point where the walk along the branch stopped ({e})"
                )));
                continue;
            }
            results[i] = match walker.as_mut() {
                Some(w) => match w.advance(v, branch) {
                    Ok(()) => finish(problem, v, &w.solution, branch),
                    Err(e) => {
                        stopped = Some(e.clone());
                        Err(e)
                    }
                },
                None => solve_ladder_raw(v, &[segments], branch).map(|mut levels| {
                    let (shape, solution) = levels.remove(0);
                    walker = Some(Walker::new(v, solution));
                    shape
                }),
            };
        }
    }
    results
}
