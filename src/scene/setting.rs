//! A change to a scene that sweeps, their conditions and protocol phases
//! apply ([`Setting`]), and what their files share: the RON options and the
//! rule for names that become directory names.

use crate::params::{BlockedRegion, DiffusionRate};
use crate::scene::{EnergyTerm, Scene};
use serde::{Deserialize, Serialize};

/// Why a [`Setting`] does not fit a scene.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum SettingError {
    /// The setting needs diffusion, which the scene does not declare.
    #[error("the scene declares no diffusion")]
    NoDiffusion,
    /// The setting needs a term the scene does not declare.
    #[error("the scene declares no {0} term")]
    NoTerm(&'static str),
    /// A reduced volume without exact constraints holding the area.
    #[error("a reduced volume needs exact constraints holding the area")]
    NoAreaConstraint,
    /// The value is out of range (the reason says which and why).
    #[error("{0}")]
    Invalid(String),
}

impl From<String> for SettingError {
    fn from(reason: String) -> Self {
        SettingError::Invalid(reason)
    }
}

/// A change to a scene.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum Setting {
    /// Finite diffusion rate k_d (the scene must declare diffusion).
    DiffusionRate(f64),
    /// Instant equilibration (k_d = ∞).
    DiffusionInstant,
    /// Diffusion barrier regions (empty: none).
    Barrier(Vec<BlockedRegion>),
    /// A_t of the local tension term (l̄²).
    LocalTensionTarget(f64),
    /// k_V of the volume term (Ē/l̄⁶).
    VolumeStrength(f64),
    /// Bending rigidity κ (Ē).
    Kappa(f64),
    /// Reduced volume v held exactly by the constraints (`constraints.volume:
    /// Reduced(v)`; the scene must hold the area, 0 < v ≤ 1).
    ReducedVolume(f64),
    /// Spring constant of every control point (Ē/l̄²).
    SpringStiffness(f64),
    /// Iterations of the run.
    Iterations(u64),
    /// Simulated duration of the run (s).
    Duration(f64),
    /// Target edge length h of the mesh scale (`resolution: EdgeLength(h)`,
    /// l̄; every mesh-scale length follows it).
    EdgeLength(f64),
    /// Any numeric parameter by its dotted path, as the Python package's
    /// keyword overrides name it ([`crate::scene::overrides`]): e.g.
    /// `Parameter(path: "species.species.0.curvature_coupling", value: 2.0)`
    /// or `Parameter(path: "energy.Bending.kappa", value: 2.0)`. The changed
    /// scene is validated again, as a file would be.
    Parameter {
        /// The parameter's dotted path.
        path: String,
        /// Its value (in the parameter's own units).
        value: f64,
    },
}

