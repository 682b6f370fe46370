//! What makes a term built in: the scene's entry for it ([`BuiltinTerm`]:
//! its parameters as written, `Bending(kappa: 20.0)`) and the one list of
//! built-in terms in [`super`], from which the macro `builtin_terms!` generates the
//! scene's [`EnergyTerm`](super::EnergyTerm) enum and its dispatch.
//!
//! Adding a built-in term touches two files: the term's own (its parameters,
//! kernel, `ForceTerm`, plugin and this trait) and the list in
//! `energy/mod.rs` (its `mod` line and its entry).

use crate::engine::error::BuildError;
use crate::engine::simulation::{Plugin, SimBuilder};
use crate::params::RemeshMode;

/// What a term's plugin may need to know about the rest of the scene.
#[derive(Clone, Copy, Debug)]
pub struct TermContext {
    /// The scene's remeshing mode (the geometric baseline keeps V_in for
    /// the time step and the relaxation but drops its global force).
    pub remesh_mode: RemeshMode,
}

/// Why a term is refused on an open mesh (one with boundary loops), as a
/// clause for the user.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum OpenMeshError {
    /// The term has not said it is correct on open meshes (the default of
    /// [`BuiltinTerm::open_mesh_support`]).
    #[error("it has not been made boundary-aware")]
    NotBoundaryAware,
    /// A plugin term: plugins do not declare it.
    #[error("plugin terms do not declare whether they are correct on open meshes")]
    PluginTerm,
    /// The volume penalty without a closing plane.
    #[error(
        "an open mesh encloses no volume: declare a closing plane, \
         `closing: Plane(point: (x, y, z), normal: (nx, ny, nz))`"
    )]
    NoClosingPlane,
    /// Another reason, as a clause for the user.
    #[error("{0}")]
    Invalid(String),
}

impl From<&str> for OpenMeshError {
    fn from(reason: &str) -> Self {
        OpenMeshError::Invalid(reason.to_string())
    }
}

impl From<String> for OpenMeshError {
    fn from(reason: String) -> Self {
        OpenMeshError::Invalid(reason)
    }
}

/// What a built-in term needs from the rest of the scene, what it cannot
/// run with, and what it gives the scene's defaults. The scene's
/// validation and build read these declarations (and name the field at
/// fault); they do not know the terms by name.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TermNeeds {
    /// It reads the lipid density carried by the vertices
    /// (`lipid_density: true`).
    pub lipid_density: bool,
    /// It acts through the scene's control points: it needs at least one,
    /// and control points need a term that uses them.
    pub control_points: bool,
    /// Its barriers trigger remeshing (V_in's): remeshing needs such a term.
    pub triggers_remeshing: bool,
    /// The global quantity it penalises, which an exact constraint on the
    /// same quantity would hold twice.
    pub penalises: Option<GlobalQuantity>,
    /// Why it cannot run in the fluid model, if it cannot: the field of the
    /// term at fault (empty: the term itself) and the reason.
    pub not_in_fluid_model: Option<(&'static str, String)>,
    /// The bending rigidity κ it carries (Ē): the scene's bending terms'
    /// sum is the Sobolev metric's default normal scale, and the first
    /// one's κ is the continuum adhered vesicle's.
    pub bending_rigidity: Option<f64>,
    /// The stiffness its control-point springs have (Ē/l̄²): the last such
    /// term's is the default of control points that set none.
    pub control_point_stiffness: Option<f64>,
}

/// A global quantity of the membrane that a penalty or a constraint holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GlobalQuantity {
    /// The total area.
    Area,
    /// The enclosed volume.
    Volume,
}

/// A built-in term's parameters as a scene declares them. A term writes
/// its [`plugin`](BuiltinTerm::plugin) and, where it holds, that it is
/// correct on open meshes ([`CORRECT_ON_OPEN_MESHES`](BuiltinTerm::CORRECT_ON_OPEN_MESHES));
/// the rest has defaults.
pub trait BuiltinTerm {
    /// Whether the term is correct on an open mesh (one with boundary
    /// loops: boundary edges have one face, boundary vertices an open fan).
    /// Default: no, so a new term runs on open meshes only once it says it
    /// is correct there (and its finite-difference test covers an open
    /// patch, `tests/integration/open_fd.rs`).
    const CORRECT_ON_OPEN_MESHES: bool = false;

    /// The term's plugin (its force term and whatever else it inserts:
    /// resources, systems, recorders) in a scene described by `context`.
    fn plugin(&self, context: TermContext) -> impl Plugin;

    /// Adds the term's [`plugin`](BuiltinTerm::plugin) to `builder`.
    fn add_to(&self, builder: &mut SimBuilder, context: &TermContext) -> Result<(), BuildError> {
        builder.add_plugin(self.plugin(*context))?;
        Ok(())
    }

