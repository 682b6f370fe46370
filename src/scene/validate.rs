//! Scene validation: the checks a scene passes before it is built, one
//! method per part of the scene, run in the order their errors are
//! reported (the first failing check names its field).

use super::{EnergyTerm, MAX_CAPSULE_VERTICES, MembraneSource, Scene, SceneError};
use crate::mesh::MAX_ICOSPHERE_LEVEL;
use std::path::Path;

/// The error for `field` of the scene at `path`.
fn invalid_field(path: &Path, field: &str, reason: String) -> SceneError {
    SceneError::Invalid {
        path: path.to_owned(),
        field: field.to_string(),
        reason,
    }
}

/// How an energy term is named in errors: its kind, or a custom term's
/// name.
fn term_label(t: &EnergyTerm) -> String {
    match t {
        EnergyTerm::Custom(c) => format!("Custom(name: \"{}\")", c.0.name),
        _ => t.kind().to_string(),
    }
}

impl Scene {
    /// The first term (its index and kind) whose needs satisfy `pred`.
    fn term_needing(
        &self,
        pred: impl Fn(&crate::energy::builtin::TermNeeds) -> bool,
    ) -> Option<(usize, &'static str)> {
        self.energy
            .iter()
            .enumerate()
            .find(|(_, t)| pred(&t.needs()))
            .map(|(i, t)| (i, t.kind()))
    }

    /// The species: their parameters, and in thermal dynamics one k_BT.
    fn validate_species(&self, path: &Path) -> Result<(), SceneError> {
        let Some(set) = &self.species else {
            return Ok(());
        };
        set.validate()
            .map_err(|e| invalid_field(path, &format!("species.{}", e.field), e.reason))?;
        let kbt = self.dynamics.temperature;
        if self.dynamics.method.is_overdamped() && kbt > 0.0 && kbt != set.temperature {
            return Err(invalid_field(
                path,
                "species.temperature",
                format!(
                    "{} differs from dynamics.temperature {kbt}: the fields' thermal noise and \
                     their mixing entropy must share one k_BT (Ē)",
                    set.temperature
                ),
            ));
        }
        Ok(())
    }

    /// Every check, in order; the first that fails is the error.
    pub(crate) fn validate(&self, path: &Path) -> Result<(), SceneError> {
        self.validate_membrane(path)?;
        self.validate_valence(path)?;
        self.validate_energy_terms(path)?;
        self.validate_control_points(path)?;
        self.validate_diffusion(path)?;
        self.validate_remesh(path)?;
        let invalid = |field: &str, reason: String| invalid_field(path, field, reason);
        self.validate_method(path)?;
        self.validate_constraints(path)?;
        self.validate_model(path)?;
        self.validate_species(path)?;
        for (i, c) in self.boundary.iter().enumerate() {
            c.held().map_err(|reason| {
                invalid(&format!("boundary[{i}].direction"), reason.to_string())
            })?;
        }
        if let crate::scene::resolution::Resolution::Ladder { refinements } = self.resolution {
            let most = crate::scene::resolution::MAX_LADDER_REFINEMENTS;
            if !(1..=most).contains(&refinements) {
                return Err(invalid(
                    "resolution.refinements",
                    format!(
                        "must be 1 to {most} (each rung splits every triangle into four; \
                         got {refinements})"
                    ),
                ));
            }
        }
        if self.penalty_smoothing > 64 {
            return Err(invalid(
                "penalty_smoothing",
                format!("must be at most 64 passes (got {})", self.penalty_smoothing),
            ));
        }
        Ok(())
    }

