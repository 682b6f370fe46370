#![allow(missing_docs)]
//! Force-system throughput: each force system alone and all forces of the
//! red-blood-cell scene together (V_in + bending + volume + area, 4 smoothing
//! passes, including the shared face-geometry pass and the world
//! gather/scatter) at 642 … 40962 vertices. With V_in: the shared per-edge
//! pass (`vin_edge_samples`), V_in and the time-step rule reading it, and
//! both measuring the edges themselves (`*_in_place`).
//!
//! The minimiser's per-tick kernels (`constraints`): the constraint
//! reactions (gradients of A and V, least-squares removal), the projection
//! back onto a target 1e-6 away (4 smoothing passes), and one FIRE step.
//!
//! The force stage of the paper's and the fluid model (`model`), and a
//! whole minimiser tick of the red blood cell in each (`model_tick`).
//!
//! `cargo bench -p remembrane-benches --bench forces`; filter with e.g.
//! `-- rbc_all/642`.

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use glam::DVec3;
use remembrane::energy::springs::SpringForces;
use remembrane::energy::vin::{Segmentation, VinForm, VinParams};
use remembrane::energy::{
    area::AreaForces, bending::BendingForces, local_tension::LocalTensionForces,
    self_avoidance::SelfAvoidanceForces, tension::TensionForces, vin::VinForces,
    volume::VolumeForces,
};
use remembrane::engine::force::{ForceContext, ForceTerm};
use remembrane::engine::simulation::{InitialState, SimBuilder};
use remembrane::mesh::components::ControlPoint;
use remembrane::mesh::icosphere;
use remembrane::mesh::membrane::Membrane;
use remembrane::params::BendingParams;
use remembrane::scene::plugins;
use std::hint::black_box;
use std::sync::Arc;
use std::time::Duration;

const LEVELS: [u32; 4] = [3, 4, 5, 6];

/// A path of the repository (`cargo bench` runs in `benches/`).
fn repo(path: &str) -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("..")
        .join(path)
}

fn membrane(level: u32) -> Membrane {
    let mut mesh = icosphere(level, 1.0);
    mesh.jitter(0.05, 9);
    let mut m = Membrane::from_mesh(&mesh, true).unwrap();
    for k in 0..42 {
        let dir = DVec3::new(
            (k as f64).cos(),
            (k as f64 * 0.7).sin(),
            ((k % 5) as f64 - 2.0) / 2.0,
        )
        .normalize();
        m.add_control_point(ControlPoint {
            position: dir * 7.0,
            stiffness: 4.0,
        });
    }
    m.topology().unwrap();
    m
}

fn terms(initial: &InitialState) -> Vec<Box<dyn ForceTerm>> {
    let seg = Arc::new(Segmentation::new(VinParams::default()));
    vec![
        Box::new(VinForces::new(seg, VinForm::PiecewiseLinear)),
        Box::new(BendingForces::new(BendingParams {
            kappa: 5.0,
            c0: 0.0,
            ..Default::default()
        })),
        Box::new(VolumeForces::new(4.0, 0.6 * initial.volume)),
        Box::new(AreaForces::new(8.0, 1.005 * initial.area)),
        Box::new(TensionForces::new(0.1)),
        Box::new(LocalTensionForces::new(
            12.0,
            initial.area / initial.vertices as f64,
        )),
        Box::new(SpringForces::default()),
        Box::new(SelfAvoidanceForces::new(Default::default())),
    ]
}

fn initial_state(m: &mut Membrane) -> InitialState {
    let mesh = m.to_mesh().unwrap();
    InitialState {
        vertices: mesh.vertex_count(),
        lipid_total: mesh.vertex_count() as f64,
        area: remembrane::mesh::geometry::total_area(&mesh.positions, &mesh.faces),
        volume: remembrane::mesh::geometry::enclosed_volume(
            &mesh.positions,
            &mesh.faces,
            DVec3::ZERO,
        ),
    }
}

fn configure<'a>(
    c: &'a mut Criterion,
    name: &str,
) -> criterion::BenchmarkGroup<'a, criterion::measurement::WallTime> {
    let mut g = c.benchmark_group(name);
    g.warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(2))
        .sample_size(30);
    g
}

