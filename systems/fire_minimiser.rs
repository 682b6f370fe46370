//! The FIRE minimiser ([`remembrane_core::minimise`]), in place of the overdamped
//! integrator when a scene declares `dynamics: (method: Minimise(...))`.
//!
//! Stage: Integrate. Reads: the total force and energies in
//! [`ForceBuffers`] (with the constraints' reactions removed when the
//! scene holds any), [`RemeshStats`], [`FlipStats`] and
//! [`MaintenanceFlipStats`] when present (a
//! change in their counts is a topology change: FIRE restarts from rest).
//! Writes: [`DensePositions`], the world's `Position` and `Force` (in
//! [`Membrane`]), [`Clock`] (iterations; simulated time stays 0),
//! [`TimeStepChoice`] (FIRE's step, for the `dt` column),
//! [`MinimiserStatus`] and, once a convergence criterion holds,
//! [`StopRequest`] (the state is then left where it is).
//!
//! At rest while [`ScheduledChangesAhead`] says a control-point change is
//! still to come, it does not stop the run: it counts the iteration
//! without moving anything and restarts from rest once the change has
//! moved the forces (a quasi-static protocol: each change relaxed to the
//! tolerance before the next).
//!
//! With `preconditioner: Sobolev(...)` FIRE steps along P⁻¹F in the
//! Sobolev metric of [`remembrane_core::minimise::sobolev`] (H² normal,
//! H¹ tangential), with the constraints kept in the same metric and the
//! held vertices' held directions removed; the factor is rebuilt every
//! `rebuild_every` iterations and after every topology change, at
//! positions that are checkpointed, so a resumed run steps exactly as an
//! uninterrupted one. Also reads [`Constraints`] and [`PinnedVertices`]
//! when present.
//!
//! A step that turns a face over or the membrane inside out (a closed one:
//! an open membrane encloses no volume) is undone: the
//! step is halved and FIRE restarts from rest. Below a millionth of the
//! first step the run stops with [`SimError::MinimiserStuck`].

use glam::DVec3;
use remembrane_core::constraint::{Constraints, Gradients, ProjectionDirections};
use remembrane_core::engine::core_resources::ScheduledChangesAhead;
use remembrane_core::engine::force::{ForceBuffers, ForceContext};
use remembrane_core::engine::resources::{Res, ResMut};
use remembrane_core::engine::schedule::System;
use remembrane_core::engine::shared_resources::{FlipStats, MaintenanceFlipStats, PinnedVertices};
use remembrane_core::engine::simulation::{Clock, DensePositions, SimError, StopRequest};
use remembrane_core::engine::term_inputs::TermInputs;
use remembrane_core::mesh::membrane::Membrane;
use remembrane_core::mesh::step_check::check_step;
use remembrane_core::minimise::axial;
use remembrane_core::minimise::sobolev::{MetricScales, SobolevMetric};
use remembrane_core::minimise::{Fire, MinimiserStatus, StopReason};
use remembrane_core::params::{MinimiserParams, Preconditioner, SobolevParams};
use remembrane_core::remesh::RemeshStats;
use remembrane_core::timestep::{Limiter, TimeStepChoice};
use std::collections::VecDeque;
use std::time::Duration;

/// The smallest step tried after folds, as a fraction of the first.
const SMALLEST_RETRY: f64 = 1e-6;

/// The minimiser system.
pub struct FireMinimiser {
    params: MinimiserParams,
    state: SavedFire,
    previous: Vec<DVec3>,
    metric: Option<Metric>,
    /// With `axisymmetric`: the modes and the direction without them.
    axial: Option<Axial>,
}

/// The working buffers of `axisymmetric` (nothing carries over).
#[derive(Default)]
struct Axial {
    modes: [Vec<DVec3>; 2],
    direction: Vec<DVec3>,
    /// Which constraints are held (area, volume).
    active: [bool; 2],
    /// The vertex normals at the evaluated state.
    normals: Vec<DVec3>,
    /// The modes' reactions in the metric (P g; the modes without one).
    reactions: [Vec<DVec3>; 2],
    /// The factorisation count of the metric the reactions were applied
    /// with since the modes were last measured (`None`: not yet, or the
    /// Euclidean fallback).
    reactions_from: Option<u64>,
}

