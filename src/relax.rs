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
use crate::timestep::edge_time_step_in;
use crate::topology::Topology;
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
            },
            slots,
        )
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

/// Relaxes `patch` toward `goal`. Positions are updated in place.
pub fn relax(
    patch: &mut Patch,
    goal: Goal,
    seg: &Segmentation,
    settings: &RelaxSettings,
    rng: &mut impl RngExt,
) -> RelaxOutcome {
    let (lo, hi) = settings.normal;
    let n = patch.positions.len();
    let mut force = vec![DVec3::ZERO; n];
    // Per edge and iteration: vector, length and V_in segment, computed once.
    let mut geometry: Vec<(DVec3, f64, usize)> = vec![(DVec3::ZERO, 0.0, 0); patch.edges.len()];
    let start = patch.positions.clone();
    let last_segment = seg.segment_count() - 1;
    for _ in 0..settings.max_iterations {
        let mut near_wall = false;
        for (g, &[a, b]) in geometry.iter_mut().zip(&patch.edges) {
            let d = patch.positions[b] - patch.positions[a];
            let l = d.length();
            let s = seg.segment_of(l);
            near_wall |= s < 2 || s + 2 > last_segment;
            *g = (d, l, s);
        }
        if near_wall {
            // An edge drifted next to a wall of V_in: start over (reference
            // "restored!!").
            patch.positions.copy_from_slice(&start);
            continue;
        }
        // Outcome checks.
        let others_normal = geometry
            .iter()
            .enumerate()
            .filter(|(k, _)| Some(*k) != patch.target)
            .all(|(_, g)| (lo..=hi).contains(&g.1));
        if let Some(t) = patch.target {
            let l = geometry[t].1;
            match goal {
                Goal::Extend(past) if others_normal && l > past => return RelaxOutcome::Success,
                Goal::Compress(below) if others_normal && l < below => {
                    return RelaxOutcome::Success;
                }
                Goal::Extend(_) | Goal::Compress(_) if others_normal && l > lo && l < hi => {
                    return RelaxOutcome::Cancel;
                }
                Goal::Normalize if others_normal && (lo..=hi).contains(&l) => {
                    return RelaxOutcome::Success;
                }
                _ => {}
            }
        } else if others_normal {
            return RelaxOutcome::Success;
        }
        // Forces: V_in chords plus kicks.
        force.iter_mut().for_each(|f| *f = DVec3::ZERO);
        for (k, (&[a, b], &(d, l, s))) in patch.edges.iter().zip(&geometry).enumerate() {
            let mut magnitude = -seg.slopes[s]; // > 0 pushes the ends apart
            let is_target = Some(k) == patch.target;
            let kick = match (is_target, goal) {
                (true, Goal::Extend(past)) if l <= past => Some(1.0),
                (true, Goal::Compress(below)) if l >= below => Some(-1.0),
                (true, Goal::Extend(_) | Goal::Compress(_)) => None,
                _ if l < lo => Some(1.0),
                _ if l > hi => Some(-1.0),
                _ => None,
            };
            if let Some(sign) = kick {
                magnitude += sign * settings.kick_scale * stable_alpha1_beta1(rng);
            }
            let f = d * (magnitude / l);
            force[b] += f;
            force[a] -= f;
        }
        for f in &mut force[patch.moveable..] {
            *f = DVec3::ZERO;
        }
        let mu = settings.mobility;
        let mut dt = f64::INFINITY;
        for (&[a, b], &(d, l, s)) in patch.edges.iter().zip(&geometry) {
            let rate = 2.0 * mu * d.dot(force[b] - force[a]);
            dt = dt.min(edge_time_step_in(seg, s, l, rate));
        }
        if !dt.is_finite() {
            continue; // no force this iteration: draw new kicks
        }
        for (p, f) in patch.positions[..patch.moveable].iter_mut().zip(&force) {
            *p += mu * dt * *f;
        }
    }
    RelaxOutcome::Failure
}
