//! RON scene files: the membrane, the energy terms it uses, parameters,
//! control points and seed. See `scenes/reference.ron` for every key.
//!
//! Loading rejects unknown fields and impossible values with
//! `FILE:LINE:COL: field `path`: reason`; checks that need the whole scene
//! (e.g. local tension without lipid density) name the file and field.

mod build;
mod open_mesh;
pub mod overrides;
pub mod plugin_decl;
pub mod plugins;
pub mod registry;
pub mod resolution;
pub mod setting;
mod validate;

use crate::engine::simulation::{BuildError, InitialState, SimBuilder, Simulation};
use crate::mesh::components::ControlPoint;
use crate::mesh::geometry::{enclosed_volume, total_area};
use crate::mesh::io::{MeshIoError, read_mesh};
use crate::mesh::membrane::Membrane;
use crate::mesh::{MeshError, SurfaceMesh, ValenceRange, check_mesh, docked_pair, icosphere};
use crate::params::{DynamicsParams, RemeshParams, SpringParams};
use glam::DVec3;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// A scene as written in a RON file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scene {
    /// Short name, used in outputs.
    #[serde(default)]
    pub name: String,
    /// Free text.
    #[serde(default)]
    pub description: String,
    /// Seed of every random stream (initial jitter, remesh order, noise).
    #[serde(default = "default_seed")]
    pub seed: u64,
    /// Where the initial mesh comes from.
    pub membrane: MembraneSource,
    /// Allowed vertex valences (default 5..=8; fusion uses 5..=10).
    #[serde(default)]
    pub valence: ValenceRange,
    /// Whether vertices carry a lipid density (only then is it stored).
    #[serde(default)]
    pub lipid_density: bool,
    /// The energy terms, each at most once. Only these are spawned and run.
    pub energy: Vec<EnergyTerm>,
    /// Plugin systems, each added to its stage after the built-in ones.
    #[serde(default)]
    pub systems: Vec<SystemDecl>,
    /// Passes of closed 1-ring averaging of penalty forces (volume, area,
    /// local tension); as run: 4, 0 = exact gradient.
    #[serde(default = "default_smoothing")]
    pub penalty_smoothing: u32,
    /// Fixed control points (used by the `Springs` term).
    #[serde(default)]
    pub control_points: Vec<ControlPointSpec>,
    /// Scheduled changes of control points (by declaration index).
    #[serde(default)]
    pub control_point_schedule: Vec<crate::params::schedule::ScheduledChange>,
    /// Tubes (tethers, filopodia) whose radius is measured at every frame
    /// (`radius_<name>` and `radius_<name>_norm` in series.csv).
    #[serde(default)]
    pub tube_radius: Vec<crate::analysis::tube_radius::TubeProbe>,
    /// Dynamics: mobility, temperature, time-step limits, run length, frames.
    #[serde(default)]
    pub dynamics: DynamicsParams,
    /// Barrier-crossing remeshing.
    #[serde(default)]
    pub remesh: RemeshParams,
    /// Protein species on the membrane: area fractions that couple to the
    /// curvature, bind, interact and mix (default none; see
    /// `docs/proteins.md`). Their fields relax with the minimiser; in
    /// overdamped dynamics they move by their mobility and binding rate.
    #[serde(default)]
    pub species: Option<crate::species::params::SpeciesSet>,
    /// Lipid diffusion (needs `lipid_density: true`; default none).
    #[serde(default)]
    pub diffusion: Option<crate::params::DiffusionParams>,
    /// Edge flips as Metropolis moves, for a fluid triangulation at
    /// k_BT > 0 (default none).
    #[serde(default)]
    pub edge_flips: Option<crate::params::EdgeFlipParams>,
    /// Exact area and volume constraints held by Lagrange multipliers, in
    /// place of the Area and Volume penalties (default none).
    #[serde(default)]
    pub constraints: Option<crate::params::ConstraintParams>,
    /// The membrane model: `Paper` (default; V_in acts on the shape, an
    /// elastic shell) or `Fluid()` (V_in acts only in the tangent planes:
    /// a fluid membrane without shear modulus).
    #[serde(default)]
    pub model: crate::params::MembraneModel,
    /// Boundary conditions of an open membrane, one per boundary loop:
    /// `[Pinned(loop: 0)]` (default none: every loop free, without line
    /// tension). Loops are numbered by their lowest-numbered vertex; a
    /// `Disc` or `SphericalCap` has one, loop 0. See `docs/open_meshes.md`.
    #[serde(default)]
    pub boundary: Vec<crate::params::BoundaryCondition>,
    /// Target edge length h: `EdgeLength(h)` (l̄; default 1) or `FromMesh`
    /// (the initial mesh's mean edge length). Every mesh-scale length of the
    /// scene (V_in's, remeshing's, flips', self-avoidance's, the Gaussian
    /// spring patch) is written for h = 1 and multiplied by h; the mobility
    /// per vertex follows a per-area mobility ([`crate::scene::resolution`]).
    #[serde(default)]
    pub resolution: crate::scene::resolution::Resolution,
}

