//! [`Simulation`]: a built scene: the membrane world, its force stage and
//! the dense per-tick buffers.

use crate::force::{ForceEvaluation, ForceSet};
use crate::membrane::Membrane;
use crate::topology::TopologyError;
use glam::DVec3;

/// Quantities of the initial mesh that targets are resolved against.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct InitialState {
    /// Vertex count N_initial.
    pub vertices: usize,
    /// Total area (l̄²).
    pub area: f64,
    /// Enclosed volume (l̄³).
    pub volume: f64,
}

/// A membrane with its force systems and dense buffers.
pub struct Simulation {
    /// The world and its caches.
    pub membrane: Membrane,
    /// The force stage.
    pub forces: ForceSet,
    /// Initial-mesh quantities.
    pub initial: InitialState,
    /// Dense position mirror (gathered from the world).
    pub positions: Vec<DVec3>,
    /// Dense lipid density mirror (empty without lipid density).
    pub lipid: Vec<f64>,
    /// The last force evaluation.
    pub evaluation: ForceEvaluation,
}

impl Simulation {
    /// Wraps a membrane and its force stage.
    pub fn new(membrane: Membrane, forces: ForceSet, initial: InitialState) -> Self {
        Self {
            membrane,
            forces,
            initial,
            positions: Vec::new(),
            lipid: Vec::new(),
            evaluation: ForceEvaluation::default(),
        }
    }

    /// Refreshes the caches, gathers the dense mirror, evaluates all force
    /// terms and writes the total force back to the world.
    pub fn evaluate_forces(&mut self) -> Result<&ForceEvaluation, TopologyError> {
        self.membrane.topology()?;
        self.membrane.gather_positions(&mut self.positions);
        self.membrane.gather_lipid(&mut self.lipid);
        self.forces.evaluate(
            &self.membrane.world,
            self.membrane.cached_topology(),
            &self.positions,
            &self.lipid,
            &mut self.evaluation,
        );
        self.membrane.scatter_forces(&self.evaluation.total);
        Ok(&self.evaluation)
    }
}
