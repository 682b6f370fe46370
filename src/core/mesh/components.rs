//! Components of the hecs world: the source of truth for the membrane.
//!
//! - vertex entity: [`Position`], [`Force`], and [`LipidDensity`] only when
//!   the scene declares lipid density;
//! - edge entity: [`Edge`];
//! - face entity: [`Face`];
//! - control-point entity: [`ControlPoint`].
//!
//! Subsets are tagged by values, never by inserting/removing marker
//! components: that would move entities between archetypes, a structural
//! change that invalidates the derived caches.

use glam::DVec3;
use hecs::Entity;

/// Vertex position (l̄ = 1 µm).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Position(pub DVec3);

/// Total force on a vertex from the last force evaluation (Ē/l̄).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Force(pub DVec3);

/// Normalised lipid density of a vertex (dimensionless, 1 = initial).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LipidDensity(pub f64);

/// A mesh edge. `faces[0]` traverses the edge as `vertices[0] → vertices[1]`,
/// `faces[1]` as `vertices[1] → vertices[0]`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Edge {
    /// The two end vertices.
    pub vertices: [Entity; 2],
    /// The two incident faces (left, right).
    pub faces: [Entity; 2],
}

/// A mesh face, vertices counter-clockwise seen from outside.
/// `edges[k]` joins `vertices[k]` and `vertices[(k + 1) % 3]`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Face {
    /// The three corner vertices.
    pub vertices: [Entity; 3],
    /// The three edges.
    pub edges: [Entity; 3],
}

/// A fixed external control point pulling its nearest vertex and that
/// vertex's 1-ring with Hookean springs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ControlPoint {
    /// Fixed position (l̄).
    pub position: DVec3,
    /// Spring constant k_ex (Ē/l̄²).
    pub stiffness: f64,
}

/// Declaration index of a control point in its scene (used by schedules).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ControlPointIndex(pub u32);