impl Axial {
    /// Measures the modes about `axis` at `positions` (their normal parts,
    /// with the held vertices' held directions removed) and,
    /// with a metric built for this topology, the modes' reactions in it
    /// (P g: what a force along the modes' directions looks like); returns
    /// the largest force left when the least-squares combination of the
    /// reactions and the constraint gradients `gradients` (at `positions`)
    /// is removed from `force`, and
    /// the largest force removed along the modes.
    fn measure(
        &mut self,
        positions: &[DVec3],
        topology: &remembrane_core::mesh::topology::Topology,
        axis: DVec3,
        (constraints, pinned): (Option<&Constraints>, Option<&PinnedVertices>),
        metric: Option<&mut Metric>,
        (force, gradients): (&[DVec3], &Gradients),
    ) -> (f64, f64) {
        axial::quadrupole_modes(positions, axis, &mut self.modes);
        // Their normal parts: what changes the shape. Their reactions are
        // then exactly what the metric's normal block inverts.
        remembrane_core::fluid::vertex_normals(positions, topology, &mut self.normals);
        for g in &mut self.modes {
            for (x, n) in g.iter_mut().zip(&self.normals) {
                *x = x.dot(*n) * *n;
            }
            release_held(pinned, g);
        }
        self.reactions_from = None;
        self.active = [false, false];
        if let Some(c) = constraints {
            self.active = [c.targets.area.is_some(), c.targets.volume.is_some()];
        }
        self.reactions(positions, topology, metric);
        self.direction.clear();
        self.direction.extend_from_slice(force);
        let g = gradients;
        let mut pairs: Vec<(&[DVec3], &[DVec3])> = Vec::with_capacity(4);
        for (row, on) in [&g.area_gradient, &g.volume_gradient]
            .into_iter()
            .zip(self.active)
        {
            if on {
                pairs.push((row, row));
            }
        }
        for r in &self.reactions {
            pairs.push((r, r));
        }
        axial::remove_along(&mut self.direction, &pairs);
        let largest = |d: &mut dyn Iterator<Item = f64>| d.fold(0.0, f64::max);
        let left = largest(&mut self.direction.iter().map(|f| f.length()));
        let removed = largest(
            &mut self
                .direction
                .iter()
                .zip(force)
                .map(|(d, f)| (*f - *d).length()),
        );
        (left, removed)
    }

    /// The modes' reactions: P g with a metric built for `topology`, the
    /// modes themselves without one (the Euclidean metric).
    fn reactions(
        &mut self,
        positions: &[DVec3],
        topology: &remembrane_core::mesh::topology::Topology,
        metric: Option<&mut Metric>,
    ) {
        match metric {
            Some(m) if m.sobolev.is_built_for(topology, positions.len()) => {
                // The same factor and modes as when last applied: the
                // same reactions.
                let build = Some(m.sobolev.factorisations);
                if self.reactions_from == build {
                    return;
                }
                for (g, r) in self.modes.iter().zip(&mut self.reactions) {
                    m.sobolev.apply(positions, topology, g, r);
                }
                self.reactions_from = build;
            }
            _ => {
                self.reactions.clone_from(&self.modes);
                self.reactions_from = None;
            }
        }
    }

    /// The direction in its buffer without the modes, kept tangent to the active
    /// constraints: d ← d − U ν with the rows R·d = 0, where the
    /// constraints pair their gradients with the columns the direction
    /// keeps them along (the metric's W, or the gradients themselves
    /// without a metric) and the modes pair their reactions with
    /// themselves (a projection orthogonal in the metric). `gradients`:
    /// the constraint gradients at `positions`, when constraints are held.
    fn remove_modes(
        &mut self,
        positions: &[DVec3],
        topology: &remembrane_core::mesh::topology::Topology,
        mut metric: Option<&mut Metric>,
        gradients: Option<&Gradients>,
    ) {
        self.reactions(positions, topology, metric.as_deref_mut());
        let mut pairs: Vec<(&[DVec3], &[DVec3])> = Vec::with_capacity(4);
        if let Some(g) = gradients {
            let rows = [&g.area_gradient, &g.volume_gradient];
            let columns: [&[DVec3]; 2] = match &metric {
                Some(m) => m.sobolev.columns(),
                None => [&g.area_gradient, &g.volume_gradient],
            };
            for ((row, column), on) in rows.into_iter().zip(columns).zip(self.active) {
                if on {
                    pairs.push((row, column));
                }
            }
        }
        for (r, g) in self.reactions.iter().zip(&self.modes) {
            pairs.push((r, g));
        }
        axial::remove_along(&mut self.direction, &pairs);
    }
}

