//! Plugins that scene files name: `energy: [..., Custom(name: "bar_domain",
//! params: (...))]` and `systems: [Custom(name: "...", stage: Observe,
//! params: (...))]`.
//!
//! A [`PluginRegistry`] maps each name to the plugin's parameter type and a
//! function that registers it on a [`SimBuilder`]. While a scene is parsed,
//! a `Custom` entry's name is looked up and its `params` are deserialized
//! into the plugin's own type, straight from the scene text, so an unknown
//! name or a bad parameter is reported as `FILE:LINE:COL: field ...: reason`
//! exactly like a built-in term's. The validated parameters are kept as
//! canonical RON and turned into the plugin's type again when the scene is
//! built.
//!
//! [`crate::cli::main_with`] installs a registry as the process default, so
//! every command (run, check, energy, compare, sweep) resolves the same
//! plugins; [`crate::scene::Scene::from_ron_str_with`] takes one explicitly.

use crate::engine::schedule::Stage;
use crate::engine::simulation::{BuildError, SimBuilder};
use serde::Serialize;
use serde::de::DeserializeOwned;
use std::collections::BTreeMap;
use std::sync::{Arc, RwLock};

type Validate = dyn Fn(&mut dyn erased_serde::Deserializer<'_>) -> Result<String, erased_serde::Error>
    + Send
    + Sync;
type Build = dyn Fn(&str, Option<Stage>, &mut SimBuilder) -> Result<(), BuildError> + Send + Sync;

/// One registered plugin: how to validate its parameters and how to add it.
pub struct PluginEntry {
    name: String,
    validate: Box<Validate>,
    build: Box<Build>,
}

impl PluginEntry {
    /// The plugin's name.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Deserializes and checks parameters; returns them as canonical RON.
    pub(crate) fn validate(
        &self,
        de: &mut dyn erased_serde::Deserializer<'_>,
    ) -> Result<String, erased_serde::Error> {
        (self.validate)(de)
    }

    /// Adds the plugin with canonical parameters `params` (from
    /// `PluginEntry::validate`) to `builder`; `stage` for systems.
    pub fn build(
        &self,
        params: &str,
        stage: Option<Stage>,
        builder: &mut SimBuilder,
    ) -> Result<(), BuildError> {
        (self.build)(params, stage, builder)
    }
}

impl std::fmt::Debug for PluginEntry {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "PluginEntry({})", self.name)
    }
}

/// Whether a plugin adds an energy term or a system.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PluginKind {
    /// Named in `energy: [Custom(..)]`.
    Term,
    /// Named in `systems: [Custom(..)]`.
    System,
}

/// Named plugins a scene may declare.
#[derive(Clone, Default)]
pub struct PluginRegistry {
    terms: BTreeMap<String, Arc<PluginEntry>>,
    systems: BTreeMap<String, Arc<PluginEntry>>,
}

impl std::fmt::Debug for PluginRegistry {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("PluginRegistry")
            .field("terms", &self.terms.keys().collect::<Vec<_>>())
            .field("systems", &self.systems.keys().collect::<Vec<_>>())
            .finish()
    }
}

fn entry<P, F>(name: &str, build: F) -> Arc<PluginEntry>
where
    P: DeserializeOwned + Serialize + 'static,
    F: Fn(P, Option<Stage>, &mut SimBuilder) -> Result<(), BuildError> + Send + Sync + 'static,
{
    let label = name.to_string();
    Arc::new(PluginEntry {
        name: name.to_string(),
        validate: Box::new(|de| {
            let params: P = erased_serde::deserialize(de)?;
            ron::to_string(&params).map_err(serde::de::Error::custom)
        }),
        build: Box::new(move |text, stage, builder| {
            let params: P = ron::from_str(text).map_err(|e| BuildError::Invalid {
                field: format!("{label}.params"),
                reason: e.to_string(),
            })?;
            build(params, stage, builder)
        }),
    })
}

impl PluginRegistry {
    /// An empty registry (built-in terms need no registration: they are the
    /// scene format's own variants).
    pub fn new() -> Self {
        Self::default()
    }