impl Setting {
    /// Applies the setting; the error says why it does not fit the scene.
    pub fn apply(&self, scene: &mut Scene) -> Result<(), SettingError> {
        let no_term = SettingError::NoTerm;
        match self {
            Setting::DiffusionRate(k) => {
                let d = scene.diffusion.as_mut().ok_or(SettingError::NoDiffusion)?;
                if !(k.is_finite() && *k > 0.0 && *k <= 1.0) {
                    return Err(format!("k_d must be in (0, 1] (got {k})").into());
                }
                d.rate = DiffusionRate::Finite(*k);
            }
            Setting::DiffusionInstant => {
                let d = scene.diffusion.as_mut().ok_or(SettingError::NoDiffusion)?;
                d.rate = DiffusionRate::Instant;
            }
            Setting::Barrier(regions) => {
                let d = scene.diffusion.as_mut().ok_or(SettingError::NoDiffusion)?;
                d.barrier = regions.clone();
            }
            Setting::LocalTensionTarget(a) => {
                let term = scene.energy.iter_mut().find_map(|t| match t {
                    EnergyTerm::LocalTension(p) => Some(p),
                    _ => None,
                });
                term.ok_or_else(|| no_term("LocalTension"))?.target_area =
                    crate::params::Target::Absolute(*a);
            }
            Setting::VolumeStrength(k) => {
                let term = scene.energy.iter_mut().find_map(|t| match t {
                    EnergyTerm::Volume(p) => Some(p),
                    _ => None,
                });
                term.ok_or_else(|| no_term("Volume"))?.k = *k;
            }
            Setting::Kappa(k) => {
                let term = scene.energy.iter_mut().find_map(|t| match t {
                    EnergyTerm::Bending(p) => Some(p),
                    _ => None,
                });
                term.ok_or_else(|| no_term("Bending"))?.kappa = *k;
            }
            Setting::SpringStiffness(k) => {
                for cp in &mut scene.control_points {
                    cp.stiffness = Some(*k);
                }
            }
            Setting::ReducedVolume(v) => {
                let c = scene
                    .constraints
                    .as_mut()
                    .filter(|c| c.area.is_some())
                    .ok_or(SettingError::NoAreaConstraint)?;
                if !(v.is_finite() && *v > 0.0 && *v <= 1.0) {
                    return Err(format!("a reduced volume must be in (0, 1] (got {v})").into());
                }
                c.volume = Some(crate::params::VolumeConstraint::Reduced(*v));
            }
            Setting::Iterations(n) => scene.dynamics.iterations = *n,
            Setting::Duration(t) => scene.dynamics.duration = Some(*t),
            Setting::EdgeLength(h) => {
                if !(h.is_finite() && *h > 0.0) {
                    return Err(format!("an edge length must be positive (got {h})").into());
                }
                scene.resolution = crate::scene::resolution::Resolution::EdgeLength(*h);
            }
            Setting::Parameter { path, value } => {
                let value = serde_json::Number::from_f64(*value)
                    .ok_or_else(|| format!("{path}: the value {value} is not finite"))?;
                let here = std::path::Path::new("");
                *scene = crate::scene::overrides::set_parameter(scene, here, path, value.into())
                    .map_err(|e| match e {
                        crate::scene::SceneError::Invalid { field, reason, .. } => {
                            format!("{field}: {reason}")
                        }
                        e => e.to_string(),
                    })?;
            }
        }
        Ok(())
    }

    /// The setting's value as a short label (directory names, tables).
    pub fn label(&self) -> String {
        match (self, self.value()) {
            (_, Some(v)) => format!("{v}"),
            (Setting::Barrier(r), None) if r.is_empty() => "none".into(),
            (Setting::Barrier(r), None) => format!("{}regions", r.len()),
            (_, None) => unreachable!("only barriers have no numeric value"),
        }
    }

    /// The setting's numeric value, if it has one (k_d = ∞ for instant
    /// diffusion).
    pub fn value(&self) -> Option<f64> {
        match self {
            Setting::DiffusionRate(v)
            | Setting::LocalTensionTarget(v)
            | Setting::VolumeStrength(v)
            | Setting::Kappa(v)
            | Setting::ReducedVolume(v)
            | Setting::SpringStiffness(v)
            | Setting::EdgeLength(v)
            | Setting::Duration(v)
            | Setting::Parameter { value: v, .. } => Some(*v),
            Setting::DiffusionInstant => Some(f64::INFINITY),
            Setting::Iterations(n) => Some(*n as f64),
            Setting::Barrier(_) => None,
        }
    }
}

/// A field of a sweep, protocol, diagram or study file that is invalid.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("field `{field}`: {reason}")]
pub struct FieldError {
    /// The field's dotted path.
    pub field: String,
    /// What is wrong.
    pub reason: String,
}

impl FieldError {
    /// Field `field` is invalid for `reason`.
    pub fn new(field: impl Into<String>, reason: impl Into<String>) -> Self {
        FieldError {
            field: field.into(),
            reason: reason.into(),
        }
    }
}

/// RON options of sweep, protocol and study files (`Some` implied,
/// newtype variants unwrapped), as for scenes.
pub(crate) fn ron_options() -> ron::Options {
    ron::Options::default()
        .with_default_extension(ron::extensions::Extensions::IMPLICIT_SOME)
        .with_default_extension(ron::extensions::Extensions::UNWRAP_VARIANT_NEWTYPES)
}

/// Whether `s` is a plain file-name component.
pub(crate) fn valid_name(s: &str) -> bool {
    !s.is_empty()
        && s.chars()
            .all(|c| c.is_ascii_alphanumeric() || matches!(c, '-' | '_' | '.'))
        && s != "."
        && s != ".."
}