    /// The membrane source's sizes.
    fn validate_membrane(&self, path: &Path) -> Result<(), SceneError> {
        self.validate_open_patch(path)?;
        let invalid = |field: &str, reason: String| invalid_field(path, field, reason);
        match &self.membrane {
            MembraneSource::Icosphere { level, .. }
            | MembraneSource::Ellipsoid { level, .. }
            | MembraneSource::DockedPair { level }
                if *level > MAX_ICOSPHERE_LEVEL =>
            {
                return Err(invalid(
                    "membrane.level",
                    format!("must be 0..={MAX_ICOSPHERE_LEVEL} (got {level})"),
                ));
            }
            MembraneSource::Ellipsoid {
                semi_axes: (a, b, c),
                ..
            } if ![a, b, c].iter().all(|x| x.is_finite() && **x > 0.0) => {
                return Err(invalid(
                    "membrane.semi_axes",
                    format!("must be positive and finite (got ({a}, {b}, {c}))"),
                ));
            }
            MembraneSource::Capsule {
                radius,
                length,
                mean_edge_length,
            } if crate::mesh::capsule_vertex_count(*radius, *length, *mean_edge_length)
                > MAX_CAPSULE_VERTICES =>
            {
                return Err(invalid(
                    "membrane",
                    format!(
                        "a capsule of radius {radius} and length {length} with edges of \
                         {mean_edge_length} has more than {MAX_CAPSULE_VERTICES} vertices"
                    ),
                ));
            }
            MembraneSource::Axisymmetric { reduced_volume, .. }
                if !(*reduced_volume > 0.5 && *reduced_volume <= 1.0) =>
            {
                return Err(invalid(
                    "membrane.reduced_volume",
                    format!(
                        "must be in (0.5, 1], the axisymmetric solver's domain (got {reduced_volume})"
                    ),
                ));
            }
            MembraneSource::Axisymmetric {
                area,
                mean_edge_length,
                ..
            } if 2.0 * area / (3f64.sqrt() * mean_edge_length * mean_edge_length)
                > MAX_CAPSULE_VERTICES as f64 =>
            {
                return Err(invalid(
                    "membrane.mean_edge_length",
                    format!(
                        "an area of {area} with edges of {mean_edge_length} has more than \
                         {MAX_CAPSULE_VERTICES} vertices"
                    ),
                ));
            }
            MembraneSource::State { refine, .. } if *refine > 3 => {
                return Err(invalid(
                    "membrane.refine",
                    format!("must be at most 3 (64 times the faces; got {refine})"),
                ));
            }
            MembraneSource::State { refine, .. } if *refine > 0 && self.lipid_density => {
                return Err(invalid(
                    "membrane.refine",
                    "a refined state has new vertices without a lipid density: use a scene \
                     without `lipid_density`, or refine 0"
                        .into(),
                ));
            }
            MembraneSource::Ellipsoid { tilt, .. } if !tilt.is_finite() => {
                return Err(invalid(
                    "membrane.tilt",
                    format!("must be finite (degrees; got {tilt})"),
                ));
            }
            MembraneSource::Ellipsoid { jitter, .. } if *jitter >= 0.5 => {
                return Err(invalid(
                    "membrane.jitter",
                    format!(
                        "must be below 0.5 of the mean edge length, or faces may fold (got {jitter})"
                    ),
                ));
            }
            _ => {}
        }
        Ok(())
    }

    /// The generated open patches' cap angle and size.
    fn validate_open_patch(&self, path: &Path) -> Result<(), SceneError> {
        let invalid = |field: &str, reason: String| invalid_field(path, field, reason);
        match &self.membrane {
            MembraneSource::SphericalCap { opening_angle, .. }
                if !crate::mesh::patch::valid_cap_angle(*opening_angle) =>
            {
                return Err(invalid(
                    "membrane.opening_angle",
                    format!("must be in (0, 90] degrees (got {opening_angle})"),
                ));
            }
            MembraneSource::Disc {
                radius,
                mean_edge_length,
            } if crate::mesh::patch::patch_vertex_count_for(*radius, *mean_edge_length)
                > MAX_CAPSULE_VERTICES =>
            {
                return Err(invalid(
                    "membrane",
                    format!(
                        "a disc of radius {radius} with edges of {mean_edge_length} has more \
                         than {MAX_CAPSULE_VERTICES} vertices"
                    ),
                ));
            }
            MembraneSource::SphericalCap {
                sphere_radius,
                opening_angle,
                mean_edge_length,
            } if crate::mesh::patch::patch_vertex_count_for(
                sphere_radius * opening_angle.to_radians(),
                *mean_edge_length,
            ) > MAX_CAPSULE_VERTICES =>
            {
                return Err(invalid(
                    "membrane",
                    format!(
                        "a cap of sphere radius {sphere_radius} and opening {opening_angle}° \
                         with edges of {mean_edge_length} has more than \
                         {MAX_CAPSULE_VERTICES} vertices"
                    ),
                ));
            }
            _ => {}
        }
        Ok(())
    }

