//! Docs that cannot drift: `scenes/reference.ron` documents every key of a
//! scene, and the crate map in `src/lib.rs` names every built-in system
//! and plugin.

use crate::common;
use remembrane::scene::Scene;
use serde::de::{self, Deserializer, Visitor};

/// The field names serde reads for `T` (a struct), as its derive lists them
/// to the deserializer: renames and all.
fn struct_fields<'de, T: serde::Deserialize<'de>>() -> &'static [&'static str] {
    struct Fields(std::cell::Cell<&'static [&'static str]>);
    #[derive(Debug)]
    struct Stop;
    impl std::fmt::Display for Stop {
        fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
            f.write_str("stop")
        }
    }
    impl std::error::Error for Stop {}
    impl de::Error for Stop {
        fn custom<M: std::fmt::Display>(_: M) -> Self {
            Stop
        }
    }
    impl<'de> Deserializer<'de> for &Fields {
        type Error = Stop;
        fn deserialize_any<V: Visitor<'de>>(self, _: V) -> Result<V::Value, Stop> {
            Err(Stop)
        }
        fn deserialize_struct<V: Visitor<'de>>(
            self,
            _: &'static str,
            fields: &'static [&'static str],
            _: V,
        ) -> Result<V::Value, Stop> {
            self.0.set(fields);
            Err(Stop)
        }
        serde::forward_to_deserialize_any! {
            bool i8 i16 i32 i64 i128 u8 u16 u32 u64 u128 f32 f64 char str string
            bytes byte_buf option unit unit_struct newtype_struct seq tuple
            tuple_struct map enum identifier ignored_any
        }
    }
    let fields = Fields(std::cell::Cell::new(&[]));
    let _ = T::deserialize(&fields);
    fields.0.get()
}

/// Whether `text` has `key:` at the start of a line (after indentation),
/// as a key or in a comment that shows it (`//   key: ...`).
fn documents(text: &str, key: &str) -> bool {
    text.lines().any(|line| {
        let line = line.trim_start();
        let line = line.strip_prefix("//").map_or(line, str::trim_start);
        line.strip_prefix(key)
            .is_some_and(|rest| rest.starts_with(':'))
    })
}

/// Every field of [`Scene`] is a key of `scenes/reference.ron`, written or
/// shown in a comment where this scene cannot hold it.
#[test]
fn the_reference_scene_documents_every_scene_key() {
    let fields = struct_fields::<Scene>();
    assert!(fields.len() >= 20, "{fields:?}");
    let text = std::fs::read_to_string(common::scene("reference.ron")).unwrap();
    let missing: Vec<_> = fields.iter().filter(|f| !documents(&text, f)).collect();
    assert!(
        missing.is_empty(),
        "scenes/reference.ron does not document {missing:?}"
    );
    // The file is a scene that loads.
    Scene::load(&common::scene("reference.ron")).unwrap();
}

/// The names `pub mod NAME;` or `pub fn NAME(` declares in `text`.
fn declared(text: &str, prefix: &str, end: char) -> Vec<String> {
    text.lines()
        .filter_map(|l| l.strip_prefix(prefix))
        .filter_map(|rest| rest.split(end).next())
        .map(str::to_string)
        .collect()
}

/// Every built-in system (a module of `systems/`) and every built-in plugin
/// (a `pub fn` of `src/scene/plugins.rs`) is named in the crate map.
#[test]
fn the_crate_map_names_every_system_and_plugin() {
    let map = std::fs::read_to_string(common::repo("src/lib.rs")).unwrap();
    let systems = declared(
        &std::fs::read_to_string(common::repo("systems/lib.rs")).unwrap(),
        "pub mod ",
        ';',
    );
    let plugins = declared(
        &std::fs::read_to_string(common::repo("src/scene/plugins.rs")).unwrap(),
        "pub fn ",
        '(',
    );
    assert!(
        systems.len() >= 19 && plugins.len() >= 10,
        "{systems:?} {plugins:?}"
    );
    let missing: Vec<_> = systems
        .iter()
        .chain(&plugins)
        .filter(|name| !map.contains(&format!("`{name}`")))
        .collect();
    assert!(missing.is_empty(), "src/lib.rs does not name {missing:?}");
}
