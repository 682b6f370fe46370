//! The double-barrier edge potential V_in (SPEC §2) and its piecewise-linear
//! segmentation (SPEC §3).
//!
//! V_in(l) = V0·[coth(k_w(l − l_min)) + coth(k_w(l_max − l))
//!              + b·σ(k11(l − r11)) + b·σ(k12(r12 − l))
//!              + b·σ(k21(l − r21)) + b·σ(k22(r22 − l))] − offset,
//! σ(x) = 1/(1 + e^{−x}); the offset makes the minimum over the sample grid 0.
//!
//! ## The force term
//!
//! Stage: Forces. Reads: positions, topology (edges). Writes: force
//! accumulator. Units: Ē, Ē/l̄. One V_in per edge: E_in = Σ_edges V_in(l_e);
//! the force on an edge's end points is ∓V_in'(l) along the edge, with V_in'
//! the chord slope of l's segment (piecewise-linear form) or the exact slope.

use crate::engine::force::{FlipProposal, ForceContext, ForceKind, ForceTerm};
use crate::engine::resources::{Res, ResMut};
use crate::engine::schedule::{Stage, System};
use crate::engine::simulation::{DensePositions, Plugin, SimBuilder, SimError};
use crate::engine::term_inputs::TermInputs;
use crate::mesh::membrane::Membrane;
use glam::DVec3;
use serde::{Deserialize, Serialize};
use std::sync::Arc;

/// Parameters of V_in and of its segmentation. Defaults are the as-run set.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct VinParams {
    /// V0, energy scale of the potential (Ē; default 0.2 = 2 k_BT).
    pub v0: f64,
    /// b, barrier height relative to V0 (dimensionless; default 0.5).
    pub barrier_height: f64,
    /// (r11, r12): rising and falling flank of the near barrier (l̄; default 0.05, 0.75).
    pub near_barrier: (f64, f64),
    /// (r21, r22): rising and falling flank of the far barrier (l̄; default 1.25, 1.75).
    pub far_barrier: (f64, f64),
    /// (k11, k12): steepness of the near barrier's flanks (1/l̄; default 50, 25).
    pub near_steepness: (f64, f64),
    /// (k21, k22): steepness of the far barrier's flanks (1/l̄; default 25, 50).
    pub far_steepness: (f64, f64),
    /// k_w, steepness of the two coth walls (1/l̄; default 100).
    pub wall_steepness: f64,
    /// l_min, position of the near wall (l̄; default 0 as run, the paper's table says −0.05).
    pub l_min: f64,
    /// l_max, position of the far wall (l̄; default 2.2).
    pub l_max: f64,
    /// dl, sampling step of the segmentation grid (l̄; default 1e-4).
    pub dl: f64,
    /// A segment is split while its linear fit has R² below this (default 0.5).
    pub segment_r2_min: f64,
    /// ... or while the sample standard deviation of V within it exceeds this
    /// (Ē, absolute; default 0.001 as run; the paper's text says 0.001·V0).
    pub segment_std_max: f64,
    /// Which form the force system evaluates (default `PiecewiseLinear`, the
    /// segmentation chords the dynamics needs; `Exact` for analysis).
    pub form: VinForm,
}

/// Which form of V_in a force system evaluates.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum VinForm {
    /// The chord of the segment containing l (SPEC §3): what the dynamics uses.
    #[default]
    PiecewiseLinear,
    /// The smooth formula (for analysis and checks).
    Exact,
}

impl Default for VinParams {
    fn default() -> Self {
        Self {
            v0: 0.2,
            barrier_height: 0.5,
            near_barrier: (0.05, 0.75),
            far_barrier: (1.25, 1.75),
            near_steepness: (50.0, 25.0),
            far_steepness: (25.0, 50.0),
            wall_steepness: 100.0,
            l_min: 0.0,
            l_max: 2.2,
            dl: 1e-4,
            segment_r2_min: 0.5,
            segment_std_max: 0.001,
            form: VinForm::PiecewiseLinear,
        }
    }
}

#[inline]
fn sigmoid(x: f64) -> f64 {
    1.0 / (1.0 + (-x).exp())
}

