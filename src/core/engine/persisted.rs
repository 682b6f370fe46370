//! Resources that carry a run's state from one tick to the next and so go
//! into a checkpoint (`remembrane::io::checkpoint`).
//!
//! Most resources are either set up by the scene (parameters, the V_in
//! segmentation) or recomputed every tick (forces, face geometry, the dense
//! mirrors); rebuilding the scene restores them. The few that persist (the
//! clock, the last time step, the abnormal edges handed to the next tick,
//! the remeshing statistics) are declared by the plugin that inserts them
//! with [`crate::engine::simulation::SimBuilder::persist_resource`]; a user's plugin
//! does the same for its own stateful resources.

use crate::engine::error::StateError;
use crate::engine::resources::{FetchError, Resource, Resources};
use serde::Serialize;
use serde::de::DeserializeOwned;
use std::collections::BTreeMap;

/// Why a run's persisted state (its resources, its force terms' and its
/// systems' states) could not be saved into a checkpoint or restored from
/// one.
#[derive(Debug, thiserror::Error)]
pub enum PersistError {
    /// A persisted resource could not be fetched.
    #[error(transparent)]
    Fetch(#[from] FetchError),
    /// A value does not serialize, or a saved value does not deserialize.
    #[error(transparent)]
    Json(#[from] serde_json::Error),
    /// A persisted resource's value could not be saved or restored.
    #[error("resource `{name}`: {source}")]
    Resource {
        /// The resource's type name.
        name: &'static str,
        /// What went wrong.
        source: Box<PersistError>,
    },
    /// An optional part's state could not be saved or restored.
    #[error("`{name}`: {source}")]
    Optional {
        /// The part's name (e.g. "force terms").
        name: &'static str,
        /// What went wrong.
        source: Box<PersistError>,
    },
    /// A persisted resource is not in the checkpoint.
    #[error("resource `{0}` is not in the checkpoint")]
    MissingResource(&'static str),
    /// The checkpoint holds a resource the scene does not persist.
    #[error("resource `{0}` is in the checkpoint but not in the scene")]
    UnknownResource(String),
    /// The named states are not a map.
    #[error("expected a map of named states")]
    NotAMap,
    /// A named state is for a part the scene does not have.
    #[error("`{0}` is not part of this scene")]
    UnknownPart(String),
    /// A named part could not take its state back.
    #[error("`{name}`: {source}")]
    Part {
        /// The part's name.
        name: String,
        /// Why.
        source: StateError,
    },
    /// The force terms' states could not be restored.
    #[error("force term {0}")]
    ForceTerm(Box<PersistError>),
    /// A system could not take its state back.
    #[error("system `{name}`: {source}")]
    System {
        /// The system.
        name: String,
        /// Why.
        source: StateError,
    },
    /// A system keeps state, but the checkpoint holds none for it.
    #[error("system `{0}` keeps state, but the checkpoint holds none for it")]
    MissingSystemState(String),
    /// The checkpoint holds the state of a system the scene does not have.
    #[error("the checkpoint holds the state of system `{0}`, which this scene does not have")]
    UnknownSystem(String),
}

type Save = fn(&Resources) -> Result<serde_json::Value, PersistError>;
type Restore = fn(&Resources, serde_json::Value) -> Result<(), PersistError>;

/// The persisted resources, by name.
#[derive(Default)]
pub struct PersistedResources {
    entries: Vec<(&'static str, Save, Restore)>,
    /// Entries saved only when they hold a state (not `null`), and restored
    /// only when the checkpoint holds one.
    optional: Vec<(&'static str, Save, Restore)>,
}

fn save<T: Resource + Serialize>(r: &Resources) -> Result<serde_json::Value, PersistError> {
    let value = r.get::<T>()?;
    Ok(serde_json::to_value(&*value)?)
}

fn restore<T: Resource + DeserializeOwned>(
    r: &Resources,
    value: serde_json::Value,
) -> Result<(), PersistError> {
    let new: T = serde_json::from_value(value)?;
    *r.get_mut::<T>()? = new;
    Ok(())
}

impl PersistedResources {
    /// Declares `T` persistent (once; later declarations are ignored).
    pub fn add<T: Resource + Serialize + DeserializeOwned>(&mut self) {
        let name = std::any::type_name::<T>();
        if self.entries.iter().all(|(n, ..)| *n != name) {
            self.entries.push((name, save::<T>, restore::<T>));
        }
    }

    /// Declares a part of a resource's state saved and restored by `save`
    /// and `restore` under `name` (once), present in a checkpoint only when
    /// `save` returns a value other than `null`: the force terms' own
    /// states ([`crate::engine::force::ForceBuffers`]).
    pub fn add_optional(&mut self, name: &'static str, save: Save, restore: Restore) {
        if self.optional.iter().all(|(n, ..)| *n != name) {
            self.optional.push((name, save, restore));
        }
    }

    /// Every persisted resource's value, by name.
    pub fn save(
        &self,
        resources: &Resources,
    ) -> Result<BTreeMap<String, serde_json::Value>, PersistError> {
        let mut saved = BTreeMap::new();
        for (name, save, _) in &self.entries {
            let value = save(resources).map_err(|e| PersistError::Resource {
                name,
                source: Box::new(e),
            })?;
            saved.insert(name.to_string(), value);
        }
        for (name, save, _) in &self.optional {
            let value = save(resources).map_err(|e| PersistError::Optional {
                name,
                source: Box::new(e),
            })?;
            if !value.is_null() {
                saved.insert(name.to_string(), value);
            }
        }
        Ok(saved)
    }

    /// Sets every persisted resource from `saved`, which must hold exactly
    /// the persisted resources.
    pub fn restore(
        &self,
        resources: &Resources,
        saved: &BTreeMap<String, serde_json::Value>,
    ) -> Result<(), PersistError> {
        for (name, _, restore) in &self.entries {
            let value = saved
                .get(*name)
                .ok_or(PersistError::MissingResource(name))?;
            restore(resources, value.clone()).map_err(|e| PersistError::Resource {
                name,
                source: Box::new(e),
            })?;
        }
        for (name, _, restore) in &self.optional {
            if let Some(value) = saved.get(*name) {
                restore(resources, value.clone()).map_err(|e| PersistError::Optional {
                    name,
                    source: Box::new(e),
                })?;
            }
        }
        if let Some(extra) = saved.keys().find(|k| {
            self.entries
                .iter()
                .chain(&self.optional)
                .all(|(n, ..)| n != k)
        }) {
            return Err(PersistError::UnknownResource(extra.clone()));
        }
        Ok(())
    }
}

/// The states of named parts (force terms, recorders) as one value: a map
/// from name to state over the parts that keep one, `None` if none does.
pub fn save_named<'a>(
    parts: impl IntoIterator<Item = (String, Option<serde_json::Value>)> + 'a,
) -> Option<serde_json::Value> {
    let map: serde_json::Map<String, serde_json::Value> = parts
        .into_iter()
        .filter_map(|(name, state)| Some((name, state?)))
        .collect();
    (!map.is_empty()).then_some(serde_json::Value::Object(map))
}

/// Gives named parts back what [`save_named`] saved: `restore(part, state)`
/// for each saved name, found by `name(part)`.
pub fn restore_named<T>(
    parts: &mut [T],
    name: impl Fn(usize, &T) -> String,
    mut restore: impl FnMut(&mut T, serde_json::Value) -> Result<(), StateError>,
    state: serde_json::Value,
) -> Result<(), PersistError> {
    let serde_json::Value::Object(map) = state else {
        return Err(PersistError::NotAMap);
    };
    for (key, value) in map {
        let part = parts
            .iter_mut()
            .enumerate()
            .find(|(i, p)| name(*i, p) == key)
            .map(|(_, p)| p)
            .ok_or_else(|| PersistError::UnknownPart(key.clone()))?;
        restore(part, value).map_err(|source| PersistError::Part { name: key, source })?;
    }
    Ok(())
}