fn default_seed() -> u64 {
    1
}
fn default_smoothing() -> u32 {
    4
}
fn default_edge_length() -> f64 {
    1.0
}
fn default_docking_level() -> u32 {
    2
}

/// Largest capsule a scene may ask for (as many vertices as an icosphere of
/// the largest level, 163842, times 6).
const MAX_CAPSULE_VERTICES: usize = 1_000_000;

/// The largest ratio between a generated mesh's edges and the resolution's
/// h (either way) that [`Scene::cautions`] lets pass.
const EDGE_MISMATCH: f64 = 1.2;

/// Source of the initial mesh.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum MembraneSource {
    /// Icosphere of `level` subdivisions (0..=7; 3 gives 642 vertices).
    Icosphere {
        /// Subdivision level 0..=7.
        level: u32,
        /// Mean edge length after rescaling (l̄; default 1).
        #[serde(
            default = "default_edge_length",
            deserialize_with = "crate::util::validate::positive"
        )]
        mean_edge_length: f64,
        /// Amplitude of a seeded uniform jitter added to every coordinate
        /// (l̄; default 0; the reference code used ≈ 6.6e-4).
        #[serde(default, deserialize_with = "crate::util::validate::non_negative")]
        jitter: f64,
    },
    /// An ellipsoid: the unit icosphere of `level` subdivisions with every
    /// vertex mapped to (a x, b y, c z), so all vertices lie on the surface
    /// x²/a² + y²/b² + z²/c² = 1 (the spheroid of the accuracy study).
    Ellipsoid {
        /// Subdivision level 0..=7.
        level: u32,
        /// Semi-axes (a, b, c) along x, y, z (l̄).
        semi_axes: (f64, f64, f64),
        /// Seeded random tangential displacement of each unit-sphere vertex
        /// before the mapping, as a fraction of the unit icosphere's mean
        /// edge length (default 0). Vertices stay exactly on the surface;
        /// only the mesh quality changes (paper Fig 1).
        #[serde(default, deserialize_with = "crate::util::validate::non_negative")]
        jitter: f64,
        /// Rotation of the unit icosphere about the x axis before the
        /// jitter and the mapping (degrees, default 0): another
        /// triangulation of the same surface.
        #[serde(default)]
        tilt: f64,
    },
    /// A capsule along z, centred at the origin: a cylinder of `radius` and
    /// `length` closed by hemispherical caps, in staggered rings of nearly
    /// equilateral triangles (the tether study's tube).
    Capsule {
        /// Radius of the cylinder and the caps (l̄).
        #[serde(deserialize_with = "crate::util::validate::positive")]
        radius: f64,
        /// Length of the cylindrical part; the caps add 2·radius (l̄).
        #[serde(deserialize_with = "crate::util::validate::non_negative")]
        length: f64,
        /// Side of the triangles (l̄; default 1).
        #[serde(
            default = "default_edge_length",
            deserialize_with = "crate::util::validate::positive"
        )]
        mean_edge_length: f64,
    },
    /// The continuum's equilibrium vesicle on `branch` at `reduced_volume`
    /// (the project's axisymmetric solver, `crate::analysis::axisymmetric`, at 200
    /// segments, κ-independent at `c0 = 0`), scaled to `area`, axis along z,
    /// as a surface of revolution in rings of nearly equilateral triangles
    /// of side `mean_edge_length`: a start on a branch that a deflated
    /// sphere or spheroid does not reach (the stomatocyte's cup and neck).
    Axisymmetric {
        /// `Prolate`, `Oblate` or `Stomatocyte` (the last exists below
        /// v ≈ 0.6608).
        branch: crate::analysis::axisymmetric::Branch,
        /// Reduced volume v = 3V/(4πR0³), R0 = √(area/4π), in (0.5, 1]
        /// (dimensionless).
        reduced_volume: f64,
        /// Area of the continuum shape (l̄²); the mesh's, inscribed, is a
        /// little smaller.
        #[serde(deserialize_with = "crate::util::validate::positive")]
        area: f64,
        /// Side of the triangles (l̄; default 1).
        #[serde(
            default = "default_edge_length",
            deserialize_with = "crate::util::validate::positive"
        )]
        mean_edge_length: f64,
    },
    /// An open flat disc in the plane z = 0, centred at the origin, normal
    /// +z, in rings of a hexagonal lattice (valence 6 inside, 3-4 on the rim;
    /// 1 + 3K(K + 1) vertices for K rings): one boundary loop. Open meshes
    /// run only the terms and options that are correct on them (see
    /// `docs/open_meshes.md`).
    Disc {
        /// Radius of the rim (l̄).
        #[serde(deserialize_with = "crate::util::validate::positive")]
        radius: f64,
        /// Mean edge length aimed at (l̄; default 1): K = round(1.12 ·
        /// radius / mean_edge_length) rings.
        #[serde(
            default = "default_edge_length",
            deserialize_with = "crate::util::validate::positive"
        )]
        mean_edge_length: f64,
    },
    /// An open spherical cap: the part of the sphere of `sphere_radius`
    /// centred at the origin within `opening_angle` of the +z pole, normal
    /// outward, in the disc's lattice mapped to equal polar-angle steps:
    /// one boundary loop (an open mesh, as `Disc`).
    SphericalCap {
        /// Radius of the sphere (l̄).
        #[serde(deserialize_with = "crate::util::validate::positive")]
        sphere_radius: f64,
        /// Polar angle of the rim (degrees, in (0, 90]).
        opening_angle: f64,
        /// Mean edge length aimed at (l̄; default 1).
        #[serde(
            default = "default_edge_length",
            deserialize_with = "crate::util::validate::positive"
        )]
        mean_edge_length: f64,
    },
    /// Two icospheres of `level` glued through one triangle (fusion; level 2
    /// gives 321 vertices).
    DockedPair {
        /// Subdivision level of each sphere (default 2).
        #[serde(default = "default_docking_level")]
        level: u32,
    },
    /// A `.ply` or `.obj` file, relative to the scene file's folder.
    File {
        /// Path of the mesh file.
        path: PathBuf,
        /// Factor applied to all coordinates (default 1).
        #[serde(
            default = "default_edge_length",
            deserialize_with = "crate::util::validate::positive"
        )]
        scale: f64,
    },
    /// The `state.json` of a completed run (relative to the scene file's
    /// folder): its mesh and, if the scene declares lipid density, its
    /// densities. `remembrane run --from STATE` sets this.
    State {
        /// Path of the state file.
        path: PathBuf,
        /// Times every triangle is split into four at its edges' midpoints
        /// (default 0; at most 3): the saved shape on a mesh with edges
        /// half as long per step, a start for a finer resolution
        /// (`resolution: EdgeLength(h / 2)`). Needs a scene without lipid
        /// density.
        #[serde(default)]
        refine: u32,
    },
    /// A mesh given inline (what the Python package's `Scene.with_mesh`
    /// writes): vertex positions and triangles, checked like a file's.
    Mesh {
        /// Vertex positions (l̄).
        positions: Vec<DVec3>,
        /// Triangles as vertex indices, counter-clockwise seen from outside.
        faces: Vec<[u32; 3]>,
    },
}