impl VinParams {
    /// V_in(l) without the offset (Ē).
    pub fn raw(&self, l: f64) -> f64 {
        let kw = self.wall_steepness;
        let b = self.barrier_height;
        let walls = 1.0 / (kw * (l - self.l_min)).tanh() + 1.0 / (kw * (self.l_max - l)).tanh();
        let barriers = b * sigmoid(self.near_steepness.0 * (l - self.near_barrier.0))
            + b * sigmoid(self.near_steepness.1 * (self.near_barrier.1 - l))
            + b * sigmoid(self.far_steepness.0 * (l - self.far_barrier.0))
            + b * sigmoid(self.far_steepness.1 * (self.far_barrier.1 - l));
        self.v0 * (walls + barriers)
    }

    /// dV_in/dl (Ē/l̄).
    pub fn derivative(&self, l: f64) -> f64 {
        let kw = self.wall_steepness;
        let b = self.barrier_height;
        let csch2 = |x: f64| {
            let s = x.sinh();
            1.0 / (s * s)
        };
        let walls = -kw * csch2(kw * (l - self.l_min)) + kw * csch2(kw * (self.l_max - l));
        let ds = |k: f64, x: f64| {
            let s = sigmoid(k * x);
            k * s * (1.0 - s)
        };
        let barriers = b * ds(self.near_steepness.0, l - self.near_barrier.0)
            - b * ds(self.near_steepness.1, self.near_barrier.1 - l)
            + b * ds(self.far_steepness.0, l - self.far_barrier.0)
            - b * ds(self.far_steepness.1, self.far_barrier.1 - l);
        self.v0 * (walls + barriers)
    }

    /// V_in(l) without the offset and dV_in/dl together (Ē, Ē/l̄), sharing
    /// one hyperbolic function per wall (csch² = coth² − 1) and one
    /// exponential per barrier flank: half the transcendental calls of
    /// [`VinParams::raw`] and [`VinParams::derivative`], equal to them to
    /// round-off.
    #[inline]
    pub fn raw_and_derivative(&self, l: f64) -> (f64, f64) {
        let kw = self.wall_steepness;
        let b = self.barrier_height;
        let wall = |x: f64| {
            let coth = 1.0 / x.tanh();
            (coth, coth * coth - 1.0)
        };
        let (near_wall, near_csch2) = wall(kw * (l - self.l_min));
        let (far_wall, far_csch2) = wall(kw * (self.l_max - l));
        let flank = |k: f64, x: f64| {
            let s = sigmoid(k * x);
            (s, k * s * (1.0 - s))
        };
        let (s11, d11) = flank(self.near_steepness.0, l - self.near_barrier.0);
        let (s12, d12) = flank(self.near_steepness.1, self.near_barrier.1 - l);
        let (s21, d21) = flank(self.far_steepness.0, l - self.far_barrier.0);
        let (s22, d22) = flank(self.far_steepness.1, self.far_barrier.1 - l);
        let value = near_wall + far_wall + b * (s11 + s12 + s21 + s22);
        let slope = kw * (far_csch2 - near_csch2) + b * (d11 - d12 + d21 - d22);
        (self.v0 * value, self.v0 * slope)
    }

    /// Checks the parameters describe a double-barrier potential; returns the
    /// offending field and reason otherwise.
    pub fn check(&self) -> Result<(), (&'static str, String)> {
        let pos = |name, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err((name, format!("must be > 0 (got {v})")))
            }
        };
        pos("v0", self.v0)?;
        pos("barrier_height", self.barrier_height)?;
        pos("wall_steepness", self.wall_steepness)?;
        pos("dl", self.dl)?;
        pos("segment_std_max", self.segment_std_max)?;
        for (name, (a, b)) in [
            ("near_steepness", self.near_steepness),
            ("far_steepness", self.far_steepness),
        ] {
            pos(name, a)?;
            pos(name, b)?;
        }
        if !(self.segment_r2_min.is_finite() && (0.0..1.0).contains(&self.segment_r2_min)) {
            return Err((
                "segment_r2_min",
                format!("must be in [0, 1) (got {})", self.segment_r2_min),
            ));
        }
        let order = [
            self.l_min,
            self.near_barrier.0,
            self.near_barrier.1,
            self.far_barrier.0,
            self.far_barrier.1,
            self.l_max,
        ];
        if order.iter().any(|x| !x.is_finite()) || order.windows(2).any(|w| w[0] >= w[1]) {
            return Err((
                "near_barrier",
                format!(
                    "need l_min < r11 < r12 < r21 < r22 < l_max (got {} < {} < {} < {} < {} < {})",
                    order[0], order[1], order[2], order[3], order[4], order[5]
                ),
            ));
        }
        if (self.l_max - self.l_min) / self.dl < 100.0 || (self.l_max - self.l_min) / self.dl > 1e7
        {
            return Err((
                "dl",
                format!(
                    "gives {} samples; need 100..1e7",
                    (self.l_max - self.l_min) / self.dl
                ),
            ));
        }
        Ok(())
    }
}