/// `d` with the held vertices' held directions removed.
fn release_held(pinned: Option<&PinnedVertices>, d: &mut [DVec3]) {
    if let Some(pin) = pinned {
        for (&v, &h) in pin.vertices.iter().zip(&pin.held) {
            d[v as usize] = h.release(d[v as usize]);
        }
    }
}

/// The preconditioner's working state (rebuilt from [`SavedFire`] after a
/// resume).
struct Metric {
    settings: SobolevParams,
    sobolev: SobolevMetric,
    direction: Vec<DVec3>,
    /// The force terms' normal stiffness at the last build, or at the
    /// current positions after the check for new contact (Ē/l̄²).
    stiffness: Vec<f64>,
    /// Whether any term has a normal stiffness (else the metric is never
    /// rebuilt for new contact, and nothing is measured for it).
    stiff: bool,
}

/// What carries from one iteration to the next (checkpointed).
#[derive(Clone, Debug, Default, serde::Serialize, serde::Deserialize)]
struct SavedFire {
    fire: Option<Fire>,
    /// Remesh successes plus accepted flips when FIRE last stepped.
    edits_seen: u64,
    /// Total energies since the last restart, the newest last (at most
    /// `energy_window` + 1).
    energies: VecDeque<f64>,
    /// With a preconditioner: the positions its factor was built at (empty
    /// until the first build, and after a topology change).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    metric_positions: Vec<DVec3>,
    /// With a preconditioner: iterations since its factor was built.
    #[serde(default, skip_serializing_if = "is_zero")]
    since_build: u32,
}

fn is_zero(x: &u32) -> bool {
    *x == 0
}

impl FireMinimiser {
    /// A minimiser with `params`.
    pub fn new(params: MinimiserParams) -> Self {
        let metric = match params.preconditioner {
            Preconditioner::None => None,
            Preconditioner::Sobolev(settings) => Some(Metric {
                settings,
                sobolev: SobolevMetric::default(),
                direction: Vec::new(),
                stiffness: Vec::new(),
                stiff: false,
            }),
        };
        let mut params = params;
        if let Some(m) = &metric {
            params.dt_start = m.settings.dt_start;
            params.dt_max = m.settings.dt_max;
        }
        Self {
            params,
            state: SavedFire::default(),
            previous: Vec::new(),
            metric,
            axial: None,
        }
    }
}

/// Its name in the schedule.
pub const FIRE_MINIMISER: &str = "fire_minimiser";

