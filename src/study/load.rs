//! Reading and checking a study file ([`Study::load`]): every error names
//! the file and the field.

use super::{Case, Problem, Reference, Resolution, Rung, RungStart, Study, StudyError, start_dir};
use crate::scene::Scene;
use crate::scene::setting::{FieldError, valid_name};
use std::collections::HashSet;
use std::path::Path;

impl Study {
    /// Reads and checks a study file: every problem's scene loads, every
    /// rung's settings apply, labels are unique directory names, `quick`
    /// indices exist, and `FinestRung` problems give every rung an `h`.
    pub fn load(path: &Path) -> Result<(Study, Vec<Case>), StudyError> {
        let bad = |reason: String| StudyError::File {
            path: path.to_owned(),
            reason,
        };
        let text = std::fs::read_to_string(path).map_err(|e| bad(format!("cannot read: {e}")))?;
        let study: Study = crate::scene::setting::ron_options()
            .from_str(&text)
            .map_err(|e| {
                bad(format!(
                    "{}:{}: {}",
                    e.span.start.line, e.span.start.col, e.code
                ))
            })?;
        study
            .check_name_and_peers()
            .map_err(|e| bad(e.to_string()))?;
        let base = path.parent().unwrap_or(Path::new("."));
        let mut cases = Vec::new();
        let mut names = HashSet::new();
        for (p, problem) in study.problems.iter().enumerate() {
            problem
                .check(p, &mut names)
                .map_err(|e| bad(e.to_string()))?;
            problem
                .push_cases(p, base, &mut cases)
                .map_err(|e| bad(e.to_string()))?;
        }
        Ok((study, cases))
    }

    /// Checks the study's name and peers, and that it declares a problem.
    fn check_name_and_peers(&self) -> Result<(), FieldError> {
        if !valid_name(&self.name) {
            return Err(FieldError::new(
                "name",
                format!("`{}` must be a plain directory name", self.name),
            ));
        }
        for (k, peer) in self.peers.iter().enumerate() {
            if !valid_name(&peer.name) || self.peers[..k].iter().any(|o| o.name == peer.name) {
                return Err(FieldError::new(
                    format!("peers[{k}].name"),
                    format!("`{}` must be a unique plain directory name", peer.name),
                ));
            }
            if peer.command.is_empty() {
                return Err(FieldError::new(
                    format!("peers[{k}].command"),
                    "names no program",
                ));
            }
        }
        if self.problems.is_empty() {
            return Err(FieldError::new("problems", "the study declares no problem"));
        }
        Ok(())
    }
}

/// The path of field `f` of problem `p`, for messages.
fn field(p: usize, f: &str) -> String {
    format!("problems[{p}].{f}")
}

/// Why a problem of a study file is invalid.
#[derive(Debug, thiserror::Error)]
enum ProblemError {
    /// A field is invalid.
    #[error(transparent)]
    Field(#[from] FieldError),
    /// A rung starts from a state refined more than 3 times.
    #[error("field `{start}`.refine: must be at most 3 (got {refine})")]
    Refine {
        /// The rung's `start` field.
        start: String,
        /// Its refinement.
        refine: u32,
    },
}

/// Why a problem's reference cannot be computed for its scene.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
struct ReferenceUnsupported(&'static str);

impl Problem {
    /// Checks problem `p` (its name must not be in `names`, the names of
    /// the problems before it, and is added): its ladder, its `quick`
    /// indices and every rung.
    fn check<'a>(&'a self, p: usize, names: &mut HashSet<&'a str>) -> Result<(), ProblemError> {
        if !valid_name(&self.name) || !names.insert(self.name.as_str()) {
            return Err(FieldError::new(
                field(p, "name"),
                format!(
                    "`{}` must be a unique name of letters, digits, `_`, `-` or `.`",
                    self.name
                ),
            )
            .into());
        }
        if self.rungs.is_empty() {
            return Err(FieldError::new(field(p, "rungs"), "the problem has no rung").into());
        }
        if let Some(quick) = &self.quick
            && let Some(k) = quick.iter().find(|&&k| k >= self.rungs.len())
        {
            return Err(FieldError::new(
                field(p, "quick"),
                format!("rung {k} does not exist ({} rungs)", self.rungs.len()),
            )
            .into());
        }
        let mut labels = HashSet::new();
        for (r, rung) in self.rungs.iter().enumerate() {
            self.check_rung(p, r, rung, &mut labels)?;
        }
        Ok(())
    }

    /// Checks rung `r` of problem `p` (its label must not be in `labels`,
    /// those of the rungs before it, and is added).
    fn check_rung<'a>(
        &self,
        p: usize,
        r: usize,
        rung: &'a Rung,
        labels: &mut HashSet<&'a str>,
    ) -> Result<(), ProblemError> {
        if !valid_name(&rung.label) || !labels.insert(rung.label.as_str()) {
            return Err(FieldError::new(
                field(p, &format!("rungs[{r}].label")),
                format!(
                    "`{}` must be a unique name of letters, digits, `_`, `-` or `.`",
                    rung.label
                ),
            )
            .into());
        }
        if let Some(h) = rung.h
            && !(h.is_finite() && h > 0.0)
        {
            return Err(FieldError::new(
                field(p, &format!("rungs[{r}].h")),
                format!("must be positive and finite (got {h})"),
            )
            .into());
        }
        if matches!(self.reference, Reference::FinestRung(_))
            && self.resolution == Resolution::Vertices
            && rung.h.is_none()
        {
            return Err(FieldError::new(
                field(p, &format!("rungs[{r}].h")),
                "a FinestRung problem needs `h` on every rung or `resolution: MeanStep`, to know which rung is finest",
            )
            .into());
        }
        if let Some(start) = &rung.start {
            self.check_start(p, r, start)?;
        }
        if rung.threads == Some(0) {
            return Err(FieldError::new(
                field(p, &format!("rungs[{r}].threads")),
                "must be at least 1",
            )
            .into());
        }
        Ok(())
    }