impl MembraneSource {
    /// The edge length a generator is asked for (`mean_edge_length`), or
    /// `None` for a source whose edges follow from a level or a file.
    pub fn generated_edge_length(&self) -> Option<f64> {
        match self {
            MembraneSource::Icosphere {
                mean_edge_length, ..
            }
            | MembraneSource::Capsule {
                mean_edge_length, ..
            }
            | MembraneSource::Axisymmetric {
                mean_edge_length, ..
            }
            | MembraneSource::Disc {
                mean_edge_length, ..
            }
            | MembraneSource::SphericalCap {
                mean_edge_length, ..
            } => Some(*mean_edge_length),
            _ => None,
        }
    }
}

/// One energy term and its parameters: a built-in term (the list in
/// [`crate::energy`], which generates the enum) or a plugin term
/// (`Custom(name: "...", params: (...))`).
pub type EnergyTerm = crate::energy::EnergyTerm<crate::scene::plugin_decl::TermPlugin>;

/// A system declared by a scene.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum SystemDecl {
    /// A plugin system from the registry:
    /// `Custom(name: "...", stage: Observe, params: (...))`.
    Custom(crate::scene::plugin_decl::SystemPlugin),
}

/// A control point as written in a scene.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ControlPointSpec {
    /// Fixed position (l̄).
    #[serde(deserialize_with = "crate::util::validate::finite_vec3")]
    pub position: (f64, f64, f64),
    /// Spring constant (Ē/l̄²); default: the `Springs` term's `stiffness`.
    #[serde(default, deserialize_with = "crate::util::validate::optional_positive")]
    pub stiffness: Option<f64>,
    /// With a name, every frame records the force this point's springs
    /// exert on the membrane: `series.csv` columns `force_<name>` (its
    /// magnitude) and `force_<name>_x`, `_y`, `_z` (Ē/l̄ = 10 k_BT/µm ≈
    /// 41 pN at 300 K). Letters, digits and `_`.
    #[serde(default)]
    pub name: Option<String>,
}