/// V_in sampled on l = l_min + dl … l_max − dl, offset so the minimum sample
/// is 0, and cut into segments whose chords form the piecewise-linear V_in
/// used by the dynamics.
#[derive(Clone, Debug)]
pub struct Segmentation {
    params: VinParams,
    /// Offset subtracted from the raw potential (Ē).
    pub offset: f64,
    /// Breakpoint lengths b_0 < b_1 < … < b_Ω (l̄); segment s (0-based) is (b_s, b_{s+1}].
    pub breakpoints: Vec<f64>,
    /// V_in (offset) at each breakpoint (Ē).
    pub values: Vec<f64>,
    /// Chord slope of each segment (Ē/l̄).
    pub slopes: Vec<f64>,
    /// Segment lookup: `bin_segment[j]` is the segment containing the start
    /// b_0 + j·w of lookup bin j, for a bin width w of half the narrowest
    /// segment, so the segment of any l in the bin is that one or the next
    /// (at most one breakpoint per bin). Small enough to stay in L1 (438
    /// segments as run: 3.2 k bins of u16, 6 KiB; the fine sample grid
    /// would take 88 KiB).
    bin_segment: Vec<u16>,
    /// (start, value at start, slope) of each segment, packed for lookup.
    packed: Vec<[f64; 3]>,
    /// Squared step targets of each segment: (midpoint_below², midpoint_above²).
    step_targets_sq: Vec<[f64; 2]>,
    /// b_0 (l̄).
    lookup_origin: f64,
    /// 1/w (1/l̄).
    inv_bin_width: f64,
}

impl Segmentation {
    /// Samples and segments V_in (SPEC §3): critical points (ends, strict
    /// interior extrema) give the initial segments; any segment whose samples
    /// (both ends included) have a least-squares R² below `segment_r2_min` or
    /// a sample standard deviation (N − 1) above `segment_std_max` is split at
    /// its rounded midpoint index until all settle.
    pub fn new(params: VinParams) -> Self {
        let n_bins = ((params.l_max - params.l_min) / params.dl).round() as usize;
        let count = n_bins - 1;
        let l_at = |k: usize| params.l_min + (k + 1) as f64 * params.dl;
        let raw: Vec<f64> = (0..count).map(|k| params.raw(l_at(k))).collect();
        let offset = raw.iter().copied().fold(f64::INFINITY, f64::min);
        let y: Vec<f64> = raw.iter().map(|v| v - offset).collect();

        let mut cuts = vec![0usize];
        for k in 1..count - 1 {
            if (y[k - 1] < y[k] && y[k + 1] < y[k]) || (y[k - 1] > y[k] && y[k + 1] > y[k]) {
                cuts.push(k);
            }
        }
        cuts.push(count - 1);

        loop {
            let mut next = Vec::with_capacity(cuts.len() * 2);
            let mut changed = false;
            for w in cuts.windows(2) {
                let (a, b) = (w[0], w[1]);
                next.push(a);
                if b - a > 1 && needs_split(&y, a, b, &params, l_at) {
                    next.push((a + b).div_ceil(2));
                    changed = true;
                }
            }
            next.push(*cuts.last().unwrap_or(&0));
            cuts = next;
            if !changed {
                break;
            }
        }

        let breakpoints: Vec<f64> = cuts.iter().map(|&k| l_at(k)).collect();
        let values: Vec<f64> = cuts.iter().map(|&k| y[k]).collect();
        let slopes: Vec<f64> = (0..cuts.len() - 1)
            .map(|s| (values[s + 1] - values[s]) / (breakpoints[s + 1] - breakpoints[s]))
            .collect();
        let packed = (0..slopes.len())
            .map(|s| [breakpoints[s], values[s], slopes[s]])
            .collect();
        let narrowest = breakpoints
            .windows(2)
            .map(|w| w[1] - w[0])
            .fold(f64::INFINITY, f64::min);
        let origin = breakpoints[0];
        let span = breakpoints[breakpoints.len() - 1] - origin;
        let bins = (2.0 * span / narrowest).ceil() as usize + 1;
        let inv_bin_width = bins as f64 / span;
        let mut bin_segment = Vec::with_capacity(bins + 1);
        let mut seg = 0usize;
        for j in 0..=bins {
            let start = origin + j as f64 / inv_bin_width;
            while seg + 1 < slopes.len() && start > breakpoints[seg + 1] {
                seg += 1;
            }
            bin_segment.push(u16::try_from(seg).expect("at most 65535 segments"));
        }
        let mut segmentation = Self {
            params,
            offset,
            breakpoints,
            values,
            slopes,
            bin_segment,
            packed,
            step_targets_sq: Vec::new(),
            lookup_origin: origin,
            inv_bin_width,
        };
        segmentation.step_targets_sq = (0..segmentation.slopes.len())
            .map(|s| {
                let (below, above) = (
                    segmentation.midpoint_below(s),
                    segmentation.midpoint_above(s),
                );
                [below * below, above * above]
            })
            .collect();
        segmentation
    }