    /// Checks the start of rung `r` of problem `p`: an earlier rung, at
    /// most 3 refinements, and quick if the rung is.
    fn check_start(&self, p: usize, r: usize, start: &RungStart) -> Result<(), ProblemError> {
        let field = field(p, &format!("rungs[{r}].start"));
        let Some(k) = self.rungs[..r].iter().position(|o| o.label == start.rung) else {
            return Err(FieldError::new(
                field,
                format!("`{}` is not an earlier rung of this problem", start.rung),
            )
            .into());
        };
        if start.refine > 3 {
            return Err(ProblemError::Refine {
                start: field,
                refine: start.refine,
            });
        }
        if let Some(quick) = &self.quick
            && quick.contains(&r)
            && !quick.contains(&k)
        {
            return Err(FieldError::new(
                field,
                format!("rung {r} is quick but starts from rung {k}, which is not"),
            )
            .into());
        }
        Ok(())
    }

    /// Loads the scene of problem `p` (relative to `base`) and pushes one
    /// case per rung onto `cases`: the scene with the rung's settings,
    /// checked against the problem's reference.
    fn push_cases(&self, p: usize, base: &Path, cases: &mut Vec<Case>) -> Result<(), FieldError> {
        let scene_path = base.join(&self.scene);
        let scene = Scene::load(&scene_path)
            .map_err(|e| FieldError::new(field(p, "scene"), e.to_string()))?;
        for (r, rung) in self.rungs.iter().enumerate() {
            let at =
                |f: &str, e: &dyn std::fmt::Display| FieldError::new(field(p, f), e.to_string());
            let scene = crate::scene::overrides::set_parameters(&scene, &scene_path, &rung.set)
                .map_err(|e| at(&format!("rungs[{r}].set"), &e))?;
            scene
                .refuse_ladder("a study's rung")
                .map_err(|e| at(&format!("rungs[{r}]"), &e))?;
            check_reference(self.reference, &scene).map_err(|e| at(&format!("rungs[{r}]"), &e))?;
            let start = rung
                .start
                .as_ref()
                .map(|start| (start_dir(&self.name, start), start.refine));
            cases.push(Case {
                problem: p,
                rung: r,
                scene,
                scene_path: scene_path.clone(),
                dir: Path::new("cases").join(&self.name).join(&rung.label),
                start,
            });
        }
        Ok(())
    }
}

/// Whether the reference can be computed for the scene.
fn check_reference(reference: Reference, scene: &Scene) -> Result<(), ReferenceUnsupported> {
    let unsupported = ReferenceUnsupported;
    let bending = scene.energy.iter().find_map(|t| match t {
        crate::scene::EnergyTerm::Bending(p) => Some(*p),
        _ => None,
    });
    let needs_bending = !matches!(reference, Reference::FinestRung(_));
    match bending {
        None if needs_bending => return Err(unsupported("the reference needs a Bending term")),
        Some(p) if needs_bending && (p.kappa <= 0.0 || p.c0 != 0.0) => {
            return Err(unsupported("the reference needs κ > 0 and c0 = 0"));
        }
        _ => {}
    }
    if reference == Reference::SphereBending
        && !matches!(
            scene.membrane,
            crate::scene::MembraneSource::Icosphere { jitter, .. } if jitter == 0.0
        )
    {
        return Err(unsupported(
            "SphereBending needs `membrane: Icosphere(...)` without jitter",
        ));
    }
    if reference == Reference::Tether {
        let sigma = scene.energy.iter().find_map(|t| match t {
            crate::scene::EnergyTerm::Tension(p) => Some(p.sigma),
            _ => None,
        });
        if !sigma.is_some_and(|s| s > 0.0) {
            return Err(unsupported(
                "Tether needs a `Tension(sigma: ...)` term with sigma > 0",
            ));
        }
        if scene.tube_radius.len() != 1 {
            return Err(unsupported("Tether needs exactly one `tube_radius` probe"));
        }
        if !scene.control_points.iter().any(|c| c.name.is_some()) {
            return Err(unsupported(
                "Tether needs a control point with a `name` (its force is measured)",
            ));
        }
    }
    if reference == Reference::Adhesion && scene.adhesion_plane().is_none() {
        return Err(unsupported(
            "Adhesion needs exactly one `Adhesion(shape: Plane(...))` term (the continuum \
             reference lies on a flat substrate)",
        ));
    }
    if reference == Reference::SpheroidBending {
        match scene.membrane {
            crate::scene::MembraneSource::Ellipsoid {
                semi_axes: (a, b, _),
                ..
            } if a == b => {}
            _ => {
                return Err(unsupported(
                    "SpheroidBending needs `membrane: Ellipsoid(semi_axes: (a, a, c), ...)`",
                ));
            }
        }
    }
    Ok(())
}