/// A scene could not be loaded or built.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// The file could not be read.
    #[error("{path}: cannot read scene file: {source}")]
    Read {
        /// Scene path.
        path: PathBuf,
        /// I/O error.
        source: std::io::Error,
    },
    /// Malformed RON, an unknown or missing field, or a bad value.
    #[error("{}:{line}:{col}: {}{reason}", path.display(), field_prefix(field))]
    Parse {
        /// Scene path.
        path: PathBuf,
        /// 1-based line.
        line: usize,
        /// 1-based column.
        col: usize,
        /// Dotted path of the field, if known (e.g. `energy[1].Bending.kappa`).
        field: Option<String>,
        /// What is wrong.
        reason: String,
    },
    /// The scene parsed but is inconsistent.
    #[error("{}: field `{field}`: {reason}", path.display())]
    Invalid {
        /// Scene path.
        path: PathBuf,
        /// Dotted path of the field.
        field: String,
        /// What is wrong.
        reason: String,
    },
    /// The membrane's mesh file is unreadable or not a valid membrane.
    #[error("{}: field `membrane`: {source}", path.display())]
    MeshFile {
        /// Scene path.
        path: PathBuf,
        /// The mesh file's error (names the mesh file).
        source: MeshIoError,
    },
    /// The generated or loaded mesh violates the scene's mesh requirements.
    #[error("{}: field `{field}`: {source}", path.display())]
    Mesh {
        /// Scene path.
        path: PathBuf,
        /// Field responsible (`membrane` or `valence`).
        field: &'static str,
        /// The violated invariant.
        source: MeshError,
    },
}

/// Why a scene has no continuum adhered vesicle
/// ([`Scene::adhesion_substrate`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
pub enum NoSubstrate {
    /// Its resolution is not an edge length.
    #[error("needs `resolution: EdgeLength(h)` (a ladder's rungs have one)")]
    NoEdgeLength,
    /// It has no bending term.
    #[error("no bending term")]
    NoBending,
    /// It has no (single) plane adhesion term.
    #[error("no plane adhesion term")]
    NoPlaneAdhesion,
}

