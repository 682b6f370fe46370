//! Boundary conditions of an open membrane, one per boundary loop, as a
//! scene declares them: `boundary: [Pinned(loop: 0)]`. Loops are numbered
//! in the order of their lowest-numbered vertex in the initial mesh
//! ([`crate::mesh::topology::Topology::boundary_loops`]); a generated
//! `Disc` or `SphericalCap` has one, loop 0. A loop without a condition is
//! free without line tension.
//!
//! `Pinned` and `Roller` loops hold their vertices by [`HeldDirections`]:
//! all three directions of motion for a pinned loop, the declared one for a
//! roller.

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
    /// Every vertex of the loop keeps its initial coordinate along
    /// `direction` and moves freely perpendicular to it: its force loses
    /// the component along the direction before the step, and its position
    /// gets that coordinate back after it. A roller with direction (0, 0, 1)
    /// holds a patch's rim in its plane z = z0 and lets it slide in it.
    Roller {
        /// Index of the boundary loop (see the module docs).
        #[serde(rename = "loop")]
        loop_index: usize,
        /// The direction in which the loop is held (any finite non-zero
        /// vector; normalised).
        direction: (f64, f64, f64),
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
            | BoundaryCondition::Roller { loop_index, .. }
            | BoundaryCondition::Free { loop_index, .. } => loop_index,
        }
    }

    /// The directions in which the condition holds the loop's vertices
    /// (`None` for a free loop), or why the declaration is invalid.
    pub fn held(&self) -> Result<Option<HeldDirections>, crate::util::validate::ValidationError> {
        match *self {
            BoundaryCondition::Pinned { .. } => Ok(Some(HeldDirections::All)),
            BoundaryCondition::Roller { direction, .. } => {
                let d = glam::DVec3::new(direction.0, direction.1, direction.2);
                let n = d.length();
                if !n.is_finite() || n == 0.0 {
                    return Err(format!(
                        "the roller's direction must be a finite, non-zero vector, not {direction:?}"
                    )
                    .into());
                }
                Ok(Some(HeldDirections::Along(d / n)))
            }
            BoundaryCondition::Free { .. } => Ok(None),
        }
    }
}

/// The directions of motion a boundary condition holds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum HeldDirections {
    /// All three: the vertex does not move (pinned).
    All,
    /// Only along this unit vector: the vertex slides in the plane
    /// perpendicular to it (roller).
    Along(glam::DVec3),
}

impl HeldDirections {
    /// Removes from `v` its held part: all of it, or its component along
    /// the held direction.
    #[inline]
    pub fn release(self, v: glam::DVec3) -> glam::DVec3 {
        match self {
            HeldDirections::All => glam::DVec3::ZERO,
            HeldDirections::Along(d) => v - v.dot(d) * d,
        }
    }

    /// Moves `p` back to `x0` in the held directions, keeping its free
    /// part.
    #[inline]
    pub fn restore(self, p: glam::DVec3, x0: glam::DVec3) -> glam::DVec3 {
        match self {
            HeldDirections::All => x0,
            HeldDirections::Along(d) => p + (x0 - p).dot(d) * d,
        }
    }
}
