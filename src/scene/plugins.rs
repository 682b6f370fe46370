//! The built-in plugins other than the energy terms' (each term's plugin is
//! in its own file under [`crate::energy`], V_in's with its edge sampling). Each is a function returning a [`Plugin`] that
//! registers its resources and systems on a [`SimBuilder`], through the same
//! calls a user's crate makes (`insert_resource`, `add_system`,
//! `add_force_term`). A scene's build is the list of these plugins.
//!
//! | plugin | resources it inserts | systems (stage) |
//! |---|---|---|
//! | [`core`](fn@core) | `Clock`, `DensePositions`, `DenseLipid`, `ForceBuffers`, `FaceGeometry`, `TimeStepChoice`, `DynamicsParams`, `RemeshParams`, `AbnormalEdges`, `Seed`, `CheckInvariants`, `StopRequest` | `gather_state`, `face_geometry` (Gather), `force_total` (Forces), `adaptive_time_step` (TimeStep), `langevin_integration` (Integrate), or with `Method::Minimise` `fire_minimiser` (Integrate) and `MinimiserStatus`; `barrier_check` (BarrierCheck) |
//! | each term's `plugin` in [`crate::energy`] (vin, bending, volume, area, tension, local tension, springs, self-avoidance) | V_in: `VinSegmentation`, `VinEdgeSamples` in `TermInputs` | their term (Forces); V_in also `vin_edge_samples` (Gather), and exerts no force in the geometric baseline |
//! | [`fluid`] | `MembraneModel`, `VertexNormals` | `vertex_normals` (Gather), `fluid_projection` (Forces) |
//! | [`constraints`] | `Constraints` | `constraint_reactions` (Forces), `constraint_projection` (Integrate) |
//! | [`control_points`] | control-point entities | `control_point_schedule` (Prepare) when scheduled |
//! | [`remesh`] | `ValenceRange`, `RemeshStats`, `RemeshTriggered` | `remesh` (Remesh) |
//! | [`diffusion`] | — | `lipid_diffusion` (Diffuse) |
//! | [`recorders`] | `FrameSchedule`, `CurrentFrame`, `SummarySections` (with a plane substrate) | `frame_clock` and a `record_<name>` system per recorder (Observe) |
//! | [`boundary_conditions`] | `PinnedVertices` | `pin_forces` (Forces), `pin_positions` (Integrate); the `line_tension` term (Forces) |
//! | [`crate::io::output::frame_output`] (added last) | `OpenOutput` | `frames` (Output) |

use crate::engine::core_resources::ScheduledChangesAhead;
use crate::engine::force::{FaceGeometry, ForceBuffers};
use crate::engine::schedule::Stage;
use crate::engine::shared_resources::AbnormalEdges;
use crate::engine::shared_resources::RemeshTriggered;
use crate::engine::simulation::{
    BuildError, CheckInvariants, Clock, DenseLipid, DensePositions, Plugin, Seed, SimBuilder,
};
use crate::engine::summary_section::ResourceSection;
use crate::mesh::ValenceRange;
use crate::mesh::components::ControlPoint;
use crate::mesh::membrane::Membrane;
use crate::params::schedule::ScheduledChange;
use crate::params::{DiffusionParams, DynamicsParams, RemeshParams};
use crate::remesh::RemeshStats;
use crate::systems::barrier_check::BarrierCheck;
use crate::systems::control_point_schedule::ControlPointSchedule;
use crate::systems::remesh::Remesh;
use crate::timestep::TimeStepChoice;

/// Settings of the core plugin.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CoreSettings {
    /// Mobility, temperature, time-step limits.
    pub dynamics: DynamicsParams,
    /// Seed of every random stream.
    pub seed: u64,
    /// Passes of 1-ring averaging of penalty forces.
    pub penalty_smoothing: u32,
    /// Barrier-crossing triggers (and, for the remesh plugin, its settings).
    pub remesh: RemeshParams,
}

