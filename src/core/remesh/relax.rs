//! Local relaxation of a remeshing patch (SPEC §4, reference §5) and the
//! stable (α = 1, β = 1) Lévy kicks that drive it.
//!
//! Only the patch's moveable vertices move; its boundary is fixed. Forces
//! are the V_in chord slopes of the patch edges plus, on every patch edge
//! outside the normal range, a kick ±D·R along the edge (R ~ S(1, 1), short
//! edges pushed longer, long edges shorter); the target edge is kicked
//! toward its goal until it reaches it. Steps use the same segment rule as
//! the global time step, so no edge crosses more than one V_in segment.

use crate::energy::vin::Segmentation;
use crate::mesh::topology::Topology;
use crate::timestep::edge_time_step_in;
use glam::DVec3;
use rand::RngExt;
use std::f64::consts::FRAC_PI_2;

/// One draw of the stable law with α = 1, β = 1 (scale 1, location 0, the
/// S1 parametrisation of Samorodnitsky & Taqqu, as Matlab's
/// `random('Stable', 1, 1, 1, 0)`), by Chambers–Mallows–Stuck:
/// X = (2/π)[(π/2 + U) tan U − ln((π/2) W cos U / (π/2 + U))],
/// U ~ Uniform(−π/2, π/2), W ~ Exp(1).
pub fn stable_alpha1_beta1(rng: &mut impl RngExt) -> f64 {
    let u = (rng.random::<f64>() - 0.5) * std::f64::consts::PI;
    let w = -(1.0 - rng.random::<f64>()).ln();
    let a = FRAC_PI_2 + u;
    (a * u.tan() - (FRAC_PI_2 * w * u.cos() / a).ln()) / FRAC_PI_2
}

/// Goal of the target edge during a relaxation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Goal {
    /// Extend the target past this length (split pre-relaxation).
    Extend(f64),
    /// Compress the target below this length (merge pre-relaxation).
    Compress(f64),
    /// Bring every patch edge (including the target) into the normal range.
    Normalize,
}

/// How a relaxation ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RelaxOutcome {
    /// The goal was reached with every other patch edge in the normal range.
    Success,
    /// The target returned to the normal range with the others in range.
    Cancel,
    /// The iteration cap was reached.
    Failure,
}

/// A patch in local indices: moveable vertices first, then fixed ones.
#[derive(Clone, Debug, Default)]
pub struct Patch {
    /// Positions (l̄), moveable first.
    pub positions: Vec<DVec3>,
    /// Number of moveable vertices (the first `moveable` positions).
    pub moveable: usize,
    /// Edges as local index pairs.
    pub edges: Vec<[usize; 2]>,
    /// Index of the target edge in `edges`, if any.
    pub target: Option<usize>,
    /// Unit normals of the moveable vertices, frozen when the patch was
    /// taken; when given (the fluid model), every force on them loses its
    /// normal component, so the relaxation slides vertices within the
    /// surface instead of moving it. Empty: forces act in full.
    pub normals: Vec<DVec3>,
    /// The moveable boundary vertices of an open membrane when the normals
    /// are frozen (local index, unit boundary tangent): they slide along
    /// their boundary line only (their entry in `normals` is zero).
    pub lines: Vec<(usize, DVec3)>,
}

impl Patch {
    /// The patch of the `moveable` vertex slots of `topology`: the moveable
    /// vertices first, then their neighbours (fixed); every edge incident to
    /// a moveable vertex; `target` (a slot pair) marked if given. Returns the
    /// patch and the slot of each local vertex.
    pub fn around(
        topology: &Topology,
        positions: &[DVec3],
        moveable: &[u32],
        target: Option<[u32; 2]>,
    ) -> (Patch, Vec<u32>) {
        let mut slots: Vec<u32> = moveable.to_vec();
        for &v in moveable {
            for &w in topology.neighbours(v as usize) {
                if !slots.contains(&w) {
                    slots.push(w);
                }
            }
        }
        let local = |s: u32| slots.iter().position(|&x| x == s).expect("in patch");
        let mut edges: Vec<[usize; 2]> = Vec::new();
        let mut target_index = None;
        for &v in moveable {
            for &w in topology.neighbours(v as usize) {
                let e = [local(v), local(w)];
                if edges.iter().any(|x| *x == e || *x == [e[1], e[0]]) {
                    continue;
                }
                if target.is_some_and(|[a, b]| (v, w) == (a, b) || (v, w) == (b, a)) {
                    target_index = Some(edges.len());
                }
                edges.push(e);
            }
        }
        let positions = slots.iter().map(|&s| positions[s as usize]).collect();
        (
            Patch {
                positions,
                moveable: moveable.len(),
                edges,
                target: target_index,
                normals: Vec::new(),
                lines: Vec::new(),
            },
            slots,
        )
    }

