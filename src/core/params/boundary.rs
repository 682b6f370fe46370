//! Boundary conditions of an open membrane, one per boundary loop, as a
//! scene declares them: `boundary: [Pinned(loop: 0)]`. Loops are numbered
//! in the order of their lowest-numbered vertex in the initial mesh
//! ([`crate::mesh::topology::Topology::boundary_loops`]); a generated
//! `Disc` or `SphericalCap` has one, loop 0. A loop without a condition is
//! free without line tension.

use serde::{Deserialize, Serialize};

/// The condition held on one boundary loop.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum BoundaryCondition {
    /// Every vertex of the loop keeps its initial position: its force is
    /// zeroed before the step (the minimiser never moves it) and its
    /// position restored after it (the thermal noise does not either).
    Pinned {
        /// Index of the boundary loop (see the module docs).
        #[serde(rename = "loop")]
        loop_index: usize,
    },
    /// The loop's vertices move freely; the exposed edge costs λ per
    /// length (energy λ·L, [`crate::energy::line_tension`]).
    Free {
        /// Index of the boundary loop (see the module docs).
        #[serde(rename = "loop")]
        loop_index: usize,
        /// λ, the line tension (Ē/l̄ = 10 k_BT/µm ≈ 41 pN; ≥ 0; default 0).
        #[serde(default, deserialize_with = "crate::util::validate::non_negative")]
        line_tension: f64,
    },
}

impl BoundaryCondition {
    /// The loop the condition applies to.
    pub fn loop_index(&self) -> usize {
        match *self {
            BoundaryCondition::Pinned { loop_index }
            | BoundaryCondition::Free { loop_index, .. } => loop_index,
        }
    }
}