impl System for FireMinimiser {
    type Data<'a> = (
        Res<'a, ForceBuffers>,
        Option<Res<'a, RemeshStats>>,
        Option<Res<'a, FlipStats>>,
        Option<Res<'a, MaintenanceFlipStats>>,
        Option<Res<'a, ScheduledChangesAhead>>,
        (
            Option<Res<'a, Constraints>>,
            Option<Res<'a, PinnedVertices>>,
            Option<ResMut<'a, ProjectionDirections>>,
        ),
        ResMut<'a, DensePositions>,
        ResMut<'a, Membrane>,
        ResMut<'a, Clock>,
        ResMut<'a, TimeStepChoice>,
        ResMut<'a, MinimiserStatus>,
        ResMut<'a, StopRequest>,
    );

    fn name(&self) -> &str {
        FIRE_MINIMISER
    }

    fn run(
        &mut self,
        (
            buffers,
            remesh,
            flips,
            maintenance,
            ahead,
            (constraints, pinned, mut published),
            mut positions,
            mut membrane,
            mut clock,
            mut time_step,
            mut status,
            mut stop,
        ): Self::Data<'_>,
    ) -> Result<(), SimError> {
        let p = &self.params;
        let ev = &buffers.evaluation;
        let n = positions.0.len();
        let edits = remesh.map_or(0, |s| s.successes())
            + flips.map_or(0, |s| s.accepted)
            + maintenance.map_or(0, |s| s.flipped);
        let s = &mut self.state;
        let fire = match &mut s.fire {
            Some(f) if f.velocity.len() == n && s.edits_seen == edits => f,
            fire => {
                if fire.is_some() {
                    status.restarts += 1;
                }
                s.energies.clear();
                s.edits_seen = edits;
                // A new topology needs a new factor.
                s.metric_positions.clear();
                fire.insert(Fire::new(n, p))
            }
        };
        // With held modes: the modes at the evaluated state, and the
        // force without their reactions (for the criterion).
        let axial_residual = match p.axisymmetric {
            Some(axis) => {
                let axial = self.axial.get_or_insert_with(Default::default);
                let residual = axial.measure(
                    positions.0.as_slice(),
                    membrane.cached_topology(),
                    DVec3::new(axis.0, axis.1, axis.2),
                    (constraints.as_deref(), pinned.as_deref()),
                    self.metric.as_mut(),
                    (&ev.total, &ev.constraint_gradients),
                );
                status.axial_reaction = Some(residual.1);
                Some(residual.0)
            }
            None => None,
        };
        // Convergence of the state the forces were evaluated at.
        let reason = convergence(&mut s.energies, p, ev, axial_residual, &mut status);
        if reason.is_some() && ahead.is_some_and(|a| a.0) {
            // At rest before a scheduled change: wait for it, and start
            // from rest once it has moved the forces.
            s.fire = None;
            s.energies.clear();
            clock.iteration += 1;
            *time_step = TimeStepChoice {
                dt: 0.0,
                limiter: Limiter::Cap,
            };
            return Ok(());
        }
        if let Some(reason) = reason {
            status.stopped_by = Some(reason);
            stop.0 = Some(format!("minimiser converged ({})", reason.name()));
            return Ok(());
        }
        let positions = &mut positions.0;
        if let Some(metric) = &mut self.metric {
            let topology = membrane.cached_topology();
            let rebuild = s.metric_positions.len() != n
                || s.since_build >= metric.settings.rebuild_every.max(1);
            if rebuild {
                s.metric_positions.clone_from(positions);
                s.since_build = 0;
                metric.sobolev.clear();
                // Counted here, by the schedule: a resumed run factorises
                // the same matrix again, which a summary must not show.
                status.factorisations += 1;
            }
            let mut restrict = |d: &mut [DVec3]| release_held(pinned.as_deref(), d);
            let scales = MetricScales {
                normal: metric.settings.normal_scale.unwrap_or(1.0),
                tangential: metric.settings.tangential_scale,
            };
            let build_error = |source| SimError::Preconditioner {
                iteration: clock.iteration + 1,
                source,
            };
            // The stiff terms' normal stiffness at `at`, into `out`.
            let stiffness = |at: &[DVec3], out: &mut Vec<f64>| -> bool {
                let ctx = ForceContext {
                    world: &membrane.world,
                    topology,
                    positions: at,
                    lipid: &[],
                    face_geometry: &[],
                    inputs: TermInputs::none(),
                };
                buffers.normal_stiffness(&ctx, out)
            };
            if !metric.sobolev.is_built() {
                // Rigid motions are free only when nothing holds a vertex.
                metric.sobolev.stiffen_rigid_patterns = metric.settings.rigid_patterns
                    && pinned.as_deref().is_none_or(|p| p.vertices.is_empty());
                metric.stiff = stiffness(&s.metric_positions, &mut metric.stiffness);
                metric
                    .sobolev
                    .build(&s.metric_positions, topology, scales, &metric.stiffness)
                    .map_err(build_error)?;
            }
            if metric.stiff && !rebuild {
                // A vertex that came within a stiff term's range since the
                // build: build again here (a resumed run has just rebuilt
                // the factor it was saved with, and decides the same).
                stiffness(positions, &mut metric.stiffness);
                if metric.sobolev.underestimates(&metric.stiffness) {
                    s.metric_positions.clone_from(positions);
                    s.since_build = 0;
                    status.factorisations += 1;
                    metric
                        .sobolev
                        .build(&s.metric_positions, topology, scales, &metric.stiffness)
                        .map_err(build_error)?;
                }
            }
            s.since_build += 1;
            let held = constraints
                .as_ref()
                .map(|c| (&ev.constraint_gradients, c.targets));
            metric.sobolev.direction(
                positions,
                topology,
                &ev.total,
                held,
                &mut restrict,
                &mut metric.direction,
            );
            if let Some(out) = &mut published {
                for (o, w) in out.0.iter_mut().zip(metric.sobolev.columns()) {
                    o.clear();
                    o.extend_from_slice(w);
                }
            }
        }
        let mut direction = self.metric.as_ref().map_or(&ev.total, |m| &m.direction);
        if let Some(axial) = &mut self.axial {
            axial.direction.clone_from(direction);
            axial.remove_modes(
                positions,
                membrane.cached_topology(),
                self.metric.as_mut(),
                constraints.as_ref().map(|_| &ev.constraint_gradients),
            );
            direction = &axial.direction;
        }
        self.previous.clone_from(positions);
        loop {
            fire.step_along(positions, &ev.total, direction, p);
            if let Some(v) = positions.iter().position(|x| !x.is_finite()) {
                return Err(SimError::BlowUp {
                    iteration: clock.iteration + 1,
                    quantity: "position",
                    term: FIRE_MINIMISER.into(),
                    element: format!("vertex {v}"),
                    value: format!("{:?}", positions[v]),
                });
            }
            let topology = membrane.cached_topology();
            let faces = &topology.faces;
            let (turned, volume) = check_step(faces, &self.previous, positions);
            let folded = turned.is_some() || !(volume > 0.0 || topology.is_open());
            // A step that folds nothing must also stay in every term's domain.
            let refused = match folded {
                true => None,
                false => buffers.refusal(&ForceContext {
                    world: &membrane.world,
                    topology,
                    positions,
                    lipid: &[],
                    face_geometry: &[],
                    inputs: TermInputs::none(),
                }),
            };
            if !folded && refused.is_none() {
                break;
            }
            // Undo, halve the step and start again from rest.
            let refused = refused.map(str::to_string);
            positions.copy_from_slice(&self.previous);
            status.folds_undone += 1;
            let dt = 0.5 * fire.dt;
            if dt < SMALLEST_RETRY * p.dt_start {
                if let Some(term) = refused {
                    return Err(SimError::StepRefused {
                        iteration: clock.iteration + 1,
                        dt,
                        term,
                    });
                }
                let face = turned.unwrap_or(0);
                return Err(SimError::MinimiserStuck {
                    iteration: clock.iteration + 1,
                    dt,
                    face,
                    vertices: faces.get(face).copied().unwrap_or_default(),
                });
            }
            fire.restart(n, p);
            fire.dt = dt;
        }
        membrane.scatter_positions_and_forces(positions, &ev.total);
        clock.iteration += 1;
        *time_step = TimeStepChoice {
            dt: fire.last_step,
            limiter: Limiter::Cap,
        };
        Ok(())
    }

    /// With a preconditioner: its factorisations and its solves (the rest
    /// is the direction's assembly, FIRE's step and the fold check; the
    /// constraint gradients are measured by `constraint_reactions`).
    fn sub_timings(&self) -> Vec<(String, Duration)> {
        self.metric.as_ref().map_or_else(Vec::new, |m| {
            vec![
                ("factorise".into(), m.sobolev.factor_time),
                ("solve".into(), m.sobolev.solve_time),
            ]
        })
    }

    fn save_state(&self) -> Option<serde_json::Value> {
        serde_json::to_value(&self.state).ok()
    }

    fn restore_state(
        &mut self,
        state: serde_json::Value,
    ) -> Result<(), remembrane_core::engine::error::StateError> {
        self.state = serde_json::from_value(state)?;
        if let Some(m) = &mut self.metric {
            m.sobolev.clear();
        }
        Ok(())
    }
}

