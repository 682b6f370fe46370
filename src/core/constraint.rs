//! Exact area and volume constraints (SPEC §8): the kernels behind the
//! `constraint_reactions` and `constraint_projection` systems.
//!
//! With constraints A(x) = A_t and V(x) = V_t the membrane is in equilibrium
//! when −∇E = σ∇A − Δp∇V, the Lagrange multipliers being the tension σ
//! (Ē/l̄²) and the pressure difference Δp = p_in − p_out (Ē/l̄³). Given the
//! force F = −∇E of every term, [`remove_reactions`] finds the (σ, Δp) that
//! minimise |F − σ∇A + Δp∇V| (least squares over all vertices) and leaves
//! F tangent to the constraint surface: what is left moves the shape
//! without changing A or V to first order, and vanishes at equilibrium.
//! A sphere under a tension term σ₀ with its volume held gives
//! Δp = σ₀·|∇A|/|∇V| = 2σ₀/R (Laplace).
//!
//! [`project`] then returns the positions to the constraint surface after a
//! step, by Gauss-Newton steps Δx = λ_A∇A + λ_V∇V (the shortest move that
//! corrects A and V to first order).

use glam::DVec3;

/// The targets held (l̄², l̄³); `None` is not constrained.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ConstraintTargets {
    /// Total area A_t (l̄²).
    pub area: Option<f64>,
    /// Enclosed volume V_t (l̄³).
    pub volume: Option<f64>,
}

/// Area, volume and their gradients at a set of positions.
#[derive(Clone, Debug, Default)]
pub struct Gradients {
    /// Total area (l̄²).
    pub area: f64,
    /// Enclosed volume (l̄³).
    pub volume: f64,
    /// ∂A/∂x_i by vertex slot (l̄).
    pub area_gradient: Vec<DVec3>,
    /// ∂V/∂x_i by vertex slot (l̄²).
    pub volume_gradient: Vec<DVec3>,
    /// Per-face terms of [`Gradients::measure_on`]'s gathered form.
    faces: Vec<FaceTerms>,
}

/// One face's terms of A and V, and its unit normal, for the gathered
/// [`Gradients::measure_on`] (each corner's gradients are formed where
/// they are added, by the expressions of [`Gradients::measure`]).
#[derive(Clone, Copy, Debug, Default)]
struct FaceTerms {
    /// Twice its area.
    double: f64,
    /// Six times its signed tetrahedron's volume.
    six_volume: f64,
    /// Its unit normal (used only where `double > 0`).
    n_hat: DVec3,
}

impl Gradients {
    /// Measures A, V, ∇A and ∇V at `positions` (one pass over the faces, in
    /// face order). The volume is summed against `positions[0]`, as
    /// everywhere else in the engine.
    pub fn measure(&mut self, positions: &[DVec3], faces: &[[u32; 3]]) {
        let n = positions.len();
        self.area_gradient.clear();
        self.area_gradient.resize(n, DVec3::ZERO);
        self.volume_gradient.clear();
        self.volume_gradient.resize(n, DVec3::ZERO);
        let origin = positions.first().copied().unwrap_or(DVec3::ZERO);
        let (mut twice_area, mut six_volume) = (0.0, 0.0);
        for f in faces {
            let [i0, i1, i2] = f.map(|v| v as usize);
            let (a, b, c) = (positions[i0], positions[i1], positions[i2]);
            let normal = (b - a).cross(c - a);
            let double = normal.length();
            twice_area += double;
            if double > 0.0 {
                let n_hat = normal / double;
                let g = crate::mesh::geometry::face_area_gradient(&[a, b, c], n_hat);
                self.area_gradient[i0] += g[0];
                self.area_gradient[i1] += g[1];
                self.area_gradient[i2] += g[2];
            }
            let (ra, rb, rc) = (a - origin, b - origin, c - origin);
            six_volume += ra.dot(rb.cross(rc));
            self.volume_gradient[i0] += rb.cross(rc) / 6.0;
            self.volume_gradient[i1] += rc.cross(ra) / 6.0;
            self.volume_gradient[i2] += ra.cross(rb) / 6.0;
        }
        self.area = 0.5 * twice_area;
        self.volume = six_volume / 6.0;
    }

