//! Measuring a finished run into its [`RunSummary`].

use super::*;

pub(super) fn summarize(
    name: &str,
    scene: &Scene,
    scene_path: &Path,
    sim: &Simulation,
    out: &RunOutput,
    stop: Option<&SimError>,
    wall_time_s: f64,
) -> RunSummary {
    let membrane = sim.membrane();
    let t = membrane.cached_topology();
    let clock = sim.clock();
    let stats = sim.resources().get::<RemeshStats>().ok();
    let none = RemeshStats::default();
    let stats = stats.as_deref().unwrap_or(&none);
    let model = model_summary(sim);
    let last = EnergyReport::new(name, sim);
    let timings = sim.schedule().timings();
    let time_notes: Vec<String> = remesh_dominance(&timings, stats).into_iter().collect();
    let sections = sim.summary_sections(stop.is_none());
    RunSummary {
        scene_file: scene_path.display().to_string(),
        seed: scene.seed,
        status: if stop.is_some() {
            RunStatus::BlewUp
        } else {
            RunStatus::Completed
        },
        error: stop.map(|e| e.to_string()),
        last_good_frame: out.frames.last().map(|f| f.file.clone()),
        iterations: clock.iteration,
        simulated_time: clock.time,
        wall_time_s,
        last,
        shape: crate::analysis::shape::shape_metrics(&sim.resource::<DensePositions>().0, &t.faces),
        abnormal_edges: sim.resource::<AbnormalEdges>().0.len(),
        cautions: scene.cautions(),
        time_notes,
        remesh: RemeshSummary {
            split: stats.split,
            merge: stats.merge,
            overflow_ticks: stats.overflow_ticks,
            unresolved_ticks: stats.unresolved_ticks,
            events: stats.successes(),
            relax_iterations: stats.relax_iterations,
            event_position_spread: stats.position_spread(),
        },
        minimiser: minimiser_summary(sim),
        sections,
        constraints: sim
            .resource::<crate::engine::force::ForceBuffers>()
            .evaluation
            .constraint,
        model,
        frames: out.frames.clone(),
        timings,
    }
}

/// Share of the systems' wall time above which a run says that remeshing
/// dominated it.
pub const REMESH_DOMINANT_SHARE: f64 = 0.5;

/// A note when the remesh system took more than
/// [`REMESH_DOMINANT_SHARE`] of the run's time, with what it spent it on.
fn remesh_dominance(
    timings: &[crate::engine::schedule::SystemTiming],
    stats: &RemeshStats,
) -> Option<String> {
    let share = timings
        .iter()
        .find(|t| t.system == "remesh" && t.part_of.is_none())?
        .share;
    if share <= REMESH_DOMINANT_SHARE {
        return None;
    }
    let r = &stats.relax_iterations;
    let relaxations = r.pre_success + r.pre_cancel + r.pre_failure + r.post + r.push_back;
    let failed = stats.split.failure + stats.merge.failure;
    Some(format!(
        "remeshing took {:.0} % of the run's time ({} events, {} failed, {:.2e} local \
         relaxation iterations): in the fluid model keep its remeshing defaults (direct \
         edits and maintenance flips, docs/fluid.md); otherwise lower remesh.relax_iterations",
        100.0 * share,
        stats.successes(),
        failed,
        relaxations as f64
    ))
}

/// The membrane model of `sim` and V_in's network moduli at its current
/// positions; in the fluid model also the residuals of the last force
/// evaluation.
pub fn model_summary(sim: &Simulation) -> crate::fluid::ModelSummary {
    use crate::energy::vin::VinSegmentation;
    let model = sim.resources().get::<crate::params::MembraneModel>().ok();
    let fluid = model.is_some_and(|m| m.is_fluid());
    let membrane = sim.membrane();
    let t = membrane.cached_topology();
    let positions = &sim.resource::<DensePositions>().0;
    let has_vin = sim
        .resource::<crate::engine::force::ForceBuffers>()
        .terms()
        .iter()
        .any(|term| term.kind == crate::engine::force::ForceKind::Maintenance);
    let vin_moduli = sim
        .resources()
        .get::<VinSegmentation>()
        .ok()
        .filter(|_| has_vin && positions.len() == t.vertex_count())
        .map(|seg| {
            let lengths = t
                .edges
                .iter()
                .map(|&[a, b]| positions[a as usize].distance(positions[b as usize]));
            crate::energy::vin_elasticity::network_moduli(&seg.0, lengths)
        });
    let kappa = sim
        .resources()
        .get::<crate::energy::bending::BendingRigidity>()
        .ok()
        .map(|k| k.0)
        .filter(|k| *k > 0.0);
    let foppl_von_karman = vin_moduli.zip(kappa).map(|(m, kappa)| {
        let area = crate::mesh::geometry::total_area(positions, &t.faces);
        crate::energy::vin_elasticity::foppl_von_karman(m.young, area, kappa)
    });
    let residuals = fluid
        .then(|| {
            let normals = sim
                .resources()
                .get::<crate::engine::shared_resources::VertexNormals>()
                .ok()?;
            let buffers = sim.resource::<crate::engine::force::ForceBuffers>();
            let ev = &buffers.evaluation;
            let n = ev.total.len();
            if normals.0.len() != n {
                return None;
            }
            let mut maintenance = vec![glam::DVec3::ZERO; n];
            for (term, buf) in buffers.terms().iter().zip(&ev.term_forces) {
                if term.kind == crate::engine::force::ForceKind::Maintenance && buf.len() == n {
                    for (m, f) in maintenance.iter_mut().zip(buf) {
                        *m += *f;
                    }
                }
            }
            let boundary = crate::fluid::boundary_tangents(positions, t);
            Some(crate::fluid::residuals(
                &ev.total,
                &maintenance,
                &normals.0,
                &boundary,
            ))
        })
        .flatten();
    let mut summary = crate::fluid::ModelSummary {
        name: if fluid { "fluid" } else { "paper" }.to_string(),
        vin_moduli,
        foppl_von_karman,
        residuals,
        caution: None,
    };
    summary.caution = summary.elastic_shell_caution();
    summary
}

/// How the minimisation of `sim` stands (`None` unless it runs the
/// minimiser): the largest force and constraint violation of the last
/// force evaluation, the rest from its [`crate::minimise::MinimiserStatus`].
pub fn minimiser_summary(sim: &Simulation) -> Option<MinimiserSummary> {
    let status = sim
        .resources()
        .get::<crate::minimise::MinimiserStatus>()
        .ok()?;
    let buffers = sim.resource::<crate::engine::force::ForceBuffers>();
    let ev = &buffers.evaluation;
    Some(MinimiserSummary {
        stopped_by: status
            .stopped_by
            .map_or("iteration_cap", |r| r.name())
            .to_string(),
        converged: status.stopped_by.is_some(),
        // With held modes the residual leaves their reactions out, as
        // the minimiser's criterion does (the same evaluation).
        force_residual: match status.axial_reaction {
            Some(_) => status.force_residual,
            None => ev.largest_force(),
        },
        energy_change: status.energy_change,
        constraint_violation: ev.constraint.map_or(0.0, |c| c.violation()),
        restarts: status.restarts,
        folds_undone: status.folds_undone,
        factorisations: status.factorisations,
        axial_reaction: status.axial_reaction,
    })
}
