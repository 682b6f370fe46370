//! Reading and checking a study file ([`Study::load`]): every error names
//! the file and the field.

use super::{Case, Problem, Reference, Resolution, Rung, RungStart, Study, StudyError, start_dir};
use crate::scene::Scene;
use crate::scene::setting::valid_name;
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
        study.check_name_and_peers().map_err(bad)?;
        let base = path.parent().unwrap_or(Path::new("."));
        let mut cases = Vec::new();
        let mut names = HashSet::new();
        for (p, problem) in study.problems.iter().enumerate() {
            problem.check(p, &mut names).map_err(bad)?;
            problem.push_cases(p, base, &mut cases).map_err(bad)?;
        }
        Ok((study, cases))
    }

    /// Checks the study's name and peers, and that it declares a problem.
    fn check_name_and_peers(&self) -> Result<(), String> {
        if !valid_name(&self.name) {
            return Err(format!(
                "field `name`: `{}` must be a plain directory name",
                self.name
            ));
        }
        for (k, peer) in self.peers.iter().enumerate() {
            if !valid_name(&peer.name) || self.peers[..k].iter().any(|o| o.name == peer.name) {
                return Err(format!(
                    "field `peers[{k}].name`: `{}` must be a unique plain directory name",
                    peer.name
                ));
            }
            if peer.command.is_empty() {
                return Err(format!("field `peers[{k}].command`: names no program"));
            }
        }
        if self.problems.is_empty() {
            return Err("field `problems`: the study declares no problem".into());
        }
        Ok(())
    }
}

/// The name of field `f` of problem `p`, for messages.
fn field(p: usize, f: &str) -> String {
    format!("field `problems[{p}].{f}`")
}

impl Problem {
    /// Checks problem `p` (its name must not be in `names`, the names of
    /// the problems before it, and is added): its ladder, its `quick`
    /// indices and every rung.
    fn check<'a>(&'a self, p: usize, names: &mut HashSet<&'a str>) -> Result<(), String> {
        if !valid_name(&self.name) || !names.insert(self.name.as_str()) {
            return Err(format!(
                "{}: `{}` must be a unique name of letters, digits, `_`, `-` or `.`",
                field(p, "name"),
                self.name
            ));
        }
        if self.rungs.is_empty() {
            return Err(format!("{}: the problem has no rung", field(p, "rungs")));
        }
        if let Some(quick) = &self.quick
            && let Some(k) = quick.iter().find(|&&k| k >= self.rungs.len())
        {
            return Err(format!(
                "{}: rung {k} does not exist ({} rungs)",
                field(p, "quick"),
                self.rungs.len()
            ));
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
    ) -> Result<(), String> {
        if !valid_name(&rung.label) || !labels.insert(rung.label.as_str()) {
            return Err(format!(
                "{}: `{}` must be a unique name of letters, digits, `_`, `-` or `.`",
                field(p, &format!("rungs[{r}].label")),
                rung.label
            ));
        }
        if let Some(h) = rung.h
            && !(h.is_finite() && h > 0.0)
        {
            return Err(format!(
                "{}: must be positive and finite (got {h})",
                field(p, &format!("rungs[{r}].h"))
            ));
        }
        if matches!(self.reference, Reference::FinestRung(_))
            && self.resolution == Resolution::Vertices
            && rung.h.is_none()
        {
            return Err(format!(
                "{}: a FinestRung problem needs `h` on every rung or `resolution: MeanStep`, to know which rung is finest",
                field(p, &format!("rungs[{r}].h"))
            ));
        }
        if let Some(start) = &rung.start {
            self.check_start(p, r, start)?;
        }
        if rung.threads == Some(0) {
            return Err(format!(
                "{}: must be at least 1",
                field(p, &format!("rungs[{r}].threads"))
            ));
        }
        Ok(())
    }