    /// [`Gradients::measure`] on `topology`'s faces; where the vertices
    /// split, as a gather (each face's terms in parallel, then each vertex adds its
    /// faces' in ascending face order while A and V are summed in face
    /// order): the same bits, in parallel.
    pub fn measure_on(&mut self, positions: &[DVec3], topology: &crate::mesh::topology::Topology) {
        use crate::util::parallel::{fill_vec, for_chunks2, splits};
        let faces = &topology.faces;
        let n = positions.len();
        if !splits(n) || topology.vertex_count() != n {
            return self.measure(positions, faces);
        }
        let incidence = topology.face_incidence();
        let origin = positions.first().copied().unwrap_or(DVec3::ZERO);
        fill_vec(&mut self.faces, faces.len(), |k| {
            let [a, b, c] = faces[k].map(|v| positions[v as usize]);
            let normal = (b - a).cross(c - a);
            let double = normal.length();
            let (ra, rb, rc) = (a - origin, b - origin, c - origin);
            FaceTerms {
                double,
                six_volume: ra.dot(rb.cross(rc)),
                n_hat: normal / double,
            }
        });
        for g in [&mut self.area_gradient, &mut self.volume_gradient] {
            if g.len() != n {
                g.clear();
                g.resize(n, DVec3::ZERO);
            }
        }
        let (terms, incidence) = (&self.faces, &*incidence);
        // (A degenerate face's normal is NaN; it adds no area gradient.)
        let ((twice_area, six_volume), ()) = rayon::join(
            || {
                let (mut twice_area, mut six_volume) = (0.0, 0.0);
                for t in terms {
                    twice_area += t.double;
                    six_volume += t.six_volume;
                }
                (twice_area, six_volume)
            },
            || {
                let (ga, gv) = (&mut self.area_gradient, &mut self.volume_gradient);
                for_chunks2(ga, gv, |start, ga, gv| {
                    for (j, (ga, gv)) in ga.iter_mut().zip(gv.iter_mut()).enumerate() {
                        let (mut a, mut v) = (DVec3::ZERO, DVec3::ZERO);
                        for &e in incidence.of(start + j) {
                            let (f, k) = ((e >> 2) as usize, (e & 3) as usize);
                            let t = &terms[f];
                            // The corner's own and the next two, as in
                            // `face_area_gradient` and `measure`'s volume.
                            let face = faces[f];
                            let (next, prev) = (face[(k + 1) % 3], face[(k + 2) % 3]);
                            let (p_next, p_prev) =
                                (positions[next as usize], positions[prev as usize]);
                            if t.double > 0.0 {
                                a += 0.5 * t.n_hat.cross(p_prev - p_next);
                            }
                            v += (p_next - origin).cross(p_prev - origin) / 6.0;
                        }
                        (*ga, *gv) = (a, v);
                    }
                });
            },
        );
        self.area = 0.5 * twice_area;
        self.volume = six_volume / 6.0;
    }
}

/// The multipliers of one evaluation.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Reactions {
    /// σ, the tension that holds the area (Ē/l̄²; 0 without an area
    /// constraint).
    #[serde(deserialize_with = "crate::util::validate::number_or_nan")]
    pub tension: f64,
    /// Δp = p_in − p_out, the pressure that holds the volume (Ē/l̄³; 0
    /// without a volume constraint).
    #[serde(deserialize_with = "crate::util::validate::number_or_nan")]
    pub pressure: f64,
}

/// The dot products Σ_i x[i]·y[i] of the `pairs` (x, y) of equally long
/// slices, in one pass: each is summed as `x.iter().zip(y).map(dot).sum()`
/// sums it (from −0, in index order), so the same bits, but the sums'
/// addition chains overlap (a sum's additions wait for each other, so one
/// pass of several sums costs about what one sum does). One thread: a sum
/// in index order is what keeps the bits for any thread count.
fn dots<const M: usize>(pairs: [(&[DVec3], &[DVec3]); M]) -> [f64; M] {
    let n = pairs.first().map_or(0, |(x, _)| x.len());
    assert!(pairs.iter().all(|(x, y)| x.len() == n && y.len() == n));
    let mut sums = [-0.0; M];
    for i in 0..n {
        for (s, (x, y)) in sums.iter_mut().zip(&pairs) {
            *s += x[i].dot(y[i]);
        }
    }
    sums
}