    /// The potential's parameters.
    pub fn params(&self) -> &VinParams {
        &self.params
    }

    /// Number of segments Ω.
    pub fn segment_count(&self) -> usize {
        self.slopes.len()
    }

    /// Exact V_in(l) with the same offset as the segmentation (Ē).
    pub fn exact(&self, l: f64) -> f64 {
        self.params.raw(l) - self.offset
    }

    /// Exact V_in(l) with the segmentation's offset and its slope dV_in/dl
    /// (Ē, Ē/l̄), from one evaluation ([`VinParams::raw_and_derivative`]).
    #[inline]
    pub fn exact_and_slope(&self, l: f64) -> (f64, f64) {
        let (value, slope) = self.params.raw_and_derivative(l);
        (value - self.offset, slope)
    }

    /// Segment containing `l`; lengths outside the sampled range map to the
    /// first or last segment (whose chord is extrapolated).
    #[inline(always)]
    pub fn segment_of(&self, l: f64) -> usize {
        let x = (l - self.lookup_origin) * self.inv_bin_width;
        if x.is_nan() || x <= 0.0 {
            return 0;
        }
        // Truncation = floor for x > 0 (f64::floor is a libm call on the
        // baseline x86-64 target); the corrections below settle which side
        // of a breakpoint l lies on, so round-off in x does not matter.
        let j = (x as usize).min(self.bin_segment.len() - 1);
        let s = self.bin_segment[j] as usize;
        // Segment s is (b_s, b_{s+1}]; at most one of the two corrections
        // applies. Branch-free: which side of a breakpoint an edge lies on is
        // unpredictable.
        let b = &self.breakpoints;
        let up = (s + 1 < self.slopes.len()) & (l > b[s + 1]);
        let down = (s > 0) & (l <= b[s]);
        s + usize::from(up) - usize::from(down)
    }

    /// Squared length an edge in segment `s` may reach in one step:
    /// midpoint_above(s)² if it extends, midpoint_below(s)² if it shrinks
    /// (l̄²; precomputed for the time-step loops).
    #[inline(always)]
    pub fn step_target_sq(&self, s: usize, extends: bool) -> f64 {
        self.step_targets_sq[s][usize::from(extends)]
    }

    /// Midpoint of segment `s` (l̄).
    #[inline]
    pub fn midpoint(&self, s: usize) -> f64 {
        0.5 * (self.breakpoints[s] + self.breakpoints[s + 1])
    }

    /// Where an edge in segment `s` may extend to in one step: the midpoint
    /// of segment s+1 (past the last segment: half its width beyond the end).
    #[inline]
    pub fn midpoint_above(&self, s: usize) -> f64 {
        let last = self.slopes.len() - 1;
        if s < last {
            self.midpoint(s + 1)
        } else {
            let b = &self.breakpoints;
            b[last + 1] + 0.5 * (b[last + 1] - b[last])
        }
    }

    /// Where an edge in segment `s` may shrink to in one step: the midpoint of
    /// segment s−1 (below the first segment: half its width before it, ≥ 0).
    #[inline]
    pub fn midpoint_below(&self, s: usize) -> f64 {
        if s > 0 {
            self.midpoint(s - 1)
        } else {
            let b = &self.breakpoints;
            (b[0] - 0.5 * (b[1] - b[0])).max(0.0)
        }
    }