/// Records the residual, energy, energy change and constraint violation of
/// the evaluated state in `status` (the energy also in the window
/// `energies`) and says which criterion, if any, it meets.
fn convergence(
    energies: &mut std::collections::VecDeque<f64>,
    p: &remembrane_core::params::MinimiserParams,
    ev: &remembrane_core::engine::force::ForceEvaluation,
    axial_residual: Option<f64>,
    status: &mut MinimiserStatus,
) -> Option<StopReason> {
    let residual = axial_residual.unwrap_or_else(|| ev.largest_force());
    let energy = ev.total_energy();
    energies.push_back(energy);
    while energies.len() > p.energy_window as usize + 1 {
        energies.pop_front();
    }
    let change = (energies.len() == p.energy_window as usize + 1).then(|| {
        let first = energies.front().copied().unwrap_or(energy);
        (energy - first).abs() / energy.abs().max(f64::MIN_POSITIVE)
    });
    let violation = ev.constraint.map_or(0.0, |c| c.violation());
    status.force_residual = residual;
    status.energy = energy;
    status.energy_change = change;
    status.constraint_violation = violation;
    let held = violation <= p.constraint_tolerance;
    if held && residual <= p.force_tolerance {
        Some(StopReason::ForceResidual)
    } else if held && p.energy_tolerance > 0.0 && change.is_some_and(|c| c <= p.energy_tolerance) {
        Some(StopReason::EnergyChange)
    } else {
        None
    }
}