    /// The valence range of the mesh.
    fn validate_valence(&self, path: &Path) -> Result<(), SceneError> {
        let invalid = |field: &str, reason: String| invalid_field(path, field, reason);
        let v = self.valence;
        if v.min < 3 || v.min > v.max {
            return Err(invalid(
                "valence",
                format!("need 3 <= min <= max (got min {}, max {})", v.min, v.max),
            ));
        }
        Ok(())
    }

    /// The energy list: not empty, no term twice, what each term needs, and the flips' edge range.
    fn validate_energy_terms(&self, path: &Path) -> Result<(), SceneError> {
        let invalid = |field: &str, reason: String| invalid_field(path, field, reason);
        let label = term_label;
        if self.energy.is_empty() {
            return Err(invalid("energy", "declares no energy term".into()));
        }
        for (i, term) in self.energy.iter().enumerate() {
            if let Some(j) = self.energy[..i]
                .iter()
                .position(|t| label(t) == label(term))
            {
                return Err(invalid(
                    &format!("energy[{i}]"),
                    format!("{} is already declared at energy[{j}]", label(term)),
                ));
            }
        }
        if let Some((_, kind)) = self.term_needing(|n| n.lipid_density)
            && !self.lipid_density
        {
            return Err(invalid(
                "lipid_density",
                format!("the {kind} term needs `lipid_density: true`"),
            ));
        }
        if let Some(flips) = self.edge_flips {
            let (lo, hi) = flips.edge_range;
            if !(lo.is_finite() && hi.is_finite() && 0.0 < lo && lo < hi) {
                return Err(invalid(
                    "edge_flips.edge_range",
                    format!("need 0 < min < max, both finite (got ({lo}, {hi}))"),
                ));
            }
        }
        Ok(())
    }