/// The core of every simulation: gather, face geometry, force sum, time
/// step and integration (or, with `Method::Minimise`, the FIRE minimiser
/// in their place) and barrier check, with their resources.
pub fn core(settings: CoreSettings) -> impl Plugin {
    move |b: &mut SimBuilder| {
        b.insert_resource(Clock::default())
            .insert_resource(DensePositions::default())
            .insert_resource(DenseLipid::default())
            .insert_resource(ForceBuffers::new())
            .insert_resource(FaceGeometry::default())
            .insert_resource(TimeStepChoice::default())
            .insert_resource(settings.dynamics)
            .insert_resource(settings.remesh)
            .insert_resource(AbnormalEdges::default())
            .insert_resource(Seed(settings.seed))
            .insert_resource(CheckInvariants::default())
            .insert_resource(crate::engine::simulation::StopRequest::default())
            .persist_resource::<Clock>()
            .persist_resource::<TimeStepChoice>()
            .persist_resource::<AbnormalEdges>();
        // Forces-stage systems write only the force buffers, so every force
        // is finite-checked, timed and reported through them.
        b.restrict_stage_writes(
            Stage::Forces,
            &[crate::engine::resources::ResourceId::of::<ForceBuffers>()],
        );
        use crate::systems::{adaptive_time_step, face_geometry, force_total, gather_state};
        b.add_system(Stage::Gather, gather_state::GatherState);
        b.add_system(Stage::Gather, face_geometry::FaceGeometrySystem)
            .after("gather_state");
        b.add_system(
            Stage::Forces,
            crate::systems::force_terms::ForceTermsSystem::default(),
        )
        .before(crate::engine::force::FORCE_TOTAL);
        b.add_system(
            Stage::Forces,
            force_total::ForceTotal::new(settings.penalty_smoothing),
        );
        match settings.dynamics.method {
            crate::params::Method::Overdamped => {
                b.add_system(Stage::TimeStep, adaptive_time_step::AdaptiveTimeStep);
                b.add_system(
                    Stage::Integrate,
                    crate::systems::langevin_integration::LangevinIntegration::default(),
                );
            }
            crate::params::Method::Minimise(params) => {
                b.insert_resource(crate::minimise::MinimiserStatus::default())
                    .persist_resource::<crate::minimise::MinimiserStatus>();
                b.add_system(
                    Stage::Integrate,
                    crate::systems::fire_minimiser::FireMinimiser::new(params),
                );
            }
        }
        b.add_system(Stage::BarrierCheck, BarrierCheck);
        Ok(())
    }
}

/// Exact area and volume constraints (targets resolved against the
/// initial mesh): the reactions are removed from the total force after
/// `force_total`, and the positions are projected back onto the
/// constraints after the integrator (or minimiser) has moved them.
pub fn constraints(params: crate::params::ConstraintParams) -> impl Plugin {
    move |b: &mut SimBuilder| {
        use crate::systems::constraint_projection::ConstraintProjection;
        use crate::systems::constraint_reactions::ConstraintReactions;
        let init = b.initial_state("constraints")?;
        let (area, volume) = params.targets(init.area, init.volume);
        b.insert_resource(crate::constraint::Constraints {
            targets: crate::constraint::ConstraintTargets { area, volume },
            max_correction: params.max_correction,
            smoothing: params.smoothing,
        });
        b.add_system(Stage::Forces, ConstraintReactions)
            .after(crate::engine::force::FORCE_TOTAL);
        if b.resources()
            .get::<crate::params::DynamicsParams>()
            .is_ok_and(|d| match d.method {
                crate::params::Method::Minimise(m) => {
                    matches!(m.preconditioner, crate::params::Preconditioner::Sobolev(_))
                }
                crate::params::Method::Overdamped => false,
            })
        {
            b.insert_resource(crate::constraint::ProjectionDirections::default());
        }
        let integrator = match b.resources().contains::<crate::minimise::MinimiserStatus>() {
            true => crate::systems::fire_minimiser::FIRE_MINIMISER,
            false => "langevin_integration",
        };
        b.add_system(Stage::Integrate, ConstraintProjection::default())
            .after(integrator);
        Ok(())
    }
}

/// The fluid membrane model: the forces of mesh-maintenance terms
/// (V_in) act only in the vertices' tangent planes, and so do the local
/// relaxations of remesh events; external loads (control-point springs)
/// act only along the normals. Inserts `MembraneModel` and
/// `VertexNormals`; adds `vertex_normals` (Gather, after `face_geometry`)
/// and `fluid_projection` (Forces, after `force_terms`, before
/// `force_total`).
pub fn fluid(params: crate::params::FluidParams) -> impl Plugin {
    move |b: &mut SimBuilder| {
        use crate::engine::shared_resources::VertexNormals;
        use crate::systems::fluid_projection::FluidProjection;
        use crate::systems::vertex_normals::VertexNormalsSystem;
        b.insert_resource(crate::params::MembraneModel::Fluid(params))
            .insert_resource(VertexNormals::default());
        b.add_system(Stage::Gather, VertexNormalsSystem)
            .after("face_geometry");
        let physical = params.physical_forces;
        b.add_system(Stage::Forces, FluidProjection { physical })
            .after(FluidProjection::AFTER)
            .before(FluidProjection::BEFORE);
        Ok(())
    }
}

