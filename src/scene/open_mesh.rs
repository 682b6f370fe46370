//! What a scene with an open membrane (boundary loops) may declare: every
//! energy term, constraint, remeshing and flip option that is not correct
//! on open meshes is refused here, at build time, naming the field, the
//! term and the reason (issue 32). What runs: the terms whose
//! `open_mesh_support` says so (V_in, bending in both forms, area, tension,
//! local tension, springs, self-avoidance, walls, adhesion), both membrane
//! models (the fluid model's projections are boundary-aware, see
//! `systems/fluid_projection.rs`), the dynamics and the minimiser, lipid diffusion, penalty smoothing (an average
//! over each vertex's ring, a boundary vertex's being its fan), and
//! split/merge remeshing (which keeps the held loops' vertices, see the
//! remesh system; a line tension follows its loop by the loop's vertices,
//! see `energy/line_tension.rs`).

use super::{Scene, SceneError, SystemDecl};
use std::path::Path;

impl Scene {
    /// Refuses what this scene declares that is not correct on its open
    /// membrane of `loops` boundary loops (reads the scene only).
    pub(super) fn refuse_on_open_mesh(
        &self,
        scene_path: &Path,
        loops: usize,
    ) -> Result<(), SceneError> {
        let refuse = |field: String, what: &str, reason: &str| SceneError::Invalid {
            path: scene_path.to_owned(),
            field,
            reason: format!(
                "{what} is refused on an open membrane ({loops} boundary loop{}): {reason}",
                if loops == 1 { "" } else { "s" }
            ),
        };
        for (i, term) in self.energy.iter().enumerate() {
            if let Err(reason) = term.open_mesh_support() {
                return Err(refuse(
                    format!("energy[{i}]"),
                    term.kind(),
                    &reason.to_string(),
                ));
            }
        }
        if let Some(c) = &self.constraints {
            if c.volume.is_some() {
                return Err(refuse(
                    "constraints.volume".into(),
                    "the volume constraint",
                    "an open mesh encloses no volume",
                ));
            }
            return Err(refuse(
                "constraints".into(),
                "the area constraint",
                "its projection moves every vertex, the boundary's included, and is not \
                 boundary-aware yet (use the Area penalty or a Tension term)",
            ));
        }
        if let Some((i, _)) = self
            .systems
            .iter()
            .enumerate()
            .find(|(_, s)| matches!(s, SystemDecl::Custom(_)))
        {
            return Err(refuse(
                format!("systems[{i}]"),
                "a plugin system",
                "plugin systems do not declare whether they are correct on open meshes",
            ));
        }
        Ok(())
    }
}
