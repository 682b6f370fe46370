//! Remeshing: Metropolis edge flips and split/merge events.

use super::*;

/// Edge flips as Metropolis moves ([`crate::remesh::flip`]): after every tick,
/// edges drawn at random are flipped with probability min(1, exp(−ΔE/k_BT)),
/// so the triangulation is fluid and the membrane samples the Boltzmann
/// ensemble of its energy (at k_BT = 0 only flips that lower the energy are
/// taken).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EdgeFlipParams {
    /// Flip proposals per edge per tick (dimensionless, e.g. 0.01: each edge
    /// is proposed once every 100 ticks on average). Any rate keeps the
    /// ensemble; it sets how fast the triangulation (the membrane's
    /// in-plane structure) relaxes, and costs about 1 µs per proposal.
    #[serde(deserialize_with = "crate::util::validate::positive")]
    pub attempts_per_edge: f64,
    /// Both the edge removed and the edge created must lie in this range
    /// (l̄; default (0.7, 1.3), the remesh triggers' normal range). V_in has
    /// a second well beyond its far barrier (1.75-2.2 l̄, as low as the
    /// normal one), so without this bound a flip could create an edge there,
    /// between two of V_in's steepest walls. Required both ways, so the
    /// reverse flip is allowed exactly when this one is.
    #[serde(default = "default_flip_range")]
    pub edge_range: (f64, f64),
}

pub(super) fn default_flip_range() -> (f64, f64) {
    (0.7, 1.3)
}

/// Which remeshing runs.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum RemeshMode {
    /// No remeshing: barrier crossings are only detected and counted.
    #[default]
    Off,
    /// The paper's free-energy-controlled split/merge (V_in acts globally).
    FreeEnergy,
    /// Geometry-based baseline: the same triggers and relaxation, but V_in
    /// exerts no force in the global dynamics (still sets Δt and relaxes).
    Geometric,
}

/// Barrier-crossing remeshing (SPEC §4). Defaults are the as-run values.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RemeshParams {
    /// Off (default), FreeEnergy or Geometric.
    pub mode: RemeshMode,
    /// l_−: an edge shorter than this crossed the near barrier (l̄; default 0.7;
    /// 0.6 in the fluid model with direct edits).
    #[serde(deserialize_with = "crate::util::validate::positive")]
    pub shorter_than: f64,
    /// l_+: an edge longer than this crossed the far barrier (l̄; default 1.3;
    /// 1.4 in the fluid model with direct edits).
    #[serde(deserialize_with = "crate::util::validate::positive")]
    pub longer_than: f64,
    /// l_++: a split's pre-relaxation succeeds once the edge is longer (l̄;
    /// default 1.8 as run; paper 1.7).
    #[serde(deserialize_with = "crate::util::validate::positive")]
    pub split_done: f64,
    /// L_−: a merge's pre-relaxation succeeds once the edge is shorter (l̄;
    /// default 0.05 as run; paper 0.1).
    #[serde(deserialize_with = "crate::util::validate::positive")]
    pub merge_done: f64,
    /// Range the other patch edges must lie in during relaxation (l̄;
    /// default (0.8, 1.2) as run).
    pub normal_range: (f64, f64),
    /// D, scale of the Lévy kicks (Ē/l̄; default 10).
    #[serde(deserialize_with = "crate::util::validate::positive")]
    pub kick_scale: f64,
    /// Iteration cap of one local relaxation (default 5000, 300 in the fluid
    /// model with direct edits; in the
    /// filopodium scene successful pre-relaxations took a median of 725
    /// iterations, 99 % under 6500; a failed 1-ring relaxation is retried
    /// once with a 2-ring patch).
    pub relax_iterations: u32,
    /// Most remesh events per tick; abnormal edges left over are counted as
    /// an overflow and retried next tick (default 64).
    pub max_events_per_tick: u32,
}

impl RemeshParams {
    /// The keys whose defaults differ in the fluid model with direct edits,
    /// and their values there: triggers 0.6 and 1.4 l̄ (a split's halves
    /// stay above l_−, so they are never merged again), and local
    /// relaxations of at most 300 iterations (V_in's tangential forces go
    /// on regularising the mesh in the global dynamics; a post-relaxation
    /// that cannot reach the normal range otherwise ran to its cap of 5000
    /// after most events: 540 000 of them in 120 events on the prolate red
    /// blood cell, 57 % of its wall time, against 12 % with 300).
    pub const FLUID_DEFAULTS: [(&'static str, f64); 3] = [
        ("shorter_than", 0.6),
        ("longer_than", 1.4),
        ("relax_iterations", 300.0),
    ];

    /// Sets each key of [`FLUID_DEFAULTS`](Self::FLUID_DEFAULTS) for which
    /// `given(key)` is false to its fluid default.
    pub fn apply_fluid_defaults(&mut self, given: impl Fn(&str) -> bool) {
        for (key, value) in Self::FLUID_DEFAULTS {
            if given(key) {
                continue;
            }
            match key {
                "shorter_than" => self.shorter_than = value,
                "longer_than" => self.longer_than = value,
                "relax_iterations" => self.relax_iterations = value as u32,
                _ => unreachable!("every key is listed"),
            }
        }
    }
}

impl Default for RemeshParams {
    fn default() -> Self {
        Self {
            mode: RemeshMode::Off,
            shorter_than: 0.7,
            longer_than: 1.3,
            split_done: 1.8,
            merge_done: 0.05,
            normal_range: (0.8, 1.2),
            kick_scale: 10.0,
            relax_iterations: 5000,
            max_events_per_tick: 64,
        }
    }
}
