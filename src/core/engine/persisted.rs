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

use crate::engine::resources::{Resource, Resources};
use serde::Serialize;
use serde::de::DeserializeOwned;
use std::collections::BTreeMap;

type Save = fn(&Resources) -> Result<serde_json::Value, String>;
type Restore = fn(&Resources, serde_json::Value) -> Result<(), String>;

/// The persisted resources, by name.
#[derive(Default)]
pub struct PersistedResources {
    entries: Vec<(&'static str, Save, Restore)>,
    /// Entries saved only when they hold a state (not `null`), and restored
    /// only when the checkpoint holds one.
    optional: Vec<(&'static str, Save, Restore)>,
}

fn save<T: Resource + Serialize>(r: &Resources) -> Result<serde_json::Value, String> {
    let value = r.get::<T>().map_err(|e| e.to_string())?;
    serde_json::to_value(&*value).map_err(|e| e.to_string())
}

fn restore<T: Resource + DeserializeOwned>(
    r: &Resources,
    value: serde_json::Value,
) -> Result<(), String> {
    let new: T = serde_json::from_value(value).map_err(|e| e.to_string())?;
    *r.get_mut::<T>().map_err(|e| e.to_string())? = new;
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
    ) -> Result<BTreeMap<String, serde_json::Value>, String> {
        let mut saved = BTreeMap::new();
        for (name, save, _) in &self.entries {
            let value = save(resources).map_err(|e| format!("resource `{name}`: {e}"))?;
            saved.insert(name.to_string(), value);
        }
        for (name, save, _) in &self.optional {
            let value = save(resources).map_err(|e| format!("`{name}`: {e}"))?;
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
    ) -> Result<(), String> {
        for (name, _, restore) in &self.entries {
            let value = saved
                .get(*name)
                .ok_or_else(|| format!("resource `{name}` is not in the checkpoint"))?;
            restore(resources, value.clone()).map_err(|e| format!("resource `{name}`: {e}"))?;
        }
        for (name, _, restore) in &self.optional {
            if let Some(value) = saved.get(*name) {
                restore(resources, value.clone()).map_err(|e| format!("`{name}`: {e}"))?;
            }
        }
        if let Some(extra) = saved.keys().find(|k| {
            self.entries
                .iter()
                .chain(&self.optional)
                .all(|(n, ..)| n != k)
        }) {
            return Err(format!(
                "resource `{extra}` is in the checkpoint but not in the scene"
            ));
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
    mut restore: impl FnMut(&mut T, serde_json::Value) -> Result<(), crate::engine::error::StateError>,
    state: serde_json::Value,
) -> Result<(), String> {
    let serde_json::Value::Object(map) = state else {
        return Err("expected a map of named states".into());
    };
    for (key, value) in map {
        let part = parts
            .iter_mut()
            .enumerate()
            .find(|(i, p)| name(*i, p) == key)
            .map(|(_, p)| p)
            .ok_or_else(|| format!("`{key}` is not part of this scene"))?;
        restore(part, value).map_err(|e| format!("`{key}`: {e}"))?;
    }
    Ok(())
}