fn each_system(c: &mut Criterion) {
    for level in LEVELS {
        let mut m = membrane(level);
        let initial = initial_state(&mut m);
        let mut pos = Vec::new();
        let mut rho = Vec::new();
        m.gather_positions(&mut pos);
        m.gather_lipid(&mut rho);
        let n = pos.len();
        // The shared per-face geometry pass, timed on its own; the terms
        // below read its result.
        let mut geometry = Vec::new();
        let mut g = configure(c, "face_geometry");
        g.throughput(Throughput::Elements(n as u64));
        g.bench_with_input(BenchmarkId::from_parameter(n), &n, |b, _| {
            b.iter(|| {
                remembrane::mesh::geometry::face_geometry(
                    &pos,
                    &m.cached_topology().faces,
                    &mut geometry,
                );
                black_box(geometry.len())
            })
        });
        g.finish();
        let ctx = ForceContext::new(
            &m.world,
            m.cached_topology(),
            &pos,
            &rho,
            &mut geometry,
            true,
        );
        // The per-edge pass shared by V_in and the time step, then both
        // reading it, against both measuring the edges in place.
        let seg = Arc::new(Segmentation::new(VinParams::default()));
        let edges = &m.cached_topology().edges;
        let mut samples = remembrane::energy::vin::VinEdgeSamples::default();
        let mut g = configure(c, "vin_edge_samples");
        g.throughput(Throughput::Elements(n as u64));
        g.bench_with_input(BenchmarkId::from_parameter(n), &n, |b, _| {
            b.iter(|| {
                samples.measure(edges, &pos, |l| seg.segment_of(l));
                black_box(samples.0.len())
            })
        });
        g.finish();
        let mut inputs = remembrane::engine::term_inputs::TermInputs::default();
        inputs.insert(samples.clone());
        let sampled = ForceContext {
            inputs: &inputs,
            ..ctx
        };
        let mut vin = VinForces::new(seg.clone(), VinForm::PiecewiseLinear);
        let mut force = vec![DVec3::ZERO; n];
        for (name, context) in [("vin_sampled", &sampled), ("vin_in_place", &ctx)] {
            let mut g = configure(c, name);
            g.throughput(Throughput::Elements(n as u64));
            g.bench_with_input(BenchmarkId::from_parameter(n), &n, |b, _| {
                b.iter(|| black_box(vin.accumulate(context, &mut force)))
            });
            g.finish();
        }
        for (name, s) in [
            ("time_step_sampled", &samples.0[..]),
            ("time_step_in_place", &[][..]),
        ] {
            let mut g = configure(c, name);
            g.throughput(Throughput::Elements(n as u64));
            g.bench_with_input(BenchmarkId::from_parameter(n), &n, |b, _| {
                b.iter(|| {
                    black_box(remembrane::timestep::choose_time_step(
                        Some(&seg),
                        edges,
                        s,
                        &pos,
                        &force,
                        1000.0,
                        1e-3,
                        10.0,
                    ))
                })
            });
            g.finish();
        }
        for mut term in terms(&initial) {
            let name = term.name().to_string();
            let mut g = configure(c, &name);
            g.throughput(Throughput::Elements(n as u64));
            let mut force = vec![DVec3::ZERO; n];
            g.bench_with_input(BenchmarkId::from_parameter(n), &n, |b, _| {
                b.iter(|| black_box(term.accumulate(&ctx, &mut force)))
            });
            g.finish();
        }
        // The bending term in Jülicher's dihedral form, beside the
        // cotangent form's `bending` group above.
        let mut term = BendingForces::new(BendingParams {
            kappa: 5.0,
            discretisation: remembrane::params::BendingDiscretisation::Dihedral,
            ..Default::default()
        });
        let mut g = configure(c, "bending_dihedral");
        g.throughput(Throughput::Elements(n as u64));
        g.bench_with_input(BenchmarkId::from_parameter(n), &n, |b, _| {
            b.iter(|| black_box(term.accumulate(&ctx, &mut force)))
        });
        g.finish();
    }
}

fn rbc_all_forces(c: &mut Criterion) {
    let mut g = configure(c, "rbc_all");
    for level in LEVELS {
        let mut m = membrane(level);
        let initial = initial_state(&mut m);
        let mut builder = SimBuilder::new(m, initial);
        builder
            .add_plugin(plugins::core(plugins::CoreSettings {
                dynamics: Default::default(),
                seed: 1,
                penalty_smoothing: 4,
                remesh: Default::default(),
            }))
            .unwrap();
        for t in terms(&initial).into_iter().take(4) {
            builder.add_force_term(t).unwrap();
        }
        let mut sim = builder.build().unwrap();
        let n = initial.vertices;
        g.throughput(Throughput::Elements(n as u64));
        g.bench_with_input(BenchmarkId::from_parameter(n), &n, |b, _| {
            b.iter(|| black_box(sim.evaluate_forces().unwrap().evaluation.total_energy()))
        });
    }
    g.finish();
}

