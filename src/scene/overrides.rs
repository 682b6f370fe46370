//! Setting one scene parameter by its dotted path, e.g.
//! `dynamics.temperature`, `energy.Bending.kappa` or `membrane.Icosphere.level`
//! (used by the Python package's `Scene.load(path, dynamics__temperature=0.1)`).
//!
//! A path walks the scene as it is written in RON: a segment names a field
//! of a struct, the variant of an enum value (`membrane.Icosphere`), or, in a
//! list, an index (`control_points.0.stiffness`) or the variant of the one
//! element that has it (`energy.Bending`). The changed scene is parsed and
//! validated again, so a bad value is rejected exactly as in a file.

use crate::scene::{Scene, SceneError};
use serde_json::Value;
use std::path::Path;

/// Returns `scene` with the parameter at `path` set to `value`; the error
/// names `scene_path`, the parameter path and the reason.
pub fn set_parameter(
    scene: &Scene,
    scene_path: &Path,
    path: &str,
    value: Value,
) -> Result<Scene, SceneError> {
    set_parameters(scene, scene_path, &[(path.to_string(), value)])
}

/// Returns `scene` with every `(path, value)` change applied, then parsed
/// and validated once, so that changes valid only together (e.g. a term
/// and the field it needs) are accepted.
pub fn set_parameters(
    scene: &Scene,
    scene_path: &Path,
    changes: &[(String, Value)],
) -> Result<Scene, SceneError> {
    let invalid = |field: &str, reason: String| SceneError::Invalid {
        path: scene_path.to_owned(),
        field: field.to_string(),
        reason,
    };
    let joined: Vec<&str> = changes.iter().map(|(p, _)| p.as_str()).collect();
    let all = joined.join(", ");
    let mut tree = serde_json::to_value(scene).map_err(|e| invalid(&all, e.to_string()))?;
    for (path, value) in changes {
        let mut node = &mut tree;
        for segment in path.split('.') {
            node = step(node, segment).map_err(|r| invalid(path, r.to_string()))?;
        }
        *node = value.clone();
    }
    let changed: Scene = crate::scene::registry::with_active(
        &crate::scene::registry::PluginRegistry::default_registry(),
        || serde_path_to_error::deserialize(tree),
    )
    .map_err(|e| {
        let inner = e.path().to_string();
        let reason = e.into_inner().to_string();
        match changes {
            [(path, _)] if inner == *path || inner == "." => invalid(path, reason),
            [(path, _)] => invalid(path, format!("at `{inner}`: {reason}")),
            _ => invalid(&inner, reason),
        }
    })?;
    changed.validate(scene_path)?;
    Ok(changed)
}

/// Why a segment of a parameter path names nothing.
#[derive(Debug, thiserror::Error)]
enum StepError {
    /// An object without that key.
    #[error("no field or variant `{segment}` here (has: {known})")]
    NoField { segment: String, known: String },
    /// An index past the list's end.
    #[error("index {index} is past the list's {len} elements")]
    PastEnd { index: usize, len: usize },
    /// A list without an element of that variant.
    #[error("the list has no `{0}` element")]
    NoElement(String),
    /// A list with several elements of that variant.
    #[error("the list has {count} `{segment}` elements; use an index")]
    Ambiguous { segment: String, count: usize },
    /// Inside `null`.
    #[error("`{0}` is inside a value that is not set; set the whole value instead")]
    Unset(String),
    /// Inside a number, string or boolean.
    #[error("`{0}` is inside a plain value")]
    Plain(String),
}

/// The child of `node` that `segment` names.
fn step<'a>(node: &'a mut Value, segment: &str) -> Result<&'a mut Value, StepError> {
    match node {
        Value::Object(map) => {
            if !map.contains_key(segment) {
                let known: Vec<&str> = map.keys().map(String::as_str).collect();
                return Err(StepError::NoField {
                    segment: segment.to_string(),
                    known: known.join(", "),
                });
            }
            Ok(map.get_mut(segment).expect("checked"))
        }
        Value::Array(items) => {
            if let Ok(index) = segment.parse::<usize>() {
                let len = items.len();
                return items
                    .get_mut(index)
                    .ok_or(StepError::PastEnd { index, len });
            }
            let tagged = |v: &Value| v.as_object().is_some_and(|o| o.contains_key(segment));
            match items.iter().filter(|v| tagged(v)).count() {
                1 => Ok(items
                    .iter_mut()
                    .find_map(|v| v.as_object_mut().and_then(|o| o.get_mut(segment)))
                    .expect("counted")),
                0 => Err(StepError::NoElement(segment.to_string())),
                n => Err(StepError::Ambiguous {
                    segment: segment.to_string(),
                    count: n,
                }),
            }
        }
        Value::Null => Err(StepError::Unset(segment.to_string())),
        _ => Err(StepError::Plain(segment.to_string())),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rbc() -> (Scene, &'static Path) {
        let path = Path::new("scenes/red_blood_cell.ron");
        (Scene::load(path).unwrap(), path)
    }

    #[test]
    fn every_bundled_scene_survives_json_and_ron_round_trips() {
        for entry in std::fs::read_dir("scenes").unwrap() {
            let path = entry.unwrap().path();
            if path.extension().is_none_or(|e| e != "ron") {
                continue;
            }
            let Ok(scene) = Scene::load(&path) else {
                continue; // sweep files share the folder
            };
            let tree = serde_json::to_value(&scene).unwrap();
            let back: Scene = serde_json::from_value(tree).unwrap();
            assert_eq!(back, scene, "{}", path.display());
            let text = scene.to_ron_string().unwrap();
            let back = Scene::from_ron_str(&text, &path).unwrap();
            assert_eq!(back, scene, "{}", path.display());
        }
    }

    #[test]
    fn sets_struct_fields_variants_and_list_elements() {
        let (scene, path) = rbc();
        let s = set_parameter(&scene, path, "dynamics.temperature", Value::from(0.05)).unwrap();
        assert_eq!(s.dynamics.temperature, 0.05);
        let s = set_parameter(&s, path, "energy.Bending.kappa", Value::from(2.5)).unwrap();
        let kappa = s.energy.iter().find_map(|t| match t {
            crate::scene::EnergyTerm::Bending(p) => Some(p.kappa),
            _ => None,
        });
        assert_eq!(kappa, Some(2.5));
        let s = set_parameter(&s, path, "membrane.Icosphere.level", Value::from(2)).unwrap();
        assert!(matches!(
            s.membrane,
            crate::scene::MembraneSource::Icosphere { level: 2, .. }
        ));
        // Nothing else changed.
        let back = set_parameter(
            &s,
            path,
            "dynamics.temperature",
            Value::from(scene.dynamics.temperature),
        )
        .unwrap();
        assert_ne!(back, scene);
    }

    #[test]
    fn bad_paths_and_values_name_the_parameter() {
        let (scene, path) = rbc();
        let e = set_parameter(&scene, path, "dynamics.temperatur", Value::from(1.0)).unwrap_err();
        let text = e.to_string();
        assert!(text.contains("field `dynamics.temperatur`"), "{text}");
        assert!(text.contains("no field or variant `temperatur`"), "{text}");
        let e = set_parameter(&scene, path, "energy.Bending.kappa", Value::from(-1.0))
            .unwrap_err()
            .to_string();
        assert!(e.contains("energy.Bending.kappa"), "{e}");
        let e = set_parameter(&scene, path, "energy.Nope", Value::from(1.0))
            .unwrap_err()
            .to_string();
        assert!(e.contains("no `Nope` element"), "{e}");
    }
}