    /// Piecewise-linear V_in(l) and its slope dV/dl (Ē, Ē/l̄).
    #[inline(always)]
    pub fn linear(&self, l: f64) -> (f64, f64) {
        self.linear_in(self.segment_of(l), l)
    }

    /// [`Segmentation::linear`] for an `l` already known to lie in segment
    /// `s` (from [`Segmentation::segment_of`]).
    #[inline(always)]
    pub fn linear_in(&self, s: usize, l: f64) -> (f64, f64) {
        let [start, value, slope] = self.packed[s];
        (value + slope * (l - start), slope)
    }
}

pub use crate::energy::vin_edge_samples::{EdgeSample, VinEdgeSamples};

fn needs_split(y: &[f64], a: usize, b: usize, p: &VinParams, l_at: impl Fn(usize) -> f64) -> bool {
    let n = (b - a + 1) as f64;
    let (mut sx, mut sy) = (0.0, 0.0);
    for k in a..=b {
        sx += l_at(k);
        sy += y[k];
    }
    let (mx, my) = (sx / n, sy / n);
    let (mut sxx, mut sxy, mut syy) = (0.0, 0.0, 0.0);
    for k in a..=b {
        let (dx, dy) = (l_at(k) - mx, y[k] - my);
        sxx += dx * dx;
        sxy += dx * dy;
        syy += dy * dy;
    }
    let std = (syy / (n - 1.0)).sqrt();
    // R² = 1 − SS_res/SS_tot = sxy²/(sxx·syy); undefined (never split) when flat.
    let r2 = if syy > 0.0 {
        sxy * sxy / (sxx * syy)
    } else {
        f64::NAN
    };
    r2 < p.segment_r2_min || std > p.segment_std_max
}