    /// Rescales every length in the parameters to a mesh whose edge length
    /// is `h` times the scene's (see `Scene::at_resolution`): lengths are
    /// multiplied by `h`, steepnesses (per length) divided by it. Default:
    /// nothing depends on the edge length.
    fn at_resolution(&mut self, h: f64) {
        let _ = h;
    }

    /// What the term needs from the rest of the scene ([`TermNeeds`]).
    /// Default: nothing.
    fn needs(&self) -> TermNeeds {
        TermNeeds::default()
    }

    /// Whether the term is correct on an open mesh: `Ok`, or why not, as a
    /// clause for the user. Default: as
    /// [`CORRECT_ON_OPEN_MESHES`](BuiltinTerm::CORRECT_ON_OPEN_MESHES)
    /// says; a term correct under a condition (the volume, with a closing
    /// plane) says which.
    fn open_mesh_support(&self) -> Result<(), OpenMeshError> {
        if Self::CORRECT_ON_OPEN_MESHES {
            Ok(())
        } else {
            Err(OpenMeshError::NotBoundaryAware)
        }
    }
}

/// Generates, from the list of built-in terms, the scene's `EnergyTerm`
/// enum (one variant per term, named as in scenes, plus `Custom(C)` for
/// plugin terms) with its name, resolution and build dispatch.
macro_rules! builtin_terms {
    ($( $(#[$meta:meta])* $variant:ident($params:ty), )*) => {
        /// One energy term and its parameters, as a scene declares it: a
        /// built-in term (`Bending(kappa: 20.0)`) or, with `Custom(C)`, a
        /// plugin term (the scene format's `C` is
        /// `remembrane::scene::plugin_decl::TermPlugin`).
        #[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
        #[serde(deny_unknown_fields)]
        pub enum EnergyTerm<C> {
            $( $(#[$meta])* $variant($params), )*
            /// A plugin term from the registry: `Custom(name: "...", params: (...))`.
            Custom(C),
        }

        impl<C> EnergyTerm<C> {
            /// The variant's name as written in scenes.
            pub fn kind(&self) -> &'static str {
                match self {
                    $( EnergyTerm::$variant(_) => stringify!($variant), )*
                    EnergyTerm::Custom(_) => "Custom",
                }
            }

            /// The built-in term's parameters at edge length `h`
            /// ([`BuiltinTerm::at_resolution`](crate::energy::builtin::BuiltinTerm::at_resolution)); a plugin term is unchanged.
            pub fn at_resolution(&mut self, h: f64) {
                match self {
                    $( EnergyTerm::$variant(p) => $crate::energy::builtin::BuiltinTerm::at_resolution(p, h), )*
                    EnergyTerm::Custom(_) => {}
                }
            }

            /// Whether the term is correct on an open mesh: `Ok`, or why
            /// not ([`BuiltinTerm::open_mesh_support`](crate::energy::builtin::BuiltinTerm::open_mesh_support)).
            /// A plugin term is refused: plugins do not declare it.
            pub fn open_mesh_support(&self) -> Result<(), $crate::energy::builtin::OpenMeshError> {
                match self {
                    $( EnergyTerm::$variant(p) => $crate::energy::builtin::BuiltinTerm::open_mesh_support(p), )*
                    EnergyTerm::Custom(_) => Err($crate::energy::builtin::OpenMeshError::PluginTerm),
                }
            }

            /// What the term needs from the rest of the scene
            /// ([`BuiltinTerm::needs`](crate::energy::builtin::BuiltinTerm::needs));
            /// a plugin term declares nothing.
            pub fn needs(&self) -> $crate::energy::builtin::TermNeeds {
                match self {
                    $( EnergyTerm::$variant(p) => $crate::energy::builtin::BuiltinTerm::needs(p), )*
                    EnergyTerm::Custom(_) => Default::default(),
                }
            }

            /// Adds the term to `builder`: a built-in term through its
            /// [`BuiltinTerm::add_to`](crate::energy::builtin::BuiltinTerm::add_to), a plugin term through `custom`.
            pub fn add_to(
                &self,
                builder: &mut $crate::engine::simulation::SimBuilder,
                context: &$crate::energy::builtin::TermContext,
                custom: impl FnOnce(&C, &mut $crate::engine::simulation::SimBuilder)
                    -> Result<(), $crate::engine::error::BuildError>,
            ) -> Result<(), $crate::engine::error::BuildError> {
                match self {
                    $( EnergyTerm::$variant(p) => $crate::energy::builtin::BuiltinTerm::add_to(p, builder, context), )*
                    EnergyTerm::Custom(c) => custom(c, builder),
                }
            }
        }
    };
}
pub(crate) use builtin_terms;
