//! A scene's `resolution: Ladder(refinements: k)` as a protocol: the
//! refinement ladder (continuation from coarse to fine, as in the Surface
//! Evolver) without writing one.
//!
//! Rung 0 runs the scene on its own mesh at h = 1 (`DIR/h1/`); rung r
//! splits every triangle of rung r − 1's final state into four at its
//! edges' midpoints and runs the scene at h = 1/2^r (`DIR/h1_2/`,
//! `DIR/h1_4/`, ...). Each rung is the phase a hand-written protocol would
//! declare as
//!
//! ```ron
//! (name: "h1_2", scene: "scene.ron", start: Previous, refine: 1, set: [EdgeLength(0.5)])
//! ```
//!
//! so a ladder run is that protocol's run, output for output: staged,
//! resumable, `protocol.json` with every rung's iterations and wall time.

use super::{LoadedProtocol, Phase, Protocol, ProtocolError, Start, check_phases};
use crate::scene::Scene;
use crate::scene::resolution::{Resolution, ladder_edge_length};
use crate::scene::setting::Setting;
use std::path::Path;

/// The directory name of rung `r`: `h1`, `h1_2`, `h1_4`, ...
pub fn rung_name(r: u32) -> String {
    if r == 0 {
        "h1".into()
    } else {
        format!("h1_{}", 1u64 << r)
    }
}

impl Protocol {
    /// The protocol the scene at `scene_path` (named `name`) runs as when
    /// its resolution is `Ladder(refinements)`: one phase per rung.
    pub fn ladder(scene_path: &Path, name: &str, refinements: u32) -> Protocol {
        let file = scene_path
            .file_name()
            .map_or_else(|| scene_path.to_path_buf(), Into::into);
        let phases = (0..=refinements)
            .map(|r| Phase {
                name: rung_name(r),
                scene: file.clone(),
                start: if r == 0 {
                    Start::Scene
                } else {
                    Start::Previous
                },
                iterations: None,
                duration: None,
                seed: None,
                set: vec![Setting::EdgeLength(ladder_edge_length(r))],
                refine: u32::from(r > 0),
            })
            .collect();
        Protocol {
            name: name.into(),
            description: format!(
                "the refinement ladder of {} to h = 1/{}",
                scene_path.display(),
                1u64 << refinements
            ),
            phases,
        }
    }
}

/// The ladder protocol of `scene` (read from `path`), checked, or `None`
/// when its resolution is not a ladder.
pub fn load_ladder(scene: &Scene, path: &Path) -> Option<Result<LoadedProtocol, ProtocolError>> {
    let Resolution::Ladder { refinements } = scene.resolution else {
        return None;
    };
    let name = crate::workflow::run::run_name(scene, path);
    let protocol = Protocol::ladder(path, &name, refinements);
    Some(
        check_phases(&protocol.phases, path, "resolution").map(|scenes| LoadedProtocol {
            path: path.to_owned(),
            protocol,
            scenes,
        }),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rungs_halve_the_edge_length_from_the_scene_s_own_mesh() {
        let p = Protocol::ladder(Path::new("scenes/fluid/cell.ron"), "cell", 2);
        let names: Vec<&str> = p.phases.iter().map(|q| q.name.as_str()).collect();
        assert_eq!(names, ["h1", "h1_2", "h1_4"]);
        assert_eq!(p.phases[0].start, Start::Scene);
        assert_eq!(p.phases[0].refine, 0);
        for (r, q) in p.phases.iter().enumerate().skip(1) {
            assert_eq!(q.start, Start::Previous);
            assert_eq!(q.refine, 1);
            assert_eq!(q.set, [Setting::EdgeLength(0.5f64.powi(r as i32))]);
            assert_eq!(q.scene, Path::new("cell.ron"));
        }
    }
}
