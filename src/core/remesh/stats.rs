//! What remeshing counts over a run: outcomes, relaxation iterations and
//! the events.

use super::*;

/// Counts of one operation's outcomes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct OutcomeCounts {
    /// Relaxed past the goal and re-triangulated.
    pub success: u64,
    /// The edge relaxed back into the normal range: restored, nothing changed.
    pub cancel: u64,
    /// Relaxed past the goal but no valid triangulation (or a degenerate
    /// neighbourhood): restored and pushed back into range.
    pub impossible: u64,
    /// The relaxation hit its iteration cap: restored.
    pub failure: u64,
}

/// Remeshing statistics of a run.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct RemeshStats {
    /// Split outcomes ([`RemeshStats::counts`] of [`EdgeOp::Split`]).
    pub split: OutcomeCounts,
    /// Merge outcomes ([`RemeshStats::counts`] of [`EdgeOp::Merge`]).
    pub merge: OutcomeCounts,
    /// Ticks that hit the per-tick event cap.
    pub overflow_ticks: u64,
    /// Ticks that ended with abnormal edges although every one was attempted.
    pub unresolved_ticks: u64,
    /// Abnormal edges left at the end of those ticks (summed).
    pub unresolved_edges: u64,
    /// Relaxation iterations spent, by phase.
    pub relax_iterations: RelaxIterations,
    /// Successful events.
    pub events: Vec<RemeshEvent>,
}

/// Relaxation iterations of a run by phase (where remeshing time goes).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct RelaxIterations {
    /// Pre-relaxations that reached their goal (including those whose
    /// edit then proved impossible).
    pub pre_success: u64,
    /// Pre-relaxations that ended in a cancel.
    pub pre_cancel: u64,
    /// Pre-relaxations that hit the iteration cap (1-ring and 2-ring).
    pub pre_failure: u64,
    /// Post-relaxations of new edges.
    pub post: u64,
    /// Push-backs of unsplittable/unmergeable edges.
    pub push_back: u64,
}

/// One successful split or merge.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct RemeshEvent {
    /// Iteration during which it happened.
    pub iteration: u64,
    /// The operation.
    pub op: EdgeOp,
    /// Midpoint of the edge (l̄).
    pub position: [f64; 3],
}

impl RemeshStats {
    /// The outcome counts of `op`.
    pub fn counts(&self, op: EdgeOp) -> &OutcomeCounts {
        match op {
            EdgeOp::Split => &self.split,
            EdgeOp::Merge => &self.merge,
        }
    }

    /// The outcome counts of `op`, mutably.
    pub fn counts_mut(&mut self, op: EdgeOp) -> &mut OutcomeCounts {
        match op {
            EdgeOp::Split => &mut self.split,
            EdgeOp::Merge => &mut self.merge,
        }
    }

    /// Successful events of every operation.
    pub fn successes(&self) -> u64 {
        EdgeOp::ALL.iter().map(|&op| self.counts(op).success).sum()
    }

    /// σ(|r|): standard deviation of the distance of the events from the
    /// origin (paper Fig 3D), or 0 without events.
    pub fn position_spread(&self) -> f64 {
        let r: Vec<f64> = self
            .events
            .iter()
            .map(|e| DVec3::from_array(e.position).length())
            .collect();
        if r.len() < 2 {
            return 0.0;
        }
        let mean = r.iter().sum::<f64>() / r.len() as f64;
        (r.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (r.len() - 1) as f64).sqrt()
    }
}

/// The values of every registered field at an edge's two ends, read before
/// the edit that changes them.
pub(super) struct EdgeValues(Vec<[f64; 2]>);

impl EdgeValues {
    /// Reads every field of `m` at `[i1, i2]`.
    pub(super) fn read(m: &Membrane, [i1, i2]: [Entity; 2]) -> Self {
        Self(
            m.fields()
                .iter()
                .map(|f| [f.get(&m.world, i1), f.get(&m.world, i2)])
                .collect(),
        )
    }

    /// Applies every field's split policy: (i1, i2) became (i1, n, i2).
    pub(super) fn apply_split(&self, m: &mut Membrane, [i1, i2]: [Entity; 2], n: Entity) {
        for (k, &[a, b]) in self.0.iter().enumerate() {
            let f = Arc::clone(&m.fields()[k]);
            match f.policy() {
                TransferPolicy::Conserve => {
                    f.set(&mut m.world, n, (a + b) / 3.0);
                    f.set(&mut m.world, i1, a * 2.0 / 3.0);
                    f.set(&mut m.world, i2, b * 2.0 / 3.0);
                }
                TransferPolicy::Interpolate => f.set(&mut m.world, n, 0.5 * (a + b)),
                // Set by the edit itself.
                TransferPolicy::Density => {}
            }
        }
    }

    /// Applies every field's merge policy: (i1, i2) became `survivor`.
    pub(super) fn apply_merge(&self, m: &mut Membrane, survivor: Entity) {
        for (k, &[a, b]) in self.0.iter().enumerate() {
            let f = Arc::clone(&m.fields()[k]);
            let value = match f.policy() {
                TransferPolicy::Conserve => a + b,
                TransferPolicy::Interpolate => 0.5 * (a + b),
                // Set by the edit itself.
                TransferPolicy::Density => continue,
            };
            f.set(&mut m.world, survivor, value);
        }
    }
}