    /// Control points, their names and schedule, the springs that use them, and the tube probes.
    fn validate_control_points(&self, path: &Path) -> Result<(), SceneError> {
        let invalid = |field: &str, reason: String| invalid_field(path, field, reason);
        let user = self.term_needing(|n| n.control_points);
        if let Some((_, kind)) = user
            && self.control_points.is_empty()
        {
            return Err(invalid(
                "control_points",
                format!("the {kind} term needs at least one control point"),
            ));
        }
        if user.is_none() && !self.control_points.is_empty() {
            return Err(invalid(
                "control_points",
                format!(
                    "{} control points are declared but no Springs term uses them",
                    self.control_points.len()
                ),
            ));
        }
        for (i, probe) in self.tube_radius.iter().enumerate() {
            if let Err((f, reason)) = probe.check() {
                return Err(invalid(&format!("tube_radius[{i}].{f}"), reason));
            }
            if self.tube_radius[..i].iter().any(|p| p.name == probe.name) {
                return Err(invalid(
                    &format!("tube_radius[{i}].name"),
                    format!("`{}` is used twice", probe.name),
                ));
            }
        }
        for (i, cp) in self.control_points.iter().enumerate() {
            let Some(name) = &cp.name else { continue };
            let field = format!("control_points[{i}].name");
            if name.is_empty() || !name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') {
                return Err(invalid(
                    &field,
                    format!("`{name}` must be letters, digits and `_` (it names series columns)"),
                ));
            }
            if self.control_points[..i]
                .iter()
                .any(|p| p.name.as_deref() == Some(name))
            {
                return Err(invalid(&field, format!("`{name}` is used twice")));
            }
        }
        for (i, c) in self.control_point_schedule.iter().enumerate() {
            use crate::params::schedule::{Change, When};
            let field = |f: &str| format!("control_point_schedule[{i}].{f}");
            if let Some(&p) = c
                .points
                .iter()
                .find(|&&p| p as usize >= self.control_points.len())
            {
                return Err(invalid(
                    &field("points"),
                    format!(
                        "point {p} does not exist ({} control points declared)",
                        self.control_points.len()
                    ),
                ));
            }
            if c.points.is_empty() {
                return Err(invalid(&field("points"), "selects no control point".into()));
            }
            if let When::Every { interval: 0, .. } = c.when {
                return Err(invalid(&field("when"), "interval must be > 0".into()));
            }
            if let When::Every {
                start,
                until: Some(until),
                ..
            } = c.when
                && until < start
            {
                return Err(invalid(
                    &field("when"),
                    format!("until ({until}) is before start ({start}): it would never apply"),
                ));
            }
            if let When::EveryTime { interval, start } = c.when
                && !(interval.is_finite() && interval > 0.0 && start.is_finite() && start >= 0.0)
            {
                return Err(invalid(
                    &field("when"),
                    format!(
                        "interval must be finite and > 0 and start finite and ≥ 0 (got {interval}, {start})"
                    ),
                ));
            }
            let bad = match c.change {
                Change::MoveBy(v) | Change::MoveTo(v) => {
                    !(v.0.is_finite() && v.1.is_finite() && v.2.is_finite())
                }
                Change::ScaleAbout { center: v, factor } => {
                    !(v.0.is_finite()
                        && v.1.is_finite()
                        && v.2.is_finite()
                        && factor.is_finite()
                        && factor > 0.0)
                }
                Change::SetStiffness(k) => !(k.is_finite() && k >= 0.0),
            };
            if bad {
                return Err(invalid(
                    &field("change"),
                    format!("impossible change {:?}", c.change),
                ));
            }
        }
        Ok(())
    }

    /// Lipid diffusion: its density, rate, barriers and remeshing.
    fn validate_diffusion(&self, path: &Path) -> Result<(), SceneError> {
        let invalid = |field: &str, reason: String| invalid_field(path, field, reason);
        if let Some(d) = &self.diffusion {
            if !self.lipid_density {
                return Err(invalid(
                    "lipid_density",
                    "diffusion needs `lipid_density: true`".into(),
                ));
            }
            if let crate::params::DiffusionRate::Finite(k) = d.rate
                && !(k > 0.0 && k <= 1.0)
            {
                return Err(invalid(
                    "diffusion.rate",
                    format!("k_d must be in (0, 1] (got {k})"),
                ));
            }
            for (i, r) in d.barrier.iter().enumerate() {
                let crate::params::BlockedRegion::Slab { half_width, gap } = *r;
                if !(half_width > 0.0 && half_width.is_finite() && (0.0..1.0).contains(&gap)) {
                    return Err(invalid(
                        &format!("diffusion.barrier[{i}]"),
                        format!("need half_width > 0 and 0 <= gap < 1 (got {half_width}, {gap})"),
                    ));
                }
            }
            if self.remesh.mode == crate::params::RemeshMode::Off {
                return Err(invalid(
                    "diffusion",
                    "diffusion runs after remeshing: set remesh.mode".into(),
                ));
            }
        }
        Ok(())
    }

    /// Remeshing: V_in's barriers trigger it, and its lengths are ordered.
    fn validate_remesh(&self, path: &Path) -> Result<(), SceneError> {
        let invalid = |field: &str, reason: String| invalid_field(path, field, reason);
        if self.remesh.mode != crate::params::RemeshMode::Off
            && self.term_needing(|n| n.triggers_remeshing).is_none()
        {
            return Err(invalid(
                "remesh.mode",
                "remeshing needs the Vin term (its barriers trigger it)".into(),
            ));
        }
        let r = self.remesh;
        if !(r.merge_done < r.shorter_than
            && r.shorter_than < r.normal_range.0
            && r.normal_range.0 < r.normal_range.1
            && r.normal_range.1 < r.longer_than
            && r.longer_than < r.split_done)
        {
            return Err(invalid(
                "remesh",
                format!(
                    "need merge_done < shorter_than < normal_range.0 < normal_range.1 < longer_than < split_done (got {} < {} < {} < {} < {} < {})",
                    r.merge_done,
                    r.shorter_than,
                    r.normal_range.0,
                    r.normal_range.1,
                    r.longer_than,
                    r.split_done
                ),
            ));
        }
        Ok(())
    }

    /// Checks the minimiser's settings and what it cannot do: a
    /// minimisation has no temperature and no physical time.
    fn validate_method(&self, path: &Path) -> Result<(), SceneError> {
        let crate::params::Method::Minimise(m) = self.dynamics.method else {
            return Ok(());
        };
        let invalid = |field: &str, reason: String| invalid_field(path, field, reason);
        let d = &self.dynamics;
        if d.temperature > 0.0 {
            return Err(invalid(
                "dynamics.temperature",
                format!(
                    "a minimiser finds zero-temperature equilibria (got k_BT = {}); use                      `method: Overdamped` for thermal runs",
                    d.temperature
                ),
            ));
        }
        for (set, field) in [
            (d.duration.is_some(), "dynamics.duration"),
            (d.frame_time.is_some(), "dynamics.frame_time"),
        ] {
            if set {
                return Err(invalid(
                    field,
                    "a minimisation has no physical time: bound it with `iterations` and                      space frames with `frames`"
                        .into(),
                ));
            }
        }
        if let Some(i) = self
            .control_point_schedule
            .iter()
            .position(|c| matches!(c.when, crate::params::schedule::When::EveryTime { .. }))
        {
            return Err(invalid(
                &format!("control_point_schedule[{i}].when"),
                "a minimisation has no physical time: schedule by iterations (`Every`)".into(),
            ));
        }
        if m.energy_window == 0 {
            return Err(invalid(
                "dynamics.method.Minimise.energy_window",
                "must be at least 1 iteration".into(),
            ));
        }
        if m.dt_max < m.dt_start {
            return Err(invalid(
                "dynamics.method.Minimise.dt_max",
                format!("must be at least dt_start ({} < {})", m.dt_max, m.dt_start),
            ));
        }
        Ok(())
    }

    /// The fluid model's settings, then what it cannot do yet, naming what
    /// works instead (a silently wrong result is worse than none).
    fn validate_model(&self, path: &Path) -> Result<(), SceneError> {
        if !self.model.is_fluid() {
            return Ok(());
        }
        let invalid = |field: &str, reason: String| invalid_field(path, field, reason);
        if let crate::params::MembraneModel::Fluid(crate::params::FluidParams {
            flips: Some(f),
            ..
        }) = self.model
        {
            if !(f.max_dihedral > 0.0 && f.max_dihedral <= 90.0) {
                return Err(invalid(
                    "model.Fluid.flips.max_dihedral",
                    format!("must be in (0, 90] degrees (got {})", f.max_dihedral),
                ));
            }
            if f.every == 0 {
                return Err(invalid(
                    "model.Fluid.flips.every",
                    "must be at least 1 (iterations between sweeps)".into(),
                ));
            }
        }
        // Direct edits (the fluid default) only matter with remeshing on.
        if self.model.direct_edits() && self.remesh.mode != crate::params::RemeshMode::Off {
            let r = self.remesh;
            if r.longer_than <= 2.0 * r.shorter_than {
                return Err(invalid(
                    "remesh.longer_than",
                    format!(
                        "direct edits (the fluid model's default) need longer_than > 2 x \
                         shorter_than, so that the halves of a split edge are never merged again \
                         (got {} and {}; leave both out for the fluid defaults 0.6 and 1.4, or \
                         declare `model: Fluid(edits: Relaxed)`)",
                        r.longer_than, r.shorter_than
                    ),
                ));
            }
        }
        self.validate_fluid_limits(path)
    }

    /// What the fluid model cannot do yet: thermal noise, lipid density,
    /// 1-ring spring couplings and Metropolis flips.
    fn validate_fluid_limits(&self, path: &Path) -> Result<(), SceneError> {
        let invalid = |field: &str, reason: String| invalid_field(path, field, reason);
        if self.dynamics.temperature > 0.0 {
            return Err(invalid(
                "dynamics.temperature",
                format!(
                    "the fluid model is deterministic (got k_BT = {}): its tangential projection \
                     of V_in has no known equilibrium distribution. For a thermal fluid membrane \
                     use the paper's model with Metropolis `edge_flips` and the widened well \
                     (scenes/fluctuating/flips.ron)",
                    self.dynamics.temperature
                ),
            ));
        }
        for (i, term) in self.energy.iter().enumerate() {
            if let Some((field, reason)) = term.needs().not_in_fluid_model {
                let at = if field.is_empty() {
                    format!("energy[{i}]")
                } else {
                    format!("energy[{i}].{field}")
                };
                return Err(invalid(&at, reason));
            }
        }
        if self.lipid_density || self.diffusion.is_some() {
            let field = if self.diffusion.is_some() {
                "diffusion"
            } else {
                "lipid_density"
            };
            return Err(invalid(
                field,
                "lipid density and its diffusion are carried by the vertices, which slide within \
                 the membrane in the fluid model (the density would need remapping): use the \
                 paper's model"
                    .into(),
            ));
        }
        if self.edge_flips.is_some() {
            return Err(invalid(
                "edge_flips",
                "Metropolis edge flips need k_BT > 0, which the fluid model refuses; its \
                 zero-temperature flips are Delaunay maintenance flips: \
                 `model: Fluid(flips: (max_dihedral: 20.0, every: 1))`"
                    .into(),
            ));
        }
        Ok(())
    }

    /// Checks the exact constraints against the rest of the scene.
    fn validate_constraints(&self, path: &Path) -> Result<(), SceneError> {
        let Some(c) = self.constraints else {
            return Ok(());
        };
        let invalid = |field: &str, reason: String| invalid_field(path, field, reason);
        if c.area.is_none() && c.volume.is_none() {
            return Err(invalid(
                "constraints",
                "holds nothing: give `area`, `volume` or both".into(),
            ));
        }
        if matches!(c.volume, Some(crate::params::VolumeConstraint::Reduced(_))) && c.area.is_none()
        {
            return Err(invalid(
                "constraints.volume",
                "a reduced volume is held at the area constraint's target: give `area` too".into(),
            ));
        }
        use crate::energy::builtin::GlobalQuantity;
        for (held, quantity, field) in [
            (c.area.is_some(), GlobalQuantity::Area, "constraints.area"),
            (
                c.volume.is_some(),
                GlobalQuantity::Volume,
                "constraints.volume",
            ),
        ] {
            if let Some((i, kind)) = self.term_needing(|n| n.penalises == Some(quantity))
                && held
            {
                return Err(invalid(
                    field,
                    format!(
                        "energy[{i}] ({kind}) penalises the quantity this constraint holds exactly: keep one of the two"
                    ),
                ));
            }
        }
        if self.dynamics.temperature > 0.0 {
            return Err(invalid(
                "constraints",
                "exact constraints are not implemented for thermal noise (a projected Langevin \
                 step needs a metric correction to sample the right ensemble): use the Area \
                 and Volume penalties at k_BT > 0"
                    .into(),
            ));
        }
        Ok(())
    }
}
