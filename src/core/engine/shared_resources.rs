//! What the built-in systems publish for each other and for the run's
//! reports: resources one system writes and others (or `summary.json`)
//! read. They live here, beside the engine, so that no system imports
//! another; each says who writes it and who reads it.

use crate::params::HeldDirections;
use glam::DVec3;

/// Edges (slots) outside [l_−, l_+] after the last integration (or, after
/// remeshing, those it left abnormal).
///
/// Written by `barrier_check` and `remesh`; read by `remesh` and the
/// state recorder.
#[derive(Clone, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct AbnormalEdges(pub Vec<u32>);

/// Whether this tick's remeshing was triggered (abnormal edges existed);
/// diffusion runs only after such ticks.
///
/// Written by `remesh`; read by `lipid_diffusion`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct RemeshTriggered(pub bool);

/// Unit area-weighted vertex normals, n_i ∝ Σ_{f∋i} A_f n̂_f ∝ ∇_i V, by
/// dense slot (inserted by the fluid plugin).
///
/// Written by `vertex_normals`; read by `fluid_projection` and the
/// summary's model report.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct VertexNormals(pub Vec<DVec3>);

/// The held vertices (entities and dense slots), their initial positions (l̄) and the
/// directions in which each is held.
///
/// Written by the boundary-conditions plugin and re-slotted by `remesh`;
/// read by `pin_forces`, `pin_positions`, `fluid_projection` and the
/// minimiser.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PinnedVertices {
    /// The held vertices' entities (kept through edits).
    pub entities: Vec<hecs::Entity>,
    /// Their dense slots, in the same order (a cache of `entities`).
    pub vertices: Vec<u32>,
    /// Their initial positions (l̄), in the same order.
    pub positions: Vec<DVec3>,
    /// The directions each is held in, in the same order.
    pub held: Vec<HeldDirections>,
}

/// Counts of flip proposals and their outcomes over a run.
///
/// Written by `edge_flips`; read by the minimiser (a flip restarts it)
/// and `summary.json` (`edge_flips`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct FlipStats {
    /// Flips proposed.
    pub proposed: u64,
    /// Flips taken.
    pub accepted: u64,
    /// Rejected: a valence would leave its range, c–d is already an edge,
    /// or the flip touches a control point's nearest vertex.
    pub rejected_topology: u64,
    /// Rejected: an edge outside `edge_range`, a fold, or faces the edit
    /// layer refused.
    pub rejected_geometry: u64,
    /// Rejected by the Metropolis rule.
    pub rejected_energy: u64,
}

/// Counts of the maintenance flips over a run (`summary.json`
/// `maintenance_flips`).
///
/// Written by `maintenance_flips`; read by the minimiser and
/// `summary.json`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct MaintenanceFlipStats {
    /// Sweeps over the edges.
    pub sweeps: u64,
    /// Edges found not locally Delaunay.
    pub non_delaunay: u64,
    /// Flips taken.
    pub flipped: u64,
    /// Left: a valence limit, or the new edge exists.
    pub kept_valence: u64,
    /// Left: the faces meet at more than `max_dihedral` from flat.
    pub kept_dihedral: u64,
    /// Left: the flip would fold the surface, or the edit layer refused it.
    pub kept_fold: u64,
}