fn constraints(c: &mut Criterion) {
    use remembrane::constraint::{
        ConstraintTargets, Directions, Gradients, ProjectionScratch, project, remove_reactions,
    };
    use remembrane::minimise::Fire;
    let mut g = configure(c, "constraints");
    for level in LEVELS {
        let mut m = membrane(level);
        let mut pos = Vec::new();
        m.gather_positions(&mut pos);
        let topology = m.topology().unwrap().clone();
        let n = pos.len();
        let mut gradients = Gradients::default();
        gradients.measure(&pos, &topology.faces);
        let targets = ConstraintTargets {
            area: Some(gradients.area),
            volume: Some(gradients.volume),
        };
        let force: Vec<DVec3> = pos.iter().map(|p| -0.01 * *p).collect();
        g.throughput(Throughput::Elements(n as u64));
        g.bench_with_input(BenchmarkId::new("reactions", n), &n, |b, _| {
            let mut f = force.clone();
            b.iter(|| {
                gradients.measure(&pos, &topology.faces);
                f.copy_from_slice(&force);
                black_box(remove_reactions(&gradients, targets, &mut f))
            })
        });
        let near = ConstraintTargets {
            area: Some(gradients.area * (1.0 + 1e-6)),
            volume: Some(gradients.volume * (1.0 - 1e-6)),
        };
        let mut scratch = ProjectionScratch::default();
        g.bench_with_input(BenchmarkId::new("projection", n), &n, |b, _| {
            let mut p = pos.clone();
            b.iter(|| {
                p.copy_from_slice(&pos);
                black_box(project(
                    &mut p,
                    &topology,
                    near,
                    0.02,
                    Directions::Smoothed(4),
                    &mut scratch,
                ))
            })
        });
        let params = Default::default();
        g.bench_with_input(BenchmarkId::new("fire_step", n), &n, |b, _| {
            let mut fire = Fire::new(n, &params);
            let mut p = pos.clone();
            b.iter(|| {
                p.copy_from_slice(&pos);
                black_box(fire.step(&mut p, &force, &params))
            })
        });
    }
    g.finish();
}

/// The force stage of the paper's and the fluid model (V_in + bending on
/// a jittered icosphere, the Gather and Forces stages of a tick): the fluid
/// model adds the vertex normals and the projection of V_in's force.
fn models(c: &mut Criterion) {
    use remembrane::scene::Scene;
    let mut g = configure(c, "model");
    for level in [3u32, 4, 5] {
        for (label, model) in [("paper", "Paper"), ("fluid", "Fluid()")] {
            let text = format!(
                "Scene(name: \"m\", membrane: Ellipsoid(level: {level}, \
                 semi_axes: ({a}, {a}, {c}), jitter: 0.05), \
                 energy: [Vin(form: Exact), Bending(kappa: 5.0)], model: {model})",
                a = 6.864 * (1 << (level - 3)) as f64,
                c = 6.178 * (1 << (level - 3)) as f64,
            );
            let path = std::path::Path::new("model.ron");
            let mut sim = Scene::from_ron_str(&text, path)
                .unwrap()
                .build(path)
                .unwrap();
            let n = sim.membrane().cached_topology().vertex_count();
            g.throughput(Throughput::Elements(n as u64));
            g.bench_with_input(BenchmarkId::new(label, n), &n, |b, _| {
                b.iter(|| black_box(sim.evaluate_forces().unwrap().evaluation.total_energy()))
            });
        }
    }
    g.finish();
}