fn field_prefix(field: &Option<String>) -> String {
    match field.as_deref() {
        Some(f) if !f.is_empty() && f != "." && f != "?" => format!("field `{f}`: "),
        _ => String::new(),
    }
}

/// RON options for scenes: `Vin(v0: 0.2)` for newtype variants and `Some`
/// implied for optional values.
/// The keys written in the `remesh: (...)` block of scene text that
/// parses (empty when there is none): the fluid model's defaults fill only
/// the others.
fn remesh_keys_given(text: &str) -> Vec<String> {
    let value: ron::Value = match ron_options().from_str(text) {
        Ok(v) => v,
        Err(_) => return Vec::new(),
    };
    let key = ron::Value::String("remesh".into());
    let ron::Value::Map(fields) = value else {
        return Vec::new();
    };
    match fields.get(&key) {
        Some(ron::Value::Map(remesh)) => remesh
            .keys()
            .filter_map(|k| match k {
                ron::Value::String(s) => Some(s.clone()),
                _ => None,
            })
            .collect(),
        _ => Vec::new(),
    }
}

fn ron_options() -> ron::Options {
    use ron::extensions::Extensions;
    ron::Options::default()
        .with_default_extension(Extensions::UNWRAP_VARIANT_NEWTYPES)
        .with_default_extension(Extensions::IMPLICIT_SOME)
}

impl Scene {
    /// Parses scene text with the process default plugin registry; `path`
    /// is used in error messages only.
    pub fn from_ron_str(text: &str, path: &Path) -> Result<Self, SceneError> {
        Self::from_ron_str_with(
            text,
            path,
            &crate::scene::registry::PluginRegistry::default_registry(),
        )
    }

    /// Parses scene text, resolving `Custom` plugins through `registry`.
    pub fn from_ron_str_with(
        text: &str,
        path: &Path,
        registry: &crate::scene::registry::PluginRegistry,
    ) -> Result<Self, SceneError> {
        crate::scene::registry::with_active(registry, || Self::parse(text, path))
    }

    fn parse(text: &str, path: &Path) -> Result<Self, SceneError> {
        let options = ron_options();
        let spanned = |e: ron::error::SpannedError, field: Option<String>| SceneError::Parse {
            path: path.to_owned(),
            line: e.span.start.line,
            col: e.span.start.col,
            field,
            reason: e.code.to_string(),
        };
        let mut de = ron::Deserializer::from_str_with_options(text, &options)
            .map_err(|e| spanned(e, None))?;
        let scene: Scene = match serde_path_to_error::deserialize(&mut de) {
            Ok(s) => s,
            Err(e) => {
                let field = e.path().to_string();
                let err = de.span_error(e.into_inner());
                return Err(spanned(err, Some(field)));
            }
        };
        de.end()
            .map_err(|code| spanned(de.span_error(code), None))?;
        let mut scene = scene;
        if scene.model.direct_edits() {
            let given = remesh_keys_given(text);
            scene
                .remesh
                .apply_fluid_defaults(|key| given.iter().any(|g| g == key));
        }
        scene.validate(path)?;
        Ok(scene)
    }

    /// The scene as RON text in the scene-file dialect: parsing it gives
    /// back an equal scene.
    pub fn to_ron_string(&self) -> Result<String, ron::Error> {
        let pretty = ron::ser::PrettyConfig::default().struct_names(true);
        ron_options().to_string_pretty(self, pretty)
    }

    /// Reads and parses a scene file with the process default registry.
    pub fn load(path: &Path) -> Result<Self, SceneError> {
        Self::load_with(
            path,
            &crate::scene::registry::PluginRegistry::default_registry(),
        )
    }

    /// Reads and parses a scene file, resolving plugins through `registry`.
    pub fn load_with(
        path: &Path,
        registry: &crate::scene::registry::PluginRegistry,
    ) -> Result<Self, SceneError> {
        let text = std::fs::read_to_string(path).map_err(|source| SceneError::Read {
            path: path.to_owned(),
            source,
        })?;
        Self::from_ron_str_with(&text, path, registry)
    }