    /// Checks the start of rung `r` of problem `p`: an earlier rung, at
    /// most 3 refinements, and quick if the rung is.
    fn check_start(&self, p: usize, r: usize, start: &RungStart) -> Result<(), String> {
        let field = field(p, &format!("rungs[{r}].start"));
        let Some(k) = self.rungs[..r].iter().position(|o| o.label == start.rung) else {
            return Err(format!(
                "{field}: `{}` is not an earlier rung of this problem",
                start.rung
            ));
        };
        if start.refine > 3 {
            return Err(format!(
                "{field}.refine: must be at most 3 (got {})",
                start.refine
            ));
        }
        if let Some(quick) = &self.quick
            && quick.contains(&r)
            && !quick.contains(&k)
        {
            return Err(format!(
                "{field}: rung {r} is quick but starts from rung {k}, which is not"
            ));
        }
        Ok(())
    }

    /// Loads the scene of problem `p` (relative to `base`) and pushes one
    /// case per rung onto `cases`: the scene with the rung's settings,
    /// checked against the problem's reference.
    fn push_cases(&self, p: usize, base: &Path, cases: &mut Vec<Case>) -> Result<(), String> {
        let scene_path = base.join(&self.scene);
        let scene = Scene::load(&scene_path).map_err(|e| format!("{}: {e}", field(p, "scene")))?;
        for (r, rung) in self.rungs.iter().enumerate() {
            let scene = crate::scene::overrides::set_parameters(&scene, &scene_path, &rung.set)
                .map_err(|e| format!("{}: {e}", field(p, &format!("rungs[{r}].set"))))?;
            scene
                .refuse_ladder("a study's rung")
                .map_err(|e| format!("{}: {e}", field(p, &format!("rungs[{r}]"))))?;
            check_reference(self.reference, &scene)
                .map_err(|reason| format!("{}: {reason}", field(p, &format!("rungs[{r}]"))))?;
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
fn check_reference(reference: Reference, scene: &Scene) -> Result<(), String> {
    let bending = scene.energy.iter().find_map(|t| match t {
        crate::scene::EnergyTerm::Bending(p) => Some(*p),
        _ => None,
    });
    let needs_bending = !matches!(reference, Reference::FinestRung(_));
    match bending {
        None if needs_bending => return Err("the reference needs a Bending term".into()),
        Some(p) if needs_bending && (p.kappa <= 0.0 || p.c0 != 0.0) => {
            return Err("the reference needs κ > 0 and c0 = 0".into());
        }
        _ => {}
    }
    if reference == Reference::SphereBending
        && !matches!(
            scene.membrane,
            crate::scene::MembraneSource::Icosphere { jitter, .. } if jitter == 0.0
        )
    {
        return Err("SphereBending needs `membrane: Icosphere(...)` without jitter".into());
    }
    if reference == Reference::Tether {
        let sigma = scene.energy.iter().find_map(|t| match t {
            crate::scene::EnergyTerm::Tension(p) => Some(p.sigma),
            _ => None,
        });
        if !sigma.is_some_and(|s| s > 0.0) {
            return Err("Tether needs a `Tension(sigma: ...)` term with sigma > 0".into());
        }
        if scene.tube_radius.len() != 1 {
            return Err("Tether needs exactly one `tube_radius` probe".into());
        }
        if !scene.control_points.iter().any(|c| c.name.is_some()) {
            return Err(
                "Tether needs a control point with a `name` (its force is measured)".into(),
            );
        }
    }
    if reference == Reference::Adhesion && scene.adhesion_plane().is_none() {
        return Err(
            "Adhesion needs exactly one `Adhesion(shape: Plane(...))` term (the continuum \
             reference lies on a flat substrate)"
                .into(),
        );
    }
    if reference == Reference::SpheroidBending {
        match scene.membrane {
            crate::scene::MembraneSource::Ellipsoid {
                semi_axes: (a, b, _),
                ..
            } if a == b => {}
            _ => {
                return Err(
                    "SpheroidBending needs `membrane: Ellipsoid(semi_axes: (a, a, c), ...)`".into(),
                );
            }
        }
    }
    Ok(())
}