    /// Registers an energy-term plugin named `name` with parameters `P`
    /// (use `#[serde(deny_unknown_fields)]` for strict checking); `build`
    /// registers it on the builder, typically with
    /// [`SimBuilder::add_force_term`].
    pub fn register_term<P, F>(&mut self, name: &str, build: F) -> &mut Self
    where
        P: DeserializeOwned + Serialize + 'static,
        F: Fn(P, &mut SimBuilder) -> Result<(), BuildError> + Send + Sync + 'static,
    {
        let e = entry(name, move |p: P, _, b: &mut SimBuilder| build(p, b));
        self.terms.insert(name.to_string(), e);
        self
    }

    /// Registers a system plugin named `name` with parameters `P`; `build`
    /// receives the stage the scene puts it in.
    pub fn register_system<P, F>(&mut self, name: &str, build: F) -> &mut Self
    where
        P: DeserializeOwned + Serialize + 'static,
        F: Fn(P, Stage, &mut SimBuilder) -> Result<(), BuildError> + Send + Sync + 'static,
    {
        let label = name.to_string();
        let e = entry(
            name,
            move |p: P, stage: Option<Stage>, b: &mut SimBuilder| {
                let stage = stage.ok_or_else(|| BuildError::Invalid {
                    field: format!("{label}.stage"),
                    reason: "a system plugin needs a stage".into(),
                })?;
                build(p, stage, b)
            },
        );
        self.systems.insert(name.to_string(), e);
        self
    }

    /// The plugin of `kind` named `name`.
    pub fn get(&self, kind: PluginKind, name: &str) -> Option<Arc<PluginEntry>> {
        match kind {
            PluginKind::Term => self.terms.get(name),
            PluginKind::System => self.systems.get(name),
        }
        .cloned()
    }

    /// Names of the registered plugins of `kind`, sorted.
    pub fn names(&self, kind: PluginKind) -> Vec<String> {
        match kind {
            PluginKind::Term => self.terms.keys().cloned().collect(),
            PluginKind::System => self.systems.keys().cloned().collect(),
        }
    }

    /// Makes this registry the process default used by
    /// [`crate::scene::Scene::load`] (replacing any earlier one).
    pub fn install_as_default(self) {
        let mut d = DEFAULT.write().unwrap_or_else(|e| e.into_inner());
        *d = Some(self);
    }

    /// The process default registry (empty unless one was installed).
    pub fn default_registry() -> PluginRegistry {
        let d = DEFAULT.read().unwrap_or_else(|e| e.into_inner());
        d.clone().unwrap_or_default()
    }
}

static DEFAULT: RwLock<Option<PluginRegistry>> = RwLock::new(None);

thread_local! {
    /// The registry of the scene being parsed on this thread.
    static ACTIVE: std::cell::RefCell<Option<PluginRegistry>> = const { std::cell::RefCell::new(None) };
}

/// Runs `parse` with `registry` active for `Custom` entries on this thread.
pub(crate) fn with_active<T>(registry: &PluginRegistry, parse: impl FnOnce() -> T) -> T {
    let previous = ACTIVE.with(|a| a.replace(Some(registry.clone())));
    let result = parse();
    ACTIVE.with(|a| *a.borrow_mut() = previous);
    result
}

/// A plugin name that is not in the registry.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("unknown plugin \"{name}\" (registered: {registered})")]
pub struct UnknownPlugin {
    /// The name looked up.
    pub name: String,
    /// The registered names of its kind (comma separated, or "none").
    pub registered: String,
}

/// Looks `name` up in the active registry; the error lists what exists.
pub(crate) fn resolve(kind: PluginKind, name: &str) -> Result<Arc<PluginEntry>, UnknownPlugin> {
    ACTIVE.with(|a| {
        let active = a.borrow();
        let fallback;
        let registry = match active.as_ref() {
            Some(r) => r,
            None => {
                fallback = PluginRegistry::default_registry();
                &fallback
            }
        };
        registry.get(kind, name).ok_or_else(|| {
            let names = registry.names(kind);
            let registered = if names.is_empty() {
                "none".to_string()
            } else {
                names.join(", ")
            };
            UnknownPlugin {
                name: name.to_string(),
                registered,
            }
        })
    })
}
