//! Scene parameters: one serde struct per energy term ([`energy`]), the
//! dynamics and constraints ([`dynamics`]), remeshing ([`remesh`]), lipid
//! diffusion ([`diffusion`]), the membrane model ([`model`]) and an open
//! membrane's boundary conditions ([`boundary`]), each field
//! with its unit, default and meaning. Defaults are SPEC's as-run set
//! (natural units: energy Ē = 10 k_BT, length l̄ = 1 µm, time 1 s).

use serde::{Deserialize, Serialize};

pub mod boundary;
pub mod diffusion;
pub mod dynamics;
pub mod energy;
pub mod model;
pub mod remesh;
pub mod schedule;

pub use boundary::*;
pub use diffusion::*;
pub use dynamics::*;
pub use energy::*;
pub use model::*;
pub use remesh::*;

pub use crate::energy::vin::{VinForm, VinParams};

/// A target value: absolute, or a fraction of the initial mesh's value.
/// Either number must be finite and > 0.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "TargetSpec")]
pub enum Target {
    /// An absolute value (l̄³ for volume, l̄² for area).
    Absolute(f64),
    /// This fraction of the value of the initial mesh (e.g. 0.6 of its volume).
    OfInitial(f64),
}

/// Unvalidated form of [`Target`] as written in a scene.
#[derive(Deserialize)]
enum TargetSpec {
    Absolute(f64),
    OfInitial(f64),
}

impl TryFrom<TargetSpec> for Target {
    type Error = crate::util::validate::ValidationError;
    fn try_from(spec: TargetSpec) -> Result<Self, Self::Error> {
        let (t, v) = match spec {
            TargetSpec::Absolute(v) => (Target::Absolute(v), v),
            TargetSpec::OfInitial(v) => (Target::OfInitial(v), v),
        };
        if v.is_finite() && v > 0.0 {
            Ok(t)
        } else {
            Err(format!("target must be a finite number > 0 (got {v})").into())
        }
    }
}

impl Target {
    /// The target for an initial value `initial`.
    pub fn resolve(self, initial: f64) -> f64 {
        match self {
            Target::Absolute(v) => v,
            Target::OfInitial(f) => f * initial,
        }
    }

    /// The configured number (value or fraction).
    pub fn number(self) -> f64 {
        match self {
            Target::Absolute(v) | Target::OfInitial(v) => v,
        }
    }
}
