//! Lipid diffusion.

use super::*;

/// How fast lipid density equilibrates over edges.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum DiffusionRate {
    /// k_d per sweep (dimensionless fraction, 0 < k_d ≤ 1; paper 0.025-0.25).
    Finite(f64),
    /// k_d = ∞: uniform density Σρ / N after every remesh.
    Instant,
}

/// A region whose vertices block diffusion on their edges.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum BlockedRegion {
    /// The tether barrier: blocked where |x| < `half_width` and
    /// |y| / |r| > `gap` (r measured from the origin; 1.5 and 0.1 in the
    /// paper, leaving ≈ 6 % of the barrier permeable near y = 0).
    Slab {
        /// Half width of the slab around x = 0 (l̄).
        half_width: f64,
        /// Open gap: vertices with |y| ≤ gap·|r| stay permeable (0..1).
        gap: f64,
    },
}

/// Lipid diffusion (SPEC §5); needs `lipid_density: true`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DiffusionParams {
    /// k_d: Finite(k) or Instant.
    pub rate: DiffusionRate,
    /// n_d, synchronous sweeps after every tick whose remeshing was
    /// triggered (default 50).
    #[serde(default = "default_sweeps")]
    pub sweeps: u32,
    /// Regions whose vertices block diffusion (default none).
    #[serde(default)]
    pub barrier: Vec<BlockedRegion>,
}

pub(super) fn default_sweeps() -> u32 {
    50
}
