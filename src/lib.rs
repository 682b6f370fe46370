//! remembrane: closed triangulated membranes moved by overdamped Langevin
//! dynamics under their free energy, with free-energy-controlled remeshing.

pub mod axisymmetric;
pub mod cell_list;
pub mod cli;
pub mod collect;
pub mod compare;
pub mod components;
pub mod constraint;
pub mod core_resources;
pub mod edge_flip;
pub mod edit;
pub mod energy;
pub mod error;
pub mod fluid;
pub mod geometry;
pub mod job_pool;
pub mod membrane;
pub mod mesh;
pub mod minimise;
pub mod output;
pub mod parallel;
pub mod topology;
pub mod topology_update;
pub mod world_snapshot;

/// Writes `bytes` to `path` atomically: a temporary file in the same folder,
/// then a rename, so readers never see a partial file.
pub fn atomic_write(path: &std::path::Path, bytes: &[u8]) -> std::io::Result<()> {
    atomic_write_with(path, |w| std::io::Write::write_all(w, bytes))
}

/// Writes `path` atomically from `write`, which streams into a buffered
/// temporary file in the same folder that is renamed to `path` once complete
/// (and removed if `write` fails), so a large file is never held in memory
/// whole and readers never see a partial one.
pub fn atomic_write_with<E: From<std::io::Error>>(
    path: &std::path::Path,
    write: impl FnOnce(&mut std::io::BufWriter<std::fs::File>) -> Result<(), E>,
) -> Result<(), E> {
    use std::io::Write;
    let dir = path
        .parent()
        .filter(|d| !d.as_os_str().is_empty())
        .unwrap_or(std::path::Path::new("."));
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let tmp = dir.join(format!(".{name}.{}.tmp", std::process::id()));
    let written = (|| {
        let mut file = std::io::BufWriter::new(std::fs::File::create(&tmp)?);
        write(&mut file)?;
        file.flush()?;
        std::fs::rename(&tmp, path)?;
        Ok(())
    })();
    if written.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    written
}

pub mod checkpoint;
pub mod fd;
pub mod force;
pub mod force_term_system;
pub mod params;
pub mod persisted;
pub mod protocol;

pub mod plot;
pub mod plugin_decl;
pub mod quality;
pub mod recorder;
pub mod registry;
pub mod relax;
pub mod remesh;
pub mod render;
pub mod report;
pub mod resolution;
pub mod resources;
pub mod rng;
pub mod run;
pub mod run_dir;
pub mod scene;
pub mod scene_override;
pub mod schedule;
pub mod setting;
pub mod shape;
pub mod shape_diagram;
pub mod simulation;
pub mod spectrum;
pub mod state;
pub mod study;
pub mod study_peer;
pub mod study_reference;
pub mod study_report;
pub mod sweep;
#[path = "../systems/mod.rs"]
pub mod systems;
pub mod timestep;
pub mod tube_radius;
pub mod validate;
pub mod vertex_field;

#[doc = include_str!("../README.md")]
#[cfg(doctest)]
pub struct ReadmeDoctests;