/// Delaunay flips as mesh maintenance in the fluid model, in the Remesh
/// stage (the scene adds it before [`remesh`], so it runs before any
/// split/merge); keeps every valence inside `valence`.
pub fn maintenance_flips(
    params: crate::params::MaintenanceFlipParams,
    valence: ValenceRange,
) -> impl Plugin {
    move |b: &mut SimBuilder| {
        use crate::engine::shared_resources::MaintenanceFlipStats;
        use crate::systems::maintenance_flips::MaintenanceFlips;
        b.insert_resource(valence)
            .insert_resource(MaintenanceFlipStats::default())
            .persist_resource::<MaintenanceFlipStats>();
        b.add_summary_section(ResourceSection::<MaintenanceFlipStats>::new(
            "maintenance_flips",
        ))?;
        b.add_system(Stage::Remesh, MaintenanceFlips::new(params));
        Ok(())
    }
}

/// Spawns fixed control points (declaration order gives their indices) and,
/// if `schedule` is not empty, the system applying its changes.
pub fn control_points(points: Vec<ControlPoint>, schedule: Vec<ScheduledChange>) -> impl Plugin {
    move |b: &mut SimBuilder| {
        let membrane = b
            .resource_mut::<Membrane>()
            .ok_or_else(|| BuildError::Requires {
                what: "control points".into(),
                resource: "Membrane",
                plugin: "SimBuilder::new",
            })?;
        for p in points {
            membrane.add_control_point(p);
        }
        if !schedule.is_empty() {
            b.insert_resource(ScheduledChangesAhead(true));
            b.add_system(Stage::Prepare, ControlPointSchedule::new(schedule));
        }
        Ok(())
    }
}

/// Free-energy remeshing (needs [`core`](fn@core) and V_in ([`crate::energy::vin::plugin`])): keeps every vertex's
/// valence inside `valence`.
pub fn remesh(valence: ValenceRange) -> impl Plugin {
    move |b: &mut SimBuilder| {
        b.insert_resource(valence)
            .insert_resource(RemeshStats::default())
            .insert_resource(RemeshTriggered::default())
            .persist_resource::<RemeshStats>()
            .persist_resource::<RemeshTriggered>();
        b.add_system(Stage::Remesh, Remesh::default());
        Ok(())
    }
}

/// Edge flips as Metropolis moves ([`crate::remesh::flip`]), priced under
/// every registered force term, in the Remesh stage after any split/merge.
pub fn edge_flips(params: crate::params::EdgeFlipParams, valence: ValenceRange) -> impl Plugin {
    move |b: &mut SimBuilder| {
        b.insert_resource(valence)
            .insert_resource(crate::engine::shared_resources::FlipStats::default())
            .persist_resource::<crate::engine::shared_resources::FlipStats>();
        b.add_summary_section(
            ResourceSection::<crate::engine::shared_resources::FlipStats>::new("edge_flips"),
        )?;
        b.add_system(
            Stage::Remesh,
            crate::systems::edge_flips::EdgeFlips::new(params),
        );
        Ok(())
    }
}

/// The built-in recorders (state columns, force, mean curvature, lipid
/// density; the constraints' multipliers and the minimiser's progress
/// when the [`constraints`] plugin and the minimiser were added before),
/// one tube-radius recorder per probe, one contact-curvature column per
/// adhesive substrate, and with `adhesion_report` (a plane substrate and
/// κ) the `adhesion` section of `summary.json`
/// ([`crate::analysis::adhesion::AdhesionSection`]).
pub fn recorders(
    probes: Vec<crate::analysis::tube_radius::TubeProbe>,
    named_points: Vec<(String, u32)>,
    substrates: Vec<crate::energy::adhesion::AdhesionParams>,
    adhesion_report: Option<(crate::energy::adhesion::AdhesionParams, f64)>,
) -> impl Plugin {
    move |b: &mut SimBuilder| {
        use crate::io::recorders::*;
        b.add_recorder(StateColumns)
            .add_recorder(ForceField)
            .add_recorder(MeanCurvatureField)
            .add_recorder(LipidDensityField);
        if b.resources().contains::<crate::constraint::Constraints>() {
            b.add_recorder(ConstraintColumns);
        }
        if b.resources().contains::<crate::minimise::MinimiserStatus>() {
            b.add_recorder(MinimiserColumns);
        }
        for probe in probes {
            b.add_recorder(TubeRadius::new(probe));
        }
        for (name, index) in named_points {
            b.add_recorder(ControlPointForce::new(name, index));
        }
        for params in substrates {
            b.add_recorder(ContactCurvatureColumn::new(params));
        }
        if let Some((substrate, kappa)) = adhesion_report {
            b.add_summary_section(crate::analysis::adhesion::AdhesionSection { substrate, kappa })?;
        }
        Ok(())
    }
}