    /// Freezes the area-weighted normals of the moveable vertices (slots
    /// `slots[..moveable]` of `topology` at `positions`), so that the
    /// relaxation moves them only tangentially.
    /// A moveable boundary vertex slides along its boundary line instead
    /// (see [`crate::fluid::boundary_tangents`]).
    pub fn freeze_normals(&mut self, topology: &Topology, positions: &[DVec3], slots: &[u32]) {
        self.lines.clear();
        self.normals = slots[..self.moveable]
            .iter()
            .enumerate()
            .map(|(k, &s)| {
                let s = s as usize;
                if !topology.is_boundary_vertex(s) {
                    return crate::fluid::vertex_normal(positions, topology, s);
                }
                let t = crate::fluid::boundary_tangent(positions, topology, s);
                self.lines.push((k, t));
                DVec3::ZERO
            })
            .collect();
    }
}

/// `seeds` and every vertex within `depth` rings of them (slots).
pub fn rings(topology: &Topology, seeds: &[u32], depth: usize) -> Vec<u32> {
    let mut out: Vec<u32> = seeds.to_vec();
    let mut frontier = out.clone();
    for _ in 0..depth {
        let mut next = Vec::new();
        for &v in &frontier {
            for &w in topology.neighbours(v as usize) {
                if !out.contains(&w) {
                    out.push(w);
                    next.push(w);
                }
            }
        }
        frontier = next;
    }
    out
}

/// Relaxation settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RelaxSettings {
    /// Normal range of the non-target edges (l̄; as run [0.8, 1.2]).
    pub normal: (f64, f64),
    /// Kick scale D (Ē/l̄; as run 10).
    pub kick_scale: f64,
    /// Mobility (cancels out of the displacement; l̄²/(Ē s)).
    pub mobility: f64,
    /// Iteration cap.
    pub max_iterations: u32,
}

/// A table of pre-sampled stable (α = 1, β = 1) draws, indexed uniformly at
/// random, as the reference code does (it draws from 10000 pre-sampled
/// numbers). Keeps the transcendental functions of the sampler out of the
/// relaxation loop. 2^14 draws (128 KiB, cache-resident) reach the ~10^4
/// tail; any larger kick would still move an edge by only one V_in segment
/// per step.
#[derive(Clone, Debug)]
pub struct KickTable {
    draws: Vec<f64>,
}

impl KickTable {
    /// Table size (a power of two, so an index is a mask of a random word).
    pub const SIZE: usize = 1 << 14;

    /// Samples the table from `rng`.
    pub fn new(rng: &mut impl RngExt) -> Self {
        Self {
            draws: (0..Self::SIZE).map(|_| stable_alpha1_beta1(rng)).collect(),
        }
    }

    /// The pre-sampled draws.
    pub fn draws(&self) -> &[f64] {
        &self.draws
    }

    /// One draw, picked uniformly from the table.
    #[inline(always)]
    pub fn draw(&self, rng: &mut impl RngExt) -> f64 {
        self.draws[(rng.random::<u64>() as usize) & (Self::SIZE - 1)]
    }
}

/// The result of a relaxation.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Relaxed {
    /// How it ended.
    pub outcome: RelaxOutcome,
    /// Iterations used (at most the cap).
    pub iterations: u32,
}

/// Per patch edge and iteration: the edge vector, its length, 1/length and
/// V_in segment.
#[derive(Clone, Copy, Default)]
struct EdgeState {
    d: DVec3,
    l: f64,
    inv_l: f64,
    s: usize,
}

/// What drives a relaxation besides the patch: the goal, V_in's segments,
/// the settings and the kicks.
struct Drive<'a> {
    goal: Goal,
    seg: &'a Segmentation,
    settings: &'a RelaxSettings,
    kicks: &'a KickTable,
    /// The index of the target edge, or `usize::MAX` without one.
    target: usize,
    /// The last V_in segment.
    last_segment: usize,
}