    /// κ of the scene's bending term, if it has one (Ē).
    pub fn bending_kappa(&self) -> Option<f64> {
        self.energy.iter().find_map(|t| t.needs().bending_rigidity)
    }

    /// The scene's one adhesive substrate, if it has exactly one and it is
    /// a plane (the condition of the continuum adhered vesicle).
    pub fn adhesion_plane(&self) -> Option<crate::energy::adhesion::AdhesionParams> {
        let mut terms = self.energy.iter().filter_map(|t| match t {
            EnergyTerm::Adhesion(p) => Some(p),
            _ => None,
        });
        match (terms.next(), terms.next()) {
            (Some(p), None) if matches!(p.shape, crate::energy::wall::WallShape::Plane { .. }) => {
                Some(p.clone())
            }
            _ => None,
        }
    }

    /// The continuum adhered vesicle's parameters of this scene: its plane
    /// substrate at the scene's resolution and κ; `Err` says why the scene
    /// has none (it needs one plane `Adhesion` term, a bending term and
    /// `resolution: EdgeLength(h)`).
    pub fn adhesion_substrate(
        &self,
    ) -> Result<(crate::energy::adhesion::AdhesionParams, f64), NoSubstrate> {
        let h = match self.resolution {
            resolution::Resolution::EdgeLength(h) => h,
            resolution::Resolution::FromMesh | resolution::Resolution::Ladder { .. } => {
                return Err(NoSubstrate::NoEdgeLength);
            }
        };
        let kappa = self.bending_kappa().ok_or(NoSubstrate::NoBending)?;
        let adhesion = self
            .at_resolution(h)
            .adhesion_plane()
            .ok_or(NoSubstrate::NoPlaneAdhesion)?;
        Ok((adhesion, kappa))
    }

    /// Checks that need the whole scene.
    /// Known biases and slow paths of this scene's combination of settings,
    /// as sentences for the user (printed by `check` and, before it starts,
    /// `run`; kept in summary.json).
    /// Empty when none applies.
    pub fn cautions(&self) -> Vec<String> {
        let mut out = Vec::new();
        let piecewise_vin = self.energy.iter().any(|t| {
            matches!(t, EnergyTerm::Vin(p) if p.form == crate::params::VinForm::PiecewiseLinear)
        });
        let geometric = self.remesh.mode == crate::params::RemeshMode::Geometric;
        if !self.dynamics.method.is_overdamped() && piecewise_vin && !geometric {
            out.push(
                "the minimiser with V_in's piecewise-linear form: its chord slopes jump at every \
                 segment end, so the largest force stalls far above a small tolerance (measured \
                 on the minimiser RBC: 0.10 Ē/l̄ after 20000 iterations); declare \
                 `Vin(form: Exact)`"
                    .to_string(),
            );
        }
        if let (Some(m), crate::scene::resolution::Resolution::EdgeLength(h)) =
            (self.membrane.generated_edge_length(), self.resolution)
            && self.remesh.mode != crate::params::RemeshMode::Off
            && !(1.0 / EDGE_MISMATCH..=EDGE_MISMATCH).contains(&(m / h))
        {
            out.push(format!(
                "the membrane is generated with edges of {m} l̄ and `resolution: EdgeLength({h})` \
                 asks for {h} l̄: the remeshing then splits or merges nearly every edge, one event \
                 at a time, before anything else, and the paper's relaxed events fail on a mesh \
                 stretched throughout (measured on scenes/proteins/tube_sorting.ron at h = 0.7: \
                 100 iterations in 169 s, 6400 splits failed and none done); give the membrane \
                 `mean_edge_length: {h}`"
            ));
        }
        if self.dynamics.temperature > 0.0 && self.remesh.mode != crate::params::RemeshMode::Off {
            out.push(
                "thermal noise with split/merge remeshing: its events are not \
                 detailed-balanced moves, so averages at k_BT > 0 are biased (measured: the \
                 flicker spectrum's κ 32 % low, docs/thermal.md); for a fluid membrane \
                 in equilibrium use `edge_flips` with remeshing off"
                    .to_string(),
            );
        }
        out
    }
}
