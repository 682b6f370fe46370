//! `Custom(...)` entries of a scene: a plugin named in `energy` or
//! `systems`, resolved through the active [`crate::scene::registry::PluginRegistry`]
//! while the scene is parsed (see that module).

use crate::engine::schedule::Stage;
use crate::scene::registry::{PluginEntry, PluginKind, resolve};
use serde::de::{self, DeserializeSeed, MapAccess, Visitor};
use serde::{Deserialize, Deserializer, Serialize};
use std::sync::Arc;

/// A plugin declared in a scene, its parameters checked against the
/// plugin's own type.
#[derive(Clone, Serialize)]
pub struct PluginDecl {
    /// The registered name.
    pub name: String,
    /// The stage (systems only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub stage: Option<Stage>,
    /// The validated parameters as canonical RON.
    pub params: String,
    #[serde(skip)]
    entry: Option<Arc<PluginEntry>>,
}

impl PluginDecl {
    /// The resolved plugin.
    pub fn entry(&self) -> Option<&Arc<PluginEntry>> {
        self.entry.as_ref()
    }
}

impl PartialEq for PluginDecl {
    fn eq(&self, other: &Self) -> bool {
        (&self.name, self.stage, &self.params) == (&other.name, other.stage, &other.params)
    }
}

impl std::fmt::Debug for PluginDecl {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self.stage {
            // Inside its variant's parentheses: `Custom(name: .., params: ..)`.
            Some(stage) => write!(
                f,
                "name: {:?}, stage: {}, params: {}",
                self.name,
                stage.name(),
                self.params
            ),
            None => write!(f, "name: {:?}, params: {}", self.name, self.params),
        }
    }
}

/// An energy-term plugin: `Custom(name: "...", params: (...))`.
#[derive(Clone, PartialEq, Serialize)]
pub struct TermPlugin(pub PluginDecl);

/// A system plugin: `Custom(name: "...", stage: Observe, params: (...))`.
#[derive(Clone, PartialEq, Serialize)]
pub struct SystemPlugin(pub PluginDecl);

impl std::fmt::Debug for TermPlugin {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        self.0.fmt(f)
    }
}

impl std::fmt::Debug for SystemPlugin {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        self.0.fmt(f)
    }
}

impl<'de> Deserialize<'de> for TermPlugin {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        d.deserialize_struct("Custom", &["name", "params"], DeclVisitor(PluginKind::Term))
            .map(TermPlugin)
    }
}

impl<'de> Deserialize<'de> for SystemPlugin {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        d.deserialize_struct(
            "Custom",
            &["name", "stage", "params"],
            DeclVisitor(PluginKind::System),
        )
        .map(SystemPlugin)
    }
}

#[derive(Deserialize)]
#[serde(field_identifier, rename_all = "lowercase")]
enum Field {
    Name,
    Stage,
    Params,
}

struct DeclVisitor(PluginKind);

impl<'de> Visitor<'de> for DeclVisitor {
    type Value = PluginDecl;

    fn expecting(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("a plugin declaration Custom(name: \"...\", params: (...))")
    }

    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<PluginDecl, A::Error> {
        let mut name: Option<(String, Arc<PluginEntry>)> = None;
        let mut stage = None;
        let mut params = None;
        while let Some(key) = map.next_key::<Field>()? {
            match key {
                Field::Name => name = Some(map.next_value_seed(NameSeed(self.0))?),
                Field::Stage if self.0 == PluginKind::System => {
                    stage = Some(map.next_value::<Stage>()?)
                }
                Field::Stage => {
                    return Err(de::Error::custom(
                        "`stage` belongs to system plugins (`systems: [...]`), not energy terms",
                    ));
                }
                Field::Params => {
                    let (_, entry) = name
                        .as_ref()
                        .ok_or_else(|| de::Error::custom("`name` must come before `params`"))?;
                    params = Some(map.next_value_seed(ParamsSeed(entry.clone()))?);
                }
            }
        }
        let (name, entry) = name.ok_or_else(|| de::Error::missing_field("name"))?;
        if self.0 == PluginKind::System && stage.is_none() {
            return Err(de::Error::missing_field("stage"));
        }
        let params = match params {
            Some(p) => p,
            // No `params`: the plugin's type must accept `()`.
            None => {
                let mut unit = ron::Deserializer::from_str("()").map_err(de::Error::custom)?;
                let mut erased = <dyn erased_serde::Deserializer>::erase(&mut unit);
                entry
                    .validate(&mut erased)
                    .map_err(|e| de::Error::custom(format_args!("missing field `params` ({e})")))?
            }
        };
        Ok(PluginDecl {
            name,
            stage,
            params,
            entry: Some(entry),
        })
    }
}

struct NameSeed(PluginKind);

impl<'de> DeserializeSeed<'de> for NameSeed {
    type Value = (String, Arc<PluginEntry>);

    fn deserialize<D: Deserializer<'de>>(self, d: D) -> Result<Self::Value, D::Error> {
        let name = String::deserialize(d)?;
        let entry = resolve(self.0, &name).map_err(de::Error::custom)?;
        Ok((name, entry))
    }
}

struct ParamsSeed(Arc<PluginEntry>);

impl<'de> DeserializeSeed<'de> for ParamsSeed {
    type Value = String;

    fn deserialize<D: Deserializer<'de>>(self, d: D) -> Result<String, D::Error> {
        let mut erased = <dyn erased_serde::Deserializer>::erase(d);
        self.0.validate(&mut erased).map_err(de::Error::custom)
    }
}