impl crate::util::validate::Validate for VinParams {
    fn validate(&self) -> Result<(), crate::util::validate::ValidationError> {
        self.check().map_err(
            |(field, reason)| crate::util::validate::ValidationError::Field { field, reason },
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The fused evaluation equals the separate ones to round-off over the
    /// whole range between the walls.
    #[test]
    fn value_and_slope_together_equal_the_separate_evaluations() {
        let p = VinParams::default();
        let n = 20000;
        for i in 1..n {
            let l = p.l_min + (p.l_max - p.l_min) * i as f64 / n as f64;
            let (value, slope) = p.raw_and_derivative(l);
            let (v, d) = (p.raw(l), p.derivative(l));
            assert!(
                (value - v).abs() <= 1e-13 * v.abs(),
                "V at {l}: {value} vs {v}"
            );
            // Where the terms of V' (each up to V0·k·b = 5 Ē/l̄) cancel, the
            // round-off is relative to them, not to their sum.
            assert!(
                (slope - d).abs() <= 1e-12 * d.abs().max(1.0),
                "V' at {l}: {slope} vs {d}"
            );
        }
    }
}

/// The V_in segmentation shared by the V_in force, the time-step
/// controller and remeshing (inserted by the Vin plugin).
#[derive(Clone, Debug)]
pub struct VinSegmentation(pub Arc<Segmentation>);

/// The V_in force term.
pub struct VinForces {
    segmentation: Arc<Segmentation>,
    form: VinForm,
    scratch: EdgeScratch,
}

impl VinForces {
    /// A V_in system evaluating `form` on a shared segmentation.
    pub fn new(segmentation: Arc<Segmentation>, form: VinForm) -> Self {
        Self {
            segmentation,
            form,
            scratch: EdgeScratch::default(),
        }
    }

    /// The segmentation this system uses.
    pub fn segmentation(&self) -> &Arc<Segmentation> {
        &self.segmentation
    }
}

/// Σ V(l_e) over edges, adding the edge forces when `force` is given.
/// `sample(e)` gives edge e's vector, length and segment; `v(s, l)` its
/// V_in value and slope.
///
/// One thread; where the vertices split, [`edge_gather`] gives the same bits
/// in parallel.
#[inline(always)]
fn edge_loop(
    edges: &[[u32; 2]],
    sample: impl Fn(usize) -> (DVec3, f64, usize),
    mut force: Option<&mut [DVec3]>,
    v: impl Fn(usize, f64) -> (f64, f64),
) -> f64 {
    let mut energy = 0.0;
    for (e, &[a, b]) in edges.iter().enumerate() {
        let (a, b) = (a as usize, b as usize);
        let (d, l, s) = sample(e);
        let (value, slope) = v(s, l);
        energy += value;
        if let Some(force) = force.as_deref_mut() {
            let f = d * (slope / l);
            force[a] += f;
            force[b] -= f;
        }
    }
    energy
}

/// [`edge_loop`] with the force, as a gather: every edge's value and force
/// on its first end in parallel (one buffer, 32 bytes an edge), then each
/// vertex adds its edges' forces in ascending edge order
/// ([`crate::util::parallel::Incidence`]; `+=` at end a, `-=` at end b:
/// the additions the loop makes into it, in its order) while the values
/// are summed in edge order on another thread. The same bits as
/// [`edge_loop`] on any thread count.
#[inline(always)]
fn edge_gather(
    incidence: &crate::util::parallel::Incidence,
    edges: usize,
    scratch: &mut EdgeScratch,
    sample: impl Fn(usize) -> (DVec3, f64, usize) + Sync + Send,
    force: &mut [DVec3],
    v: impl Fn(usize, f64) -> (f64, f64) + Sync + Send,
) -> f64 {
    use crate::util::parallel::{fill_vec, for_chunks};
    fill_vec(&mut scratch.edges, edges, |e| {
        let (d, l, s) = sample(e);
        let (value, slope) = v(s, l);
        (value, d * (slope / l))
    });
    let per_edge = &scratch.edges;
    let (energy, ()) = rayon::join(
        || {
            let mut energy = 0.0;
            for (value, _) in per_edge {
                energy += value;
            }
            energy
        },
        || {
            for_chunks(force, |start, chunk| {
                for (j, o) in chunk.iter_mut().enumerate() {
                    for &e in incidence.of(start + j) {
                        let f = per_edge[(e >> 2) as usize].1;
                        // End a adds f, end b subtracts it.
                        if e & 3 == 0 {
                            *o += f;
                        } else {
                            *o -= f;
                        }
                    }
                }
            })
        },
    );
    energy
}

/// Per-edge buffers of [`edge_gather`].
#[derive(Default)]
struct EdgeScratch {
    /// Each edge's V_in value and force on its first end.
    edges: Vec<(f64, DVec3)>,
}

impl VinForces {
    fn run(&mut self, ctx: &ForceContext<'_>, mut force: Option<&mut [DVec3]>) -> f64 {
        let (edges, p, seg) = (&ctx.topology.edges, ctx.positions, &*self.segmentation);
        let linear = |s: usize, l: f64| seg.linear_in(s, l);
        let exact = |_: usize, l: f64| seg.exact_and_slope(l);
        // The tick's edge samples when the Gather stage measured them (the
        // same vectors, lengths and segments this would compute).
        let samples = ctx.inputs.get::<VinEdgeSamples>().map_or(&[][..], |s| &s.0);
        let measured = |e: usize| {
            let [a, b] = edges[e].map(|i| i as usize);
            let d = p[b] - p[a];
            let l = d.length();
            (d, l, seg.segment_of(l))
        };
        let sampled = |e: usize| {
            let s = samples[e];
            (s.d, s.length, s.segment as usize)
        };
        let have_samples = samples.len() == edges.len();
        // Where the vertices split, the force as a gather (see the
        // bending's evaluation for why not from fewer).
        if crate::util::parallel::splits(ctx.topology.vertex_count())
            && let Some(force) = force.as_deref_mut()
        {
            let incidence = ctx.topology.edge_incidence();
            let (i, n, s) = (&*incidence, edges.len(), &mut self.scratch);
            return match (self.form, have_samples) {
                (VinForm::PiecewiseLinear, true) => edge_gather(i, n, s, sampled, force, linear),
                (VinForm::Exact, true) => edge_gather(i, n, s, sampled, force, exact),
                (VinForm::PiecewiseLinear, false) => edge_gather(i, n, s, measured, force, linear),
                (VinForm::Exact, false) => edge_gather(i, n, s, measured, force, exact),
            };
        }
        match (self.form, have_samples) {
            (VinForm::PiecewiseLinear, true) => edge_loop(edges, sampled, force, linear),
            (VinForm::Exact, true) => edge_loop(edges, sampled, force, exact),
            (VinForm::PiecewiseLinear, false) => edge_loop(edges, measured, force, linear),
            (VinForm::Exact, false) => edge_loop(edges, measured, force, exact),
        }
    }
}

impl ForceTerm for VinForces {
    fn name(&self) -> &str {
        "vin"
    }

    fn kind(&self) -> ForceKind {
        ForceKind::Maintenance
    }

    fn evaluate(&mut self, ctx: &ForceContext<'_>, force: Option<&mut [DVec3]>) -> f64 {
        self.run(ctx, force)
    }

    /// V of the new edge c–d less V of the old edge a–b, in the form the
    /// force uses.
    fn flip_energy_change(&mut self, proposal: &FlipProposal<'_>) -> Option<f64> {
        let (p, flip) = (proposal.before.positions, &proposal.flip);
        let v = |l: f64| match self.form {
            VinForm::PiecewiseLinear => self.segmentation.linear(l).0,
            VinForm::Exact => self.segmentation.exact(l),
        };
        let ab = p[flip.a as usize].distance(p[flip.b as usize]);
        let cd = p[flip.c as usize].distance(p[flip.d as usize]);
        Some(v(cd) - v(ab))
    }
}

/// The double-barrier edge potential V_in: inserts its segmentation (used by
/// the time step and remeshing), the per-tick edge samples and the Gather
/// system that measures them ([`VinEdgeSampling`]), and, with
/// `exerts_force`, its force term. The geometric remeshing baseline uses
/// V_in without its global force.
pub fn plugin(params: VinParams, exerts_force: bool) -> impl Plugin {
    move |b: &mut SimBuilder| {
        let segmentation = Arc::new(Segmentation::new(params));
        b.insert_resource(VinSegmentation(segmentation.clone()))
            .publish_term_input(VinEdgeSamples::default());
        b.add_system(Stage::Gather, VinEdgeSampling)
            .after("gather_state");
        if exerts_force {
            b.add_force_term(VinForces::new(segmentation, params.form))?;
        }
        Ok(())
    }
}

impl crate::energy::builtin::BuiltinTerm for VinParams {
    /// Correct on open meshes: one potential per edge: a boundary edge is an edge.
    const CORRECT_ON_OPEN_MESHES: bool = true;

    /// V_in exerts its force except in the geometric remeshing baseline,
    /// where it sets Δt and drives the local relaxation only.
    fn plugin(&self, context: crate::energy::builtin::TermContext) -> impl Plugin {
        plugin(
            *self,
            context.remesh_mode != crate::params::RemeshMode::Geometric,
        )
    }

    fn at_resolution(&mut self, h: f64) {
        self.l_min *= h;
        self.l_max *= h;
        self.dl *= h;
        self.near_barrier = (self.near_barrier.0 * h, self.near_barrier.1 * h);
        self.far_barrier = (self.far_barrier.0 * h, self.far_barrier.1 * h);
        self.near_steepness = (self.near_steepness.0 / h, self.near_steepness.1 / h);
        self.far_steepness = (self.far_steepness.0 / h, self.far_steepness.1 / h);
        self.wall_steepness /= h;
    }

    /// Its barriers trigger remeshing.
    fn needs(&self) -> crate::energy::builtin::TermNeeds {
        crate::energy::builtin::TermNeeds {
            triggers_remeshing: true,
            ..Default::default()
        }
    }
}

/// The edge-sampling system: every edge's [`VinEdgeSamples`] entry, once
/// per tick.
///
/// Stage: Gather (after `gather_state`). Reads: [`Membrane`] (edges),
/// [`DensePositions`], [`VinSegmentation`]. Writes: the
/// [`VinEdgeSamples`] in [`TermInputs`].
pub struct VinEdgeSampling;

/// Its name.
pub const VIN_EDGE_SAMPLES: &str = "vin_edge_samples";

impl System for VinEdgeSampling {
    type Data<'a> = (
        Res<'a, Membrane>,
        Res<'a, DensePositions>,
        Res<'a, VinSegmentation>,
        ResMut<'a, TermInputs>,
    );

    fn name(&self) -> &str {
        VIN_EDGE_SAMPLES
    }

    fn run(
        &mut self,
        (membrane, positions, segmentation, mut inputs): Self::Data<'_>,
    ) -> Result<(), SimError> {
        let (edges, segmentation) = (&membrane.cached_topology().edges, &segmentation.0);
        // The plugin published them; were they taken away, the force and
        // the time step would measure the edges themselves.
        if let Some(samples) = inputs.get_mut::<VinEdgeSamples>() {
            samples.measure(edges, &positions.0, |l| segmentation.segment_of(l));
        }
        Ok(())
    }
}
