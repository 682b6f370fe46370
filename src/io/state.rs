//! Saved run states (`state.json`): the final mesh and per-vertex lipid
//! density of a completed run, from which another run can start (the next
//! phase of an experiment, e.g. the tether pull from the initial tethers).
//!
//! A scene starts from a state with `membrane: State(path: "...")` (relative
//! to the scene file) or `remembrane run SCENE --from STATE`. Only completed
//! runs write a state; a run that blew up leaves none.

use crate::mesh::SurfaceMesh;
use glam::DVec3;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// Format tag written into every state file.
pub const STATE_FORMAT: &str = "remembrane-state-1";

/// A saved state.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SavedState {
    /// Always [`STATE_FORMAT`].
    pub format: String,
    /// Name of the scene that wrote it.
    pub scene: String,
    /// Seed of the run that wrote it.
    pub seed: u64,
    /// Iterations the run had completed.
    pub iteration: u64,
    /// Simulated time the run had reached (s).
    pub time: f64,
    /// Vertex positions (l̄).
    pub positions: Vec<[f64; 3]>,
    /// Faces (vertex indices, outward by the right-hand rule).
    pub faces: Vec<[u32; 3]>,
    /// Lipid density per vertex, if the scene declared it.
    pub lipid_density: Option<Vec<f64>>,
}

/// Why a state file could not be used.
#[derive(Debug, thiserror::Error)]
#[error("{}: {reason}", path.display())]
pub struct StateError {
    /// The state file.
    pub path: PathBuf,
    /// What is wrong with it.
    pub reason: String,
}

impl SavedState {
    /// A state of `mesh` and `lipid` (empty = no lipid density).
    pub fn new(
        scene: &str,
        seed: u64,
        iteration: u64,
        time: f64,
        mesh: &SurfaceMesh,
        lipid: &[f64],
    ) -> Self {
        Self {
            format: STATE_FORMAT.into(),
            scene: scene.into(),
            seed,
            iteration,
            time,
            positions: mesh.positions.iter().map(|p| p.to_array()).collect(),
            faces: mesh.faces.clone(),
            lipid_density: (!lipid.is_empty()).then(|| lipid.to_vec()),
        }
    }

    /// Reads and checks a state file (format, sizes, finite values; the
    /// mesh itself is checked by the scene like any other mesh).
    pub fn read(path: &Path) -> Result<Self, StateError> {
        let err = |reason: String| StateError {
            path: path.to_owned(),
            reason,
        };
        let text = std::fs::read_to_string(path).map_err(|e| err(format!("cannot read: {e}")))?;
        let state: SavedState =
            serde_json::from_str(&text).map_err(|e| err(format!("not a state file: {e}")))?;
        if state.format != STATE_FORMAT {
            return Err(err(format!(
                "field `format`: expected \"{STATE_FORMAT}\", found \"{}\"",
                state.format
            )));
        }
        if let Some(k) = state
            .positions
            .iter()
            .position(|p| p.iter().any(|x| !x.is_finite()))
        {
            return Err(err(format!("field `positions`: vertex {k} is not finite")));
        }
        let n = state.positions.len();
        if let Some(f) = state
            .faces
            .iter()
            .position(|f| f.iter().any(|&v| v as usize >= n))
        {
            return Err(err(format!(
                "field `faces`: face {f} names a vertex beyond the {n} positions"
            )));
        }
        if let Some(rho) = &state.lipid_density {
            if rho.len() != n {
                return Err(err(format!(
                    "field `lipid_density`: {} values for {n} vertices",
                    rho.len()
                )));
            }
            if let Some(k) = rho.iter().position(|r| !(r.is_finite() && *r > 0.0)) {
                return Err(err(format!(
                    "field `lipid_density`: vertex {k} has {} (must be finite and > 0)",
                    rho[k]
                )));
            }
        }
        Ok(state)
    }

    /// The saved mesh.
    pub fn mesh(&self) -> SurfaceMesh {
        SurfaceMesh {
            positions: self
                .positions
                .iter()
                .map(|&p| DVec3::from_array(p))
                .collect(),
            faces: self.faces.clone(),
        }
    }

    /// The state as pretty JSON.
    pub fn to_json(&self) -> String {
        serde_json::to_string(self).expect("a state serialises")
    }
}