/// Lipid diffusion after remeshing ticks (needs [`remesh`]).
pub fn diffusion(params: DiffusionParams) -> impl Plugin {
    move |b: &mut SimBuilder| {
        b.add_system(
            Stage::Diffuse,
            crate::systems::lipid_diffusion::LipidDiffusion::new(params),
        );
        Ok(())
    }
}

/// An open membrane's boundary conditions, one per boundary loop (loops
/// numbered as [`crate::mesh::topology::Topology::boundary_loops`] lists
/// them): a `Pinned` loop's vertices keep their initial positions, a
/// `Roller` loop's their initial coordinate along its direction; a `Free`
/// loop with a line tension adds the `line_tension` force term. With a
/// pinned or roller loop, inserts `PinnedVertices` and adds `pin_forces` (Forces,
/// after `force_total`) and `pin_positions` (Integrate, after the
/// integrator or minimiser). Errors name the condition (`[i].loop`).
pub fn boundary_conditions(conditions: Vec<crate::params::BoundaryCondition>) -> impl Plugin {
    move |b: &mut SimBuilder| {
        use crate::engine::shared_resources::PinnedVertices;
        use crate::systems::pin_forces::PinForces;
        use crate::systems::pin_positions::PinPositions;
        let invalid = |field: String, reason: String| BuildError::Invalid { field, reason };
        let membrane = b
            .resource_mut::<Membrane>()
            .ok_or_else(|| invalid(String::new(), "no membrane".into()))?;
        let loops = membrane
            .topology()
            .map_err(|e| invalid(String::new(), e.to_string()))?
            .boundary_loops();
        let mut positions = Vec::new();
        membrane.gather_positions(&mut positions);
        let mut pinned = PinnedVertices::default();
        let mut seen = vec![false; loops.len()];
        let mut line = Vec::new();
        for (i, c) in conditions.iter().enumerate() {
            let l = c.loop_index();
            let Some(vertices) = loops.get(l) else {
                let reason = match loops.len() {
                    0 => "the membrane is closed: it has no boundary loop".to_string(),
                    n => format!(
                        "the membrane has {n} boundary loops (0..={}), not loop {l}",
                        n - 1
                    ),
                };
                return Err(invalid(format!("[{i}].loop"), reason));
            };
            if std::mem::replace(&mut seen[l], true) {
                return Err(invalid(
                    format!("[{i}].loop"),
                    format!("loop {l} already has a condition"),
                ));
            }
            let held = c
                .held()
                .map_err(|r| invalid(format!("[{i}].direction"), r.to_string()))?;
            if let Some(held) = held {
                let t = membrane.cached_topology();
                pinned
                    .entities
                    .extend(vertices.iter().map(|&v| t.vertex_entities[v as usize]));
                pinned.vertices.extend_from_slice(vertices);
                pinned
                    .positions
                    .extend(vertices.iter().map(|&v| positions[v as usize]));
                pinned.held.extend(vertices.iter().map(|_| held));
            }
            if let crate::params::BoundaryCondition::Free { line_tension, .. } = *c
                && line_tension > 0.0
            {
                line.push((l, line_tension));
            }
        }
        if !line.is_empty() {
            b.add_force_term(crate::energy::line_tension::LineTensionForces::new(line))?;
        }
        if pinned.vertices.is_empty() {
            return Ok(());
        }
        b.insert_resource(pinned);
        b.add_system(Stage::Forces, PinForces)
            .after(crate::engine::force::FORCE_TOTAL);
        let integrator = match b.resources().contains::<crate::minimise::MinimiserStatus>() {
            true => crate::systems::fire_minimiser::FIRE_MINIMISER,
            false => "langevin_integration",
        };
        b.add_system(Stage::Integrate, PinPositions)
            .after(integrator);
        Ok(())
    }
}