/// Solves the normal equations of the active constraints for the
/// coefficients c of Δ = c_A g_A + c_V g_V with g·Δ = r, scaled to unit
/// gradients so that the 2×2 solve is well conditioned; a nearly
/// degenerate pair (a sphere, where ∇A ∥ ∇V) is regularised (Tikhonov,
/// 1e-12 of the diagonal), which gives the least-norm compromise.
/// `gram` = [∇A·∇A, ∇V·∇V, ∇A·∇V].
fn solve(gram: [f64; 3], t: ConstraintTargets, r: [f64; 2]) -> [f64; 2] {
    let [aa, vv, av] = gram;
    match (t.area.is_some(), t.volume.is_some()) {
        (false, false) => [0.0, 0.0],
        (true, false) => [r[0] / aa.max(f64::MIN_POSITIVE), 0.0],
        (false, true) => [0.0, r[1] / vv.max(f64::MIN_POSITIVE)],
        (true, true) => {
            let (na, nv) = (aa.sqrt(), vv.sqrt());
            if na == 0.0 || nv == 0.0 {
                return [0.0, 0.0];
            }
            let rho = av / (na * nv);
            let (d, b) = (1.0 + 1e-12, [r[0] / na, r[1] / nv]);
            let det = d * d - rho * rho;
            let y = [(d * b[0] - rho * b[1]) / det, (d * b[1] - rho * b[0]) / det];
            [y[0] / na, y[1] / nv]
        }
    }
}

/// Removes the constraints' reactions from `force` (Ē/l̄, by vertex slot):
/// afterwards `force` is orthogonal to ∇A and ∇V of the active targets.
/// Returns the multipliers (see the module documentation for the signs).
pub fn remove_reactions(g: &Gradients, t: ConstraintTargets, force: &mut [DVec3]) -> Reactions {
    let (ga, gv) = (&g.area_gradient[..], &g.volume_gradient[..]);
    let [af, vf, aa, vv, av] = dots([(ga, force), (gv, force), (ga, ga), (gv, gv), (ga, gv)]);
    let c = solve([aa, vv, av], t, [af, vf]);
    crate::util::parallel::for_each_mut(force, |i, f| {
        *f -= c[0] * ga[i] + c[1] * gv[i];
    });
    Reactions {
        tension: c[0],
        pressure: -c[1],
    }
}

/// The constraints as one force evaluation saw them.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ConstraintState {
    /// The targets held.
    pub targets: ConstraintTargets,
    /// Area at the evaluation (l̄²).
    #[serde(deserialize_with = "crate::util::validate::number_or_nan")]
    pub area: f64,
    /// Volume at the evaluation (l̄³).
    #[serde(deserialize_with = "crate::util::validate::number_or_nan")]
    pub volume: f64,
    /// The multipliers removed from the force.
    pub reactions: Reactions,
}

impl ConstraintState {
    /// The largest relative violation |value − target| / target of the
    /// active constraints (0 when none is active).
    pub fn violation(&self) -> f64 {
        let rel = |value: f64, target: Option<f64>| target.map_or(0.0, |t| ((value - t) / t).abs());
        rel(self.area, self.targets.area).max(rel(self.volume, self.targets.volume))
    }
}

/// What one projection did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Projection {
    /// Gauss-Newton steps taken.
    pub steps: u32,
    /// Whether a step was scaled down to the largest correction (the
    /// target is still being approached).
    pub limited: bool,
}

/// Relative violation below which [`project`] stops.
const PROJECTION_TOLERANCE: f64 = 1e-12;
/// Most Gauss-Newton steps of one projection.
const PROJECTION_STEPS: u32 = 8;

/// Area and volume only (the check between Gauss-Newton steps), summed as
/// in [`Gradients::measure`] (where the faces split, each face's terms in
/// parallel into `buffer`, then summed in face order: the same bits).
fn area_and_volume(
    positions: &[DVec3],
    faces: &[[u32; 3]],
    buffer: &mut Vec<(f64, f64)>,
) -> (f64, f64) {
    let origin = positions.first().copied().unwrap_or(DVec3::ZERO);
    let terms = |f: &[u32; 3]| {
        let [a, b, c] = f.map(|v| positions[v as usize]);
        (
            (b - a).cross(c - a).length(),
            (a - origin).dot((b - origin).cross(c - origin)),
        )
    };
    let (mut twice_area, mut six_volume) = (0.0, 0.0);
    if crate::util::parallel::splits(faces.len()) {
        crate::util::parallel::fill_vec(buffer, faces.len(), |k| terms(&faces[k]));
        for (double, six) in buffer.iter() {
            twice_area += double;
            six_volume += six;
        }
    } else {
        for f in faces {
            let (double, six) = terms(f);
            twice_area += double;
            six_volume += six;
        }
    }
    (0.5 * twice_area, six_volume / 6.0)
}