impl Drive<'_> {
    /// The target's kick direction while it has not reached its goal (with
    /// `Normalize`, while it is outside the normal range).
    #[inline]
    fn target_kick(&self, l: f64) -> Option<f64> {
        let (lo, hi) = self.settings.normal;
        match self.goal {
            Goal::Extend(past) if l <= past => Some(1.0),
            Goal::Compress(below) if l >= below => Some(-1.0),
            Goal::Extend(_) | Goal::Compress(_) => None,
            Goal::Normalize => {
                if l < lo {
                    Some(1.0)
                } else if l > hi {
                    Some(-1.0)
                } else {
                    None
                }
            }
        }
    }

    /// The kick direction of patch edge `k` of length `l`: the target's
    /// toward its goal, another's back into the normal range.
    #[inline]
    fn kick(&self, k: usize, l: f64) -> Option<f64> {
        let (lo, hi) = self.settings.normal;
        if k == self.target {
            self.target_kick(l)
        } else if l < lo {
            Some(1.0)
        } else if l > hi {
            Some(-1.0)
        } else {
            None
        }
    }

    /// Measures the patch edges into `geometry`. Returns how many edges
    /// other than the target are outside the normal range, or `None` if an
    /// edge lies next to a wall of V_in.
    fn measure_edges(&self, patch: &Patch, geometry: &mut [EdgeState]) -> Option<usize> {
        let (lo, hi) = self.settings.normal;
        let mut near_wall = false;
        let mut others_abnormal = 0usize;
        for (k, (g, &[a, b])) in geometry.iter_mut().zip(&patch.edges).enumerate() {
            let d = patch.positions[b] - patch.positions[a];
            let l = d.length();
            let s = self.seg.segment_of(l);
            near_wall |= s < 2 || s + 2 > self.last_segment;
            others_abnormal += usize::from(k != self.target && !(lo..=hi).contains(&l));
            *g = EdgeState {
                d,
                l,
                inv_l: 1.0 / l,
                s,
            };
        }
        (!near_wall).then_some(others_abnormal)
    }

    /// How the relaxation ends now that every edge but the target is in
    /// the normal range, given the target's length (`None`: no target), or
    /// `None` if it goes on.
    fn outcome(&self, target_length: Option<f64>) -> Option<RelaxOutcome> {
        let (lo, hi) = self.settings.normal;
        match (target_length, self.goal) {
            (None, _) => Some(RelaxOutcome::Success),
            (Some(l), Goal::Extend(past)) if l > past => Some(RelaxOutcome::Success),
            (Some(l), Goal::Compress(below)) if l < below => Some(RelaxOutcome::Success),
            (Some(l), Goal::Extend(_) | Goal::Compress(_)) if l > lo && l < hi => {
                Some(RelaxOutcome::Cancel)
            }
            (Some(l), Goal::Normalize) if (lo..=hi).contains(&l) => Some(RelaxOutcome::Success),
            _ => None,
        }
    }

    /// The forces on the patch vertices into `force`: V_in chords plus
    /// kicks, on the moveable vertices only (tangential if the patch has
    /// frozen normals).
    fn forces(
        &self,
        patch: &Patch,
        geometry: &[EdgeState],
        force: &mut [DVec3],
        rng: &mut impl RngExt,
    ) {
        force.iter_mut().for_each(|f| *f = DVec3::ZERO);
        for (k, (&[a, b], g)) in patch.edges.iter().zip(geometry).enumerate() {
            let mut magnitude = -self.seg.slopes[g.s]; // > 0 pushes the ends apart
            if let Some(sign) = self.kick(k, g.l) {
                magnitude += sign * self.settings.kick_scale * self.kicks.draw(rng);
            }
            let f = g.d * (magnitude * g.inv_l);
            force[b] += f;
            force[a] -= f;
        }
        for f in &mut force[patch.moveable..] {
            *f = DVec3::ZERO;
        }
        for (f, n) in force.iter_mut().zip(&patch.normals) {
            *f -= f.dot(*n) * *n;
        }
        for &(k, t) in &patch.lines {
            force[k] = crate::fluid::along_boundary(force[k], t);
        }
    }

    /// The largest time step under `force` that moves no edge across more
    /// than one V_in segment (infinite without force).
    fn time_step(&self, patch: &Patch, geometry: &[EdgeState], force: &[DVec3]) -> f64 {
        let mu = self.settings.mobility;
        let mut dt = f64::INFINITY;
        for (&[a, b], g) in patch.edges.iter().zip(geometry) {
            let rate = 2.0 * mu * g.d.dot(force[b] - force[a]);
            dt = dt.min(edge_time_step_in(self.seg, g.s, g.l, rate));
        }
        dt
    }
}

/// Relaxes `patch` toward `goal` with kicks drawn from `kicks`. Positions
/// are updated in place.
pub fn relax(
    patch: &mut Patch,
    goal: Goal,
    seg: &Segmentation,
    settings: &RelaxSettings,
    kicks: &KickTable,
    rng: &mut impl RngExt,
) -> Relaxed {
    let n = patch.positions.len();
    let moveable = patch.moveable;
    let mut force = vec![DVec3::ZERO; n];
    let mut geometry = vec![EdgeState::default(); patch.edges.len()];
    let start = patch.positions.clone();
    let drive = Drive {
        goal,
        seg,
        settings,
        kicks,
        last_segment: seg.segment_count() - 1,
        target: patch.target.unwrap_or(usize::MAX),
    };
    for iteration in 0..settings.max_iterations {
        let Some(others_abnormal) = drive.measure_edges(patch, &mut geometry) else {
            // An edge drifted next to a wall of V_in: start over (reference
            // "restored!!").
            patch.positions.copy_from_slice(&start);
            continue;
        };
        if others_abnormal == 0
            && let Some(outcome) = drive.outcome(patch.target.map(|t| geometry[t].l))
        {
            return Relaxed {
                outcome,
                iterations: iteration + 1,
            };
        }
        drive.forces(patch, &geometry, &mut force, rng);
        let dt = drive.time_step(patch, &geometry, &force);
        if !dt.is_finite() {
            continue; // no force this iteration: draw new kicks
        }
        let step = settings.mobility * dt;
        for (p, f) in patch.positions[..moveable].iter_mut().zip(&force) {
            *p += step * *f;
        }
    }
    Relaxed {
        outcome: RelaxOutcome::Failure,
        iterations: settings.max_iterations,
    }
}