/// A whole tick of the minimiser red blood cell (`scenes/fluid/red_blood_cell.ron`:
/// V_in + bending, exact area and volume, FIRE, free-energy remeshing) in
/// the paper's and the fluid model, at 642 vertices and the same cell at
/// h = 1/2 (2562), each after 4000 warm-up ticks.
fn model_ticks(c: &mut Criterion) {
    use remembrane::scene::Scene;
    let base = std::fs::read_to_string(repo("scenes/fluid/red_blood_cell.ron")).unwrap();
    let mut g = configure(c, "model_tick");
    for (level, h) in [(3u32, 1.0), (4, 0.5)] {
        for (label, model) in [("paper", "Paper"), ("fluid", "Fluid()")] {
            let text = base
                .replace("level: 3,", &format!("level: {level},"))
                .replace(
                    "model: Fluid(),",
                    &format!("model: {model}, resolution: EdgeLength({h}),"),
                );
            let path = &repo("scenes/fluid/red_blood_cell.ron");
            let mut sim = Scene::from_ron_str(&text, path)
                .unwrap()
                .build(path)
                .unwrap();
            // Near the equilibrium, so that no remesh event falls into the
            // samples (events are reported separately, `benches/remesh.rs`).
            for _ in 0..4000 {
                sim.tick().unwrap();
            }
            let n = sim.membrane().cached_topology().vertex_count();
            g.throughput(Throughput::Elements(n as u64));
            g.bench_with_input(BenchmarkId::new(label, n), &n, |b, _| {
                b.iter(|| sim.tick().unwrap())
            });
        }
    }
    g.finish();
}

/// The protein species' per-tick kernels at 642 … 10242 vertices (one
/// conserved species, c = 1 /l̄, a_p = 0.05 l̄², φ = 0.2 with a ±0.05
/// ripple, κ = 5 Ē): the species force term at fixed amounts (`species/term`,
/// with the face-geometry pass it reads and, outside the schedule, its
/// gather of the amounts from the world)
/// and the relaxation of the fields at the shape (`species/relax`), from the
/// same unrelaxed fields each time; the term's domain check after a
/// minimiser step (`species/admits`); in dynamics, one step of the fields'
/// transport (`species/transport_step`) and the fluid model's remap under a
/// step's slides (`species/remap`).
fn species(c: &mut Criterion) {
    use remembrane::energy::bending_measure::{Surface, vertex_areas};
    use remembrane::species::free_energy::BaseBending;
    use remembrane::species::params::{Initial, Species, SpeciesSet};
    use remembrane::species::relax::{RelaxSettings, relax_amounts};
    use remembrane::species::remap::remap_slides;
    use remembrane::species::state::{SpeciesAmounts, add_amounts};
    use remembrane::species::term::SpeciesForces;
    use remembrane::species::transport::Transport;
    let set = SpeciesSet {
        species: vec![Species {
            curvature_coupling: 1.0,
            ..Species::new("bar", 0.05, Initial::Fraction(0.2))
        }],
        interactions: vec![],
        temperature: 0.1,
    };
    let base = BaseBending {
        kappa: 5.0,
        c0: 0.0,
        discretisation: Default::default(),
    };
    for level in [3, 4, 5] {
        let mut m = membrane(level);
        let mut pos = Vec::new();
        m.gather_positions(&mut pos);
        let n = pos.len();
        let mut geometry = Vec::new();
        let faces = m.cached_topology().faces.clone();
        remembrane::mesh::geometry::face_geometry(&pos, &faces, &mut geometry);
        let areas = vertex_areas(&faces, &geometry, n, base.discretisation);
        add_amounts(&mut m, &set, |_, slot, p| {
            areas[slot] * (0.2 + 0.05 * (p.z / 7.0).sin()) / 0.05
        })
        .unwrap();
        let t = m.topology().unwrap().clone();
        let mut amounts = SpeciesAmounts::default();
        amounts.gather(&m.world, &t, 1);
        let mut g = configure(c, "species");
        g.throughput(Throughput::Elements(n as u64));
        let mut term = SpeciesForces::new(set.clone(), base);
        let mut force = vec![DVec3::ZERO; n];
        let mut scratch = Vec::new();
        g.bench_with_input(BenchmarkId::new("term", n), &n, |b, _| {
            b.iter(|| {
                let ctx = ForceContext::new(&m.world, &t, &pos, &[], &mut scratch, true);
                black_box(term.accumulate(&ctx, &mut force))
            })
        });
        // The domain check FIRE makes after each step (its cheap bound holds
        // here, as it does on a minimisation's usual step).
        g.bench_with_input(BenchmarkId::new("admits", n), &n, |b, _| {
            b.iter(|| {
                let ctx = ForceContext::new(&m.world, &t, &pos, &[], &mut scratch, false);
                black_box(term.admits(&ctx))
            })
        });
        let shape = Surface {
            positions: &pos,
            topology: &t,
            geometry: &geometry,
            boundary: None,
        };
        let settings = RelaxSettings {
            tolerance: 1e-9,
            max_iterations: 100,
        };
        g.bench_with_input(BenchmarkId::new("relax", n), &n, |b, _| {
            b.iter(|| {
                let mut fields = amounts.0.clone();
                black_box(relax_amounts(shape, base, &set, &mut fields, settings).unwrap())
            })
        });
        // One explicit step of the fields' transport in dynamics (a tick
        // shorter than the stable step; D = M k_BT / a_p = 1 l̄²/s).
        let mut moving = set.clone();
        moving.species[0].mobility = 0.5;
        let mut transport = Transport::default();
        g.bench_with_input(BenchmarkId::new("transport_step", n), &n, |b, _| {
            b.iter(|| {
                let mut fields = amounts.0.clone();
                black_box(
                    transport
                        .advance(shape, base, &moving, &mut fields, 1e-9, None)
                        .unwrap(),
                )
            })
        });
        // The fluid model's remap under a step's slides (a rotation about
        // the axis by 1e-4 rad: every vertex slides).
        let slides: Vec<DVec3> = pos.iter().map(|p| DVec3::Z.cross(*p) * 1e-4).collect();
        g.bench_with_input(BenchmarkId::new("remap", n), &n, |b, _| {
            b.iter(|| {
                let mut fields = amounts.0.clone();
                black_box(remap_slides(
                    shape,
                    base.discretisation,
                    &mut fields,
                    &slides,
                ))
            })
        });
        g.finish();
    }
}

