//! The membrane model: the paper's, or the fluid model and its settings.

use super::*;

/// The membrane model (SPEC §8): what the mesh-maintenance forces act on.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum MembraneModel {
    /// The paper's model: V_in acts on every degree of freedom, so on a
    /// fixed connectivity the mesh is a pre-stressed spring network with a
    /// shear modulus (an elastic shell).
    #[default]
    Paper,
    /// A two-dimensional fluid: the forces of mesh-maintenance terms
    /// ([`crate::engine::force::ForceKind::Maintenance`], V_in) are projected onto
    /// the vertices' tangent planes, and so are the local relaxations and
    /// kicks of remesh events. V_in then keeps the triangles regular without
    /// acting on the shape, which only the physical terms move (bending,
    /// tension, pressure or volume, area, plugins): no shear modulus.
    Fluid(FluidParams),
}

impl MembraneModel {
    /// Whether this is the fluid model.
    pub fn is_fluid(&self) -> bool {
        matches!(self, MembraneModel::Fluid(_))
    }

    /// Whether remesh events edit directly (the fluid model with
    /// [`FluidEdits::Direct`]).
    pub fn direct_edits(&self) -> bool {
        matches!(
            self,
            MembraneModel::Fluid(FluidParams {
                edits: FluidEdits::Direct,
                ..
            })
        )
    }
}

/// Settings of the fluid model. The vertex normal of the projection is the
/// area-weighted one, n_i ∝ Σ_f∋i A_f n_f ∝ ∇_i V, so tangential moves keep
/// the enclosed volume to first order; it has no setting.
///
/// The defaults are the ones that work on flowing shapes: direct edits and
/// maintenance flips every iteration (with the remesh triggers' fluid
/// defaults, `crate::params::RemeshParams::fluid_defaults`). Measured
/// (2026-12-06) on the red blood cell scene with a prolate start (semi-axes
/// 6.2, 6.2, 7.7) at v = 0.75, 642 vertices, Sobolev minimiser: with the
/// paper's pre-relaxed events and no flips 150 iterations took 80 s, 99.9 %
/// of it remeshing; with these defaults it converges by its force tolerance
/// in 485 iterations, 0.44 s, 12 % of it remeshing.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct FluidParams {
    /// How a remesh event edits the mesh (default `Direct`; `Relaxed` is
    /// the paper's event made tangential).
    pub edits: FluidEdits,
    /// Delaunay flips as mesh maintenance (default every iteration, up to
    /// 20° between the faces; `flips: None` turns them off). A fluid flows
    /// in its plane; without flips an elongation stretches the triangles
    /// until splits and merges cannot follow (see
    /// `systems/maintenance_flips.rs`).
    pub flips: Option<MaintenanceFlipParams>,
    /// Which components of the physical terms' forces act (default `Full`).
    #[serde(skip_serializing_if = "PhysicalForces::is_full")]
    pub physical_forces: PhysicalForces,
}

impl Default for FluidParams {
    fn default() -> Self {
        Self {
            edits: FluidEdits::Direct,
            flips: Some(MaintenanceFlipParams {
                max_dihedral: default_max_dihedral(),
                every: default_flip_every(),
            }),
            physical_forces: PhysicalForces::Full,
        }
    }
}

/// Which components of the physical terms' forces (bending, tension,
/// area and volume penalties, plugins) act in the fluid model.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum PhysicalForces {
    /// The whole gradient of the discrete energy.
    #[default]
    Full,
    /// Only the component along each vertex's area-weighted normal, as in
    /// Mem3DG, less the net force that leaves (a rigid translation). The continuum's shape derivative of an energy that does not
    /// depend on the parametrisation has no tangential part; the discrete
    /// energy's tangential gradient only slides vertices along the surface,
    /// against the mesh maintenance. Measured with the dihedral bending on
    /// the stomatocyte at 642 vertices: with `Full` its neck fires remesh
    /// events without end (981 splits and 900 merges in 20 000 iterations,
    /// E_b/8πκ +1.9 % to +23 %), with `Normal` 47 splits and 14 merges and
    /// +0.27 %. The forces are then no longer a gradient: use it with the
    /// minimiser (FIRE needs no gradient) or dynamics, not with the
    /// paper's energy-based flips.
    Normal,
}

impl PhysicalForces {
    /// Whether this is the default (left out when written).
    pub fn is_full(&self) -> bool {
        *self == PhysicalForces::Full
    }
}

/// Delaunay flips as mesh maintenance in the fluid model.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MaintenanceFlipParams {
    /// Largest angle between the normals of an edge's two faces at which
    /// the edge may be flipped (degrees; default 20): the flip moves the
    /// surface by the tetrahedron between the four corners.
    #[serde(
        default = "default_max_dihedral",
        deserialize_with = "crate::util::validate::positive"
    )]
    pub max_dihedral: f64,
    /// Iterations between sweeps over the edges (default 1). Every flip is
    /// a topology change, after which the minimiser restarts from rest.
    #[serde(default = "default_flip_every")]
    pub every: u32,
}

pub(super) fn default_max_dihedral() -> f64 {
    20.0
}

pub(super) fn default_flip_every() -> u32 {
    1
}

/// How a split or merge is carried out in the fluid model.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum FluidEdits {
    /// The paper's event, every move tangential: the patch is first relaxed
    /// under V_in and Lévy kicks until the edge crosses l_++ (split) or L_−
    /// (merge), then edited, then the new vertex's 1-ring relaxes into the
    /// normal range.
    Relaxed,
    /// The edit is applied at once, without the free-energy pre-relaxation,
    /// and the new vertex's 1-ring then relaxes tangentially into the normal
    /// range. In the fluid model V_in only keeps triangles regular, so the
    /// barrier crossing it guards has no physical meaning; the pre-relaxation
    /// fails where a region is stretched as a whole (every neighbour long at
    /// once: 647 failed splits in 90 iterations on the 2562-vertex prolate,
    /// none with direct edits). Needs `remesh.longer_than` > 2 ×
    /// `remesh.shorter_than`, so that a split's halves are never merged
    /// again (without that gap, split and merge ping-pong); the fluid
    /// defaults of the triggers have it. The default.
    #[default]
    Direct,
}