/// Protein species: their amounts on the vertices (from each species'
/// initial field), the species force term, the gather system (Gather) and,
/// with the minimiser, the fields' relaxation (Gather, after it: the
/// forces see the fields relaxed at the current shape), in overdamped
/// dynamics the fields' transport (Diffuse) where a species moves (a
/// mobility or a binding rate) and, in the fluid model, their remap under
/// the step's slides (BarrierCheck, from the tick's start positions,
/// [`SlideAnchors`]), the `species` recorder and summary section.
///
/// [`SlideAnchors`]: crate::species::remap::SlideAnchors
pub fn species(
    set: crate::species::params::SpeciesSet,
    base: crate::species::free_energy::BaseBending,
    relax: crate::species::relax::RelaxSettings,
) -> impl Plugin {
    move |b: &mut SimBuilder| {
        use crate::energy::bending_measure::vertex_areas;
        use crate::species::model::{SpeciesModel, SpeciesStatus};
        use crate::species::params::{Initial, Reservoir};
        use crate::species::state::{SpeciesAmounts, add_amounts};
        let membrane = b
            .resource_mut::<Membrane>()
            .ok_or_else(|| BuildError::Requires {
                what: "species".into(),
                resource: "Membrane",
                plugin: "SimBuilder::new",
            })?;
        let invalid = |field: String, reason: String| BuildError::Invalid { field, reason };
        let t = membrane
            .topology()
            .map_err(|e| invalid("membrane".into(), e.to_string()))?
            .clone();
        let mut positions = Vec::new();
        membrane.gather_positions(&mut positions);
        let mut geometry = Vec::new();
        crate::mesh::geometry::face_geometry(&positions, &t.faces, &mut geometry);
        let areas = vertex_areas(&t.faces, &geometry, positions.len(), base.discretisation);
        let area: f64 = areas.iter().sum();
        // Each species' uniform initial fraction.
        let mut fractions = Vec::new();
        for (k, s) in set.species.iter().enumerate() {
            let phi = match s.initial {
                Initial::Fraction(x) => x,
                Initial::Count(c) => c * s.area_per_protein / area,
            };
            fractions.push(phi);
            let total: f64 = fractions.iter().sum();
            if total >= 1.0 {
                return Err(invalid(
                    format!("species[{k}].initial"),
                    format!(
                        "the membrane (area {area:.4} l̄²) cannot carry it: with the species \
                         before it, the proteins would cover {:.4} of the area (must stay \
                         below 1)",
                        total
                    ),
                ));
            }
        }
        add_amounts(membrane, &set, |k, slot, _| {
            areas[slot] * fractions[k] / set.species[k].area_per_protein
        })
        .map_err(|e| invalid("membrane".into(), e.to_string()))?;
        // Adding the components changed the structure: the cache is rebuilt.
        let t = membrane
            .topology()
            .map_err(|e| invalid("membrane".into(), e.to_string()))?
            .clone();
        let mut amounts = SpeciesAmounts::default();
        amounts.gather(&membrane.world, &t, set.species.len());
        let counts = amounts.counts();
        let status = SpeciesStatus {
            names: set.species.iter().map(|s| s.name.clone()).collect(),
            chemical_potentials: set
                .species
                .iter()
                .map(|s| match s.reservoir {
                    Reservoir::Conserved => 0.0,
                    Reservoir::Bulk => s.chemical_potential.unwrap_or(0.0),
                })
                .collect(),
            initial_counts: counts.clone(),
            counts,
            ..Default::default()
        };
        let minimiser = b.resources().contains::<crate::minimise::MinimiserStatus>();
        let fluid = matches!(
            b.resource_mut::<crate::params::MembraneModel>().as_deref(),
            Some(crate::params::MembraneModel::Fluid(_))
        );
        b.publish_term_input(amounts);
        b.insert_resource(SpeciesModel {
            set: set.clone(),
            base,
            relax,
        })
        .insert_resource(status)
        .persist_resource::<SpeciesStatus>();
        b.add_force_term(crate::species::term::SpeciesForces::new(set.clone(), base))?;
        b.add_system(Stage::Gather, crate::systems::species_gather::SpeciesGather)
            .after("gather_state");
        if minimiser {
            b.add_system(
                Stage::Gather,
                crate::systems::species_relaxation::SpeciesRelaxation::default(),
            )
            .after(crate::systems::species_gather::SPECIES_GATHER)
            .after("face_geometry");
        } else {
            if fluid {
                b.insert_resource(crate::species::remap::SlideAnchors::default());
                b.add_system(
                    Stage::BarrierCheck,
                    crate::systems::species_remap::SpeciesRemap::default(),
                );
            }
            if set
                .species
                .iter()
                .any(|s| s.mobility > 0.0 || s.binding_rate > 0.0)
            {
                b.add_system(
                    Stage::Diffuse,
                    crate::systems::species_transport::SpeciesTransport::default(),
                );
            }
        }
        b.add_recorder(crate::io::recorders::SpeciesColumns);
        b.add_summary_section(ResourceSection::<SpeciesStatus>::new("species"))?;
        Ok(())
    }
}