/// Whole minimiser runs with one protein species against the same scene
/// without it, per iteration (the throughput is iterations per second):
/// the fluid red blood cell at 642 vertices (`scenes/fluid/red_blood_cell.ron`,
/// Sobolev FIRE) with one conserved species of c = 0 (a_p = 0.05 l̄², φ =
/// 0.2, so that both follow the same 475-iteration path), and
/// `scenes/proteins/tube_sorting.ron` (plain FIRE, the dihedral form, one
/// bulk species) against the same tube without its species. Each sample
/// builds the scene and times its run to the minimiser's stop.
fn species_ticks(c: &mut Criterion) {
    use criterion::BatchSize;
    use remembrane::engine::simulation::{Simulation, StopRequest};
    use remembrane::scene::Scene;
    let rbc = std::fs::read_to_string(repo("scenes/fluid/red_blood_cell.ron")).unwrap();
    let protein = "    species: (species: [(name: \"bar\", area_per_protein: 0.05, \
                   curvature_coupling: 0.0, initial: Fraction(0.2))]),\n)";
    let rbc_species = format!("{}{protein}\n", rbc.trim_end().strip_suffix(')').unwrap());
    let tube = std::fs::read_to_string(repo("scenes/proteins/tube_sorting.ron")).unwrap();
    let (from, to) = (
        tube.find("    species: (").unwrap(),
        tube.rfind("\n)").unwrap(),
    );
    let tube_without = format!("{}{}", &tube[..from], &tube[to + 1..]);
    let cases = [
        (
            "red_blood_cell_642/with",
            "scenes/fluid/red_blood_cell.ron",
            rbc_species,
        ),
        (
            "red_blood_cell_642/without",
            "scenes/fluid/red_blood_cell.ron",
            rbc,
        ),
        (
            "tube_sorting/with",
            "scenes/proteins/tube_sorting.ron",
            tube,
        ),
        (
            "tube_sorting/without",
            "scenes/proteins/tube_sorting.ron",
            tube_without,
        ),
    ];
    // Ticks until the minimiser stops (at most 20 000); the iterations run.
    let run = |sim: &mut Simulation| {
        let mut ticks = 0;
        while ticks < 20_000 && sim.resource::<StopRequest>().0.is_none() {
            sim.tick().unwrap();
            ticks += 1;
        }
        ticks
    };
    let mut g = c.benchmark_group("species_run");
    g.warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(8))
        .sample_size(10);
    for (label, path, text) in &cases {
        let path = &repo(path);
        let scene = Scene::from_ron_str(text, path).unwrap();
        let iterations = run(&mut scene.build(path).unwrap());
        g.throughput(Throughput::Elements(iterations));
        g.bench_function(*label, |b| {
            b.iter_batched(
                || scene.build(path).unwrap(),
                |mut sim| {
                    assert_eq!(run(&mut sim), iterations);
                    sim
                },
                BatchSize::PerIteration,
            )
        });
    }
    g.finish();
}

criterion_group!(
    benches,
    each_system,
    species,
    species_ticks,
    rbc_all_forces,
    constraints,
    models,
    model_ticks
);
criterion_main!(benches);