/// Reusable buffers of [`project`].
#[derive(Clone, Debug, Default)]
pub struct ProjectionScratch {
    gradients: Gradients,
    /// The correction directions: ∇A and ∇V averaged over 1-rings.
    directions: [Vec<DVec3>; 2],
    smoothing: crate::energy::penalty::SmoothingScratch,
    /// Per-face area and volume terms ([`area_and_volume`]).
    faces: Vec<(f64, f64)>,
}

/// M_ij = g_i · d_j, the change of constraint i along direction j.
fn response(g: [&[DVec3]; 2], d: [&[DVec3]; 2]) -> [[f64; 2]; 2] {
    let [m00, m01, m10, m11] = dots([(g[0], d[0]), (g[0], d[1]), (g[1], d[0]), (g[1], d[1])]);
    [[m00, m01], [m10, m11]]
}

/// Solves M c = r for the active constraints, with a relative Tikhonov
/// term of 1e-12 against a singular pair (a sphere).
pub(crate) fn solve_response(m: [[f64; 2]; 2], t: ConstraintTargets, r: [f64; 2]) -> [f64; 2] {
    match (t.area.is_some(), t.volume.is_some()) {
        (false, false) => [0.0, 0.0],
        (true, false) => [r[0] / nonzero(m[0][0]), 0.0],
        (false, true) => [0.0, r[1] / nonzero(m[1][1])],
        (true, true) => {
            let [[a, b], [c, e]] = m;
            // Scale rows and columns to unit diagonal before regularising.
            let (sa, se) = (nonzero(a.abs()).sqrt(), nonzero(e.abs()).sqrt());
            let (a, b, c, e) = (a / (sa * sa), b / (sa * se), c / (se * sa), e / (se * se));
            let (a, e) = (a + 1e-12 * a.signum(), e + 1e-12 * e.signum());
            let (ra, re) = (r[0] / sa, r[1] / se);
            let det = a * e - b * c;
            [(e * ra - b * re) / det / sa, (a * re - c * ra) / det / se]
        }
    }
}

fn nonzero(x: f64) -> f64 {
    if x == 0.0 { f64::MIN_POSITIVE } else { x }
}

/// Where the projection's directions come from.
#[derive(Clone, Copy, Debug)]
pub enum Directions<'a> {
    /// ∇A and ∇V averaged this many times over closed 1-rings: the exact
    /// gradients carry the discrete curvature's vertex-to-vertex noise, and
    /// a large correction along them (a target approached from afar)
    /// wrinkles the mesh; smoothed directions reach the same targets (the
    /// steps solve with the exact gradients) without the noise.
    Smoothed(u32),
    /// Given by the caller (a preconditioned minimiser's W = P⁻¹∇C, smooth
    /// by construction); a direction of another length than the positions
    /// falls back to the exact gradient.
    Given([&'a [DVec3]; 2]),
}

/// Directions that a preconditioned minimiser publishes for the
/// projection (its metric's W_A, W_V, by vertex slot); empty: the
/// projection smooths the gradients itself. A resource.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ProjectionDirections(pub [Vec<DVec3>; 2]);

/// Moves `positions` onto A = A_t, V = V_t by Newton steps
/// Δx = c_A d_A + c_V d_V with c solving ∇C·Δx = −C (the response ∇C·d
/// measured at the first step and after every two chord steps), along the
/// `directions` d ([`Directions`]). No step moves a vertex by more than
/// `max_correction` (l̄): a target farther away is approached by one scaled
/// step per call. Between steps only A and V are measured.
pub fn project(
    positions: &mut [DVec3],
    topology: &crate::mesh::topology::Topology,
    t: ConstraintTargets,
    max_correction: f64,
    directions: Directions<'_>,
    scratch: &mut ProjectionScratch,
) -> Projection {
    let faces = &topology.faces;
    let mut out = Projection::default();
    let held = |r: f64, target: Option<f64>| {
        target.is_none_or(|x| r.abs() <= PROJECTION_TOLERANCE * x.abs())
    };
    let residual = |(area, volume): (f64, f64)| {
        [
            t.area.map_or(0.0, |a| a - area),
            t.volume.map_or(0.0, |v| v - volume),
        ]
    };
    let mut r = residual(area_and_volume(positions, faces, &mut scratch.faces));
    // The directions and their response are measured at the first step
    // and again after every two chord steps that did not reach the target
    // (the residual after a Newton step is second order, so near the
    // constraint one measurement per call is enough).
    let ProjectionScratch {
        gradients: g,
        directions: [da, dv],
        smoothing: smoothing_scratch,
        faces: face_terms,
    } = scratch;
    let mut m = [[0.0; 2]; 2];
    let mut chord_steps = 0;
    while out.steps < PROJECTION_STEPS && !(held(r[0], t.area) && held(r[1], t.volume)) {
        if out.steps == 0 || chord_steps == 2 {
            g.measure_on(positions, topology);
            match directions {
                Directions::Smoothed(smoothing) => {
                    da.clone_from(&g.area_gradient);
                    dv.clone_from(&g.volume_gradient);
                    if smoothing > 0 {
                        use crate::energy::penalty::smooth_over_rings;
                        smooth_over_rings(da, topology, smoothing, smoothing_scratch);
                        smooth_over_rings(dv, topology, smoothing, smoothing_scratch);
                    }
                }
                Directions::Given([a, v]) => {
                    let n = positions.len();
                    da.clear();
                    da.extend_from_slice(if a.len() == n { a } else { &g.area_gradient });
                    dv.clear();
                    dv.extend_from_slice(if v.len() == n { v } else { &g.volume_gradient });
                }
            }
            m = response([&g.area_gradient, &g.volume_gradient], [da, dv]);
            chord_steps = 0;
        }
        let c = solve_response(m, t, r);
        // (A maximum of lengths, ≥ 0, NaN skipped: the same in any grouping.)
        let largest = |c: [f64; 2]| {
            crate::util::parallel::reduce_ranges(
                positions.len(),
                || 0.0,
                |range| {
                    range
                        .map(|i| (c[0] * da[i] + c[1] * dv[i]).length())
                        .fold(0.0, f64::max)
                },
                f64::max,
            )
        };
        let full = largest(c);
        let (c, scale) = if full <= max_correction {
            (c, 1.0)
        } else {
            out.limited = true;
            // The constraint farther from its target (relatively) is
            // approached at the rate the cap allows; the nearer one is
            // corrected in full, so that it does not drift while the other
            // is approached (a uniform scaling of the whole step lets it
            // wander by the step's second-order error every iteration).
            let relative = |k: usize, x: Option<f64>| x.map_or(0.0, |x| (r[k] / x).abs());
            let far = usize::from(relative(1, t.volume) > relative(0, t.area));
            let mut near_only = r;
            near_only[far] = 0.0;
            let c_near = solve_response(m, t, near_only);
            let c_far = [c[0] - c_near[0], c[1] - c_near[1]];
            let near = largest(c_near);
            if near >= max_correction || t.area.is_none() || t.volume.is_none() {
                (c, max_correction / full)
            } else {
                // |step_near + s step_far| ≤ |step_near| + s |step_far|.
                let s = ((max_correction - near) / largest(c_far)).min(1.0);
                ([c_near[0] + s * c_far[0], c_near[1] + s * c_far[1]], 1.0)
            }
        };
        crate::util::parallel::for_each_mut(positions, |i, p| {
            *p += scale * (c[0] * da[i] + c[1] * dv[i]);
        });
        out.steps += 1;
        chord_steps += 1;
        if out.limited {
            break;
        }
        r = residual(area_and_volume(positions, faces, face_terms));
    }
    out
}

/// The scene's exact constraints, resolved against the initial mesh (a
/// resource inserted by the constraints plugin).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Constraints {
    /// The targets held.
    pub targets: ConstraintTargets,
    /// Largest displacement of any vertex by one tick's projection (l̄).
    pub max_correction: f64,
    /// Passes of 1-ring averaging of the projection's directions.
    pub smoothing: u32,
}
