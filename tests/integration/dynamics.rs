//! The schedule, the adaptive time step, integration, determinism, a short
//! red-blood-cell run, blow-up reporting and frames read by VTK itself.

use glam::DVec3;
use remembrane::energy::vin::{Segmentation, VinParams};
use remembrane::engine::force::ForceBuffers;
use remembrane::engine::resources::{ResMut, ResourceId, Resources};
use remembrane::engine::schedule::{ScheduleBuilder, ScheduleError, Stage, System};
use remembrane::engine::simulation::{
    BuildError, Clock, DensePositions, Seed, SimError, Simulation,
};
use remembrane::io::summary::RunStatus;
use remembrane::mesh::icosphere;
use remembrane::mesh::membrane::Membrane;
use remembrane::params::DynamicsParams;
use remembrane::scene::Scene;
use remembrane::timestep::{Limiter, choose_time_step, edge_time_step};
use remembrane::workflow::run::{RunOptions, run_scene};
use std::path::{Path, PathBuf};

use crate::common;

fn rbc() -> Simulation {
    let path = crate::common::scene("red_blood_cell.ron");
    Scene::load(&path).unwrap().build(&path).unwrap()
}

struct Named(&'static str);

impl System for Named {
    type Data<'a> = ();
    fn name(&self) -> &str {
        self.0
    }
    fn run(&mut self, _: ()) -> Result<(), SimError> {
        Ok(())
    }
}

fn sys(name: &'static str) -> Named {
    Named(name)
}

/// A Forces-stage system that moves the vertices.
struct Sneaky;

impl System for Sneaky {
    type Data<'a> = ResMut<'a, DensePositions>;
    fn name(&self) -> &str {
        "sneaky"
    }
    fn run(&mut self, mut p: Self::Data<'_>) -> Result<(), SimError> {
        p.0.clear();
        Ok(())
    }
}

/// A Forces-stage system that writes the clock.
struct ClockWriter;

impl System for ClockWriter {
    type Data<'a> = ResMut<'a, Clock>;
    fn name(&self) -> &str {
        "bad"
    }
    fn run(&mut self, mut c: Self::Data<'_>) -> Result<(), SimError> {
        c.iteration += 1;
        Ok(())
    }
}

fn with_positions() -> Resources {
    let mut r = Resources::new();
    r.insert(DensePositions::default());
    r.insert(ForceBuffers::default());
    r
}

#[test]
fn schedule_validation_errors() {
    let mut b = ScheduleBuilder::new();
    b.add(Stage::Prepare, sys("a"));
    b.add(Stage::Observe, sys("a"));
    assert_eq!(
        b.build(&Resources::new()).err(),
        Some(ScheduleError::DuplicateName("a".into()))
    );

    let mut b = ScheduleBuilder::new();
    b.add(Stage::Prepare, sys("a")).after("nowhere");
    assert!(matches!(
        b.build(&Resources::new()).err(),
        Some(ScheduleError::UnknownOrderTarget { .. })
    ));

    // Ordering constraints do not cross stages.
    let mut b = ScheduleBuilder::new();
    b.add(Stage::Prepare, sys("a"));
    b.add(Stage::Observe, sys("b")).after("a");
    assert!(matches!(
        b.build(&Resources::new()).err(),
        Some(ScheduleError::UnknownOrderTarget { .. })
    ));

    let mut b = ScheduleBuilder::new();
    b.add(Stage::Remesh, sys("a")).before("b");
    b.add(Stage::Remesh, sys("b")).before("c");
    b.add(Stage::Remesh, sys("c")).before("a");
    match b.build(&Resources::new()).err() {
        Some(ScheduleError::Cycle { stage, systems }) => {
            assert_eq!(stage, "Remesh");
            assert!(systems.contains('a') && systems.contains('c'));
        }
        other => panic!("expected a cycle, got {other:?}"),
    }

    // A stage restricted to the force buffers (as the core plugin restricts
    // the Forces stage) refuses any other write; an unrestricted one allows it.
    let mut b = ScheduleBuilder::new();
    b.add(Stage::Forces, Sneaky);
    b.restrict_writes(Stage::Forces, &[ResourceId::of::<ForceBuffers>()]);
    assert_eq!(
        b.build(&with_positions()).err(),
        Some(ScheduleError::StageWrites {
            system: "sneaky".into(),
            stage: "Forces",
            resource: "DensePositions",
            allowed: "ForceBuffers".into(),
        })
    );
    let mut b = ScheduleBuilder::new();
    b.add(Stage::Forces, Sneaky);
    b.restrict_writes(Stage::Integrate, &[ResourceId::of::<ForceBuffers>()]);
    assert!(b.build(&with_positions()).is_ok());

    // A declared resource that no plugin inserted.
    let mut b = ScheduleBuilder::new();
    b.add(Stage::Integrate, Sneaky);
    match b.build(&Resources::new()).err() {
        Some(ScheduleError::MissingResource {
            system, resource, ..
        }) => {
            assert_eq!(system, "sneaky");
            assert_eq!(resource.name(), "DensePositions");
        }
        other => panic!("expected a missing resource, got {other:?}"),
    }

    assert!(matches!(
        Stage::from_name("Forcez"),
        Err(ScheduleError::UnknownStage(_))
    ));
}

#[test]
fn schedule_orders_within_stages_and_keeps_registration_order() {
    let mut b = ScheduleBuilder::new();
    b.add(Stage::Observe, sys("late"));
    b.add(Stage::Prepare, sys("p1"));
    b.add(Stage::Prepare, sys("p2")).before("p1");
    b.add(Stage::Prepare, sys("p3"));
    let order: Vec<String> = b
        .build(&Resources::new())
        .unwrap()
        .order()
        .into_iter()
        .map(|(_, n)| n)
        .collect();
    assert_eq!(order, ["p2", "p1", "p3", "late"]);
}

#[test]
fn invalid_user_schedule_is_refused_by_build() {
    let path = crate::common::scene("red_blood_cell.ron");
    let mut builder = Scene::load(&path).unwrap().builder(&path).unwrap();
    builder.add_system(Stage::Forces, ClockWriter);
    assert!(matches!(
        builder.build(),
        Err(BuildError::Schedule(ScheduleError::StageWrites { .. }))
    ));
}

#[test]
fn time_step_controller_moves_no_edge_past_the_next_segment() {
    let seg = Segmentation::new(VinParams::default());
    let mut mesh = icosphere(2, 1.0);
    mesh.jitter(0.3, 5);
    let edges = mesh.edges();
    let mobility = 1000.0;
    // Pseudo-random forces of O(1) Ē/l̄.
    let forces: Vec<DVec3> = (0..mesh.vertex_count())
        .map(|i| {
            let x = i as f64;
            DVec3::new((x * 1.3).sin(), (x * 0.7).cos(), (x * 2.1).sin() * 0.5)
        })
        .collect();
    let choice = choose_time_step(
        Some(&seg),
        &edges,
        &[],
        &mesh.positions,
        &forces,
        mobility,
        1e9,
        1e9,
    );
    assert!(matches!(choice.limiter, Limiter::Edge(_)));
    let moved: Vec<DVec3> = mesh
        .positions
        .iter()
        .zip(&forces)
        .map(|(p, f)| *p + mobility * choice.dt * *f)
        .collect();
    for &[a, b] in &edges {
        let before =
            seg.segment_of(mesh.positions[a as usize].distance(mesh.positions[b as usize]));
        let after = seg.segment_of(moved[a as usize].distance(moved[b as usize]));
        assert!(
            after.abs_diff(before) <= 1,
            "edge ({a},{b}) jumped from segment {before} to {after}"
        );
    }
    // Halving the forces doubles the step (the criterion is linear in F).
    let half: Vec<DVec3> = forces.iter().map(|f| 0.5 * *f).collect();
    let c2 = choose_time_step(
        Some(&seg),
        &edges,
        &[],
        &mesh.positions,
        &half,
        mobility,
        1e9,
        1e9,
    );
    assert!((c2.dt / choice.dt - 2.0).abs() < 1e-9);

    // B = 0 never limits; caps are respected.
    assert_eq!(edge_time_step(&seg, 1.0, 0.0), f64::INFINITY);
    let zero = vec![DVec3::ZERO; mesh.vertex_count()];
    let c = choose_time_step(
        Some(&seg),
        &edges,
        &[],
        &mesh.positions,
        &zero,
        mobility,
        0.005,
        10.0,
    );
    assert_eq!((c.dt, c.limiter), (0.005, Limiter::Cap));
    let c = choose_time_step(
        Some(&seg),
        &edges,
        &[],
        &mesh.positions,
        &forces,
        mobility,
        0.005,
        1e-6,
    );
    assert!(matches!(c.limiter, Limiter::Displacement(_)));
    let max_step = forces
        .iter()
        .map(|f| mobility * c.dt * f.length())
        .fold(0.0, f64::max);
    assert!(max_step <= 1e-6 * (1.0 + 1e-12));
    // Without V_in only the caps apply.
    let c = choose_time_step(
        None,
        &edges,
        &[],
        &mesh.positions,
        &forces,
        mobility,
        0.005,
        10.0,
    );
    assert_eq!(c.dt, 0.005);
}

#[test]
fn time_step_targets_the_neighbouring_midpoints() {
    let seg = Segmentation::new(VinParams::default());
    for l in [0.02, 0.3, 0.75, 1.0, 1.3, 1.9, 2.15] {
        let s = seg.segment_of(l);
        let b = 1.0;
        let up = edge_time_step(&seg, l, b);
        let down = edge_time_step(&seg, l, -b);
        let l_up = (l * l + b * up).sqrt();
        let l_down = (l * l - b * down).max(0.0).sqrt();
        assert!((l_up - seg.midpoint_above(s)).abs() < 1e-12, "l = {l}");
        assert!((l_down - seg.midpoint_below(s)).abs() < 1e-9, "l = {l}");
        assert!(up > 0.0 && down > 0.0);
    }
}

fn run_ticks(sim: &mut Simulation, n: u64) {
    for _ in 0..n {
        sim.tick().unwrap();
    }
}

#[test]
#[ignore = "slow tier: `.ci/run` runs it; by hand: cargo test -- --ignored --skip by_hand_"]
fn runs_are_bit_identical_for_any_thread_count() {
    let run = |threads: usize, temperature: f64, seed: u64| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let mut sim = rbc();
            sim.resource_mut::<DynamicsParams>().temperature = temperature;
            sim.resource_mut::<Seed>().0 = seed;
            run_ticks(&mut sim, 300);
            sim.positions()
        })
    };
    let bits = |p: &[DVec3]| {
        p.iter()
            .flat_map(|v| v.to_array().map(f64::to_bits))
            .collect::<Vec<_>>()
    };
    assert_eq!(bits(&run(1, 0.0, 1)), bits(&run(2, 0.0, 1)));
    let noisy = run(1, 0.1, 7);
    assert_eq!(bits(&noisy), bits(&run(2, 0.1, 7)));
    assert_ne!(
        bits(&noisy),
        bits(&run(1, 0.1, 8)),
        "the seed must matter with noise"
    );
    assert_ne!(
        bits(&noisy),
        bits(&run(1, 0.0, 7)),
        "noise must move the vertices"
    );
}

#[test]
#[ignore = "slow tier: `.ci/run` runs it; by hand: cargo test -- --ignored --skip by_hand_"]
fn short_rbc_run_lowers_the_energy_and_approaches_the_target_volume() {
    let mut sim = rbc();
    sim.evaluate_forces().unwrap();
    let target = 733.8;
    let volume = |s: &Simulation| {
        let membrane = s.resource::<Membrane>();
        let p = s.positions();
        remembrane::mesh::geometry::enclosed_volume(&p, &membrane.cached_topology().faces, p[0])
    };
    // The deflating sphere first shrinks fast, then sits near a saddle
    // (v ≈ 1 at reduced area) until the jitter grows into a shape change:
    // compare iterations 0, 500, 5000 and 10000.
    let mut energies = vec![sim.resource::<ForceBuffers>().evaluation.total_energy()];
    let mut volumes = vec![volume(&sim)];
    for n in [500, 4500, 5000] {
        run_ticks(&mut sim, n);
        energies.push(sim.resource::<ForceBuffers>().evaluation.total_energy());
        volumes.push(volume(&sim));
    }
    println!("energies {energies:?}\nvolumes {volumes:?}");
    for w in energies.windows(2) {
        assert!(w[1] < w[0], "energy must decrease: {energies:?}");
    }
    for w in volumes.windows(2) {
        assert!(
            (w[1] - target).abs() < (w[0] - target).abs(),
            "volumes {volumes:?}"
        );
    }
    assert!(
        (volumes[3] - target).abs() < 0.1 * (volumes[0] - target).abs(),
        "volumes {volumes:?}"
    );
    // Simulated time advances by the adaptive steps, each ≤ dt_max.
    assert!(sim.clock().time > 0.0 && sim.clock().time <= 10000.0 * 0.005);
}

fn options(out: &Path) -> RunOptions {
    RunOptions {
        check_invariants: Some(true),
        ..RunOptions::quiet(out)
    }
}

#[test]
fn a_blow_up_is_reported_and_the_last_good_frame_kept() {
    // An absurd mobility without V_in or displacement cap: the first step
    // throws vertices to ~1e298, the next forces overflow.
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("run");
    let err = run_unstable(dir.path(), &out, 1e300);
    let msg = err.to_string();
    println!("{msg}");
    assert!(
        msg.contains("blow-up at iteration") && msg.contains("vertex"),
        "{msg}"
    );
    assert!(
        msg.contains("`volume`") || msg.contains("`bending`") || msg.contains("langevin"),
        "{msg}"
    );
    assert_eq!(err.exit_code(), 1);
    let summary = common::summary(&out);
    assert_eq!(summary.status, RunStatus::BlewUp);
    let last = summary.last_good_frame.unwrap();
    assert!(out.join(last).exists());
    // Every written frame is finite.
    for f in &summary.frames {
        assert!(common::frame_is_finite(&out.join(&f.file)));
    }
    assert!(!dir.path().join("run.incomplete").exists());
}

#[test]
fn outputs_are_complete_and_existing_directories_are_not_mixed() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("rbc");
    let path = crate::common::scene("red_blood_cell.ron");
    let scene = Scene::load(&path).unwrap();
    let opts = RunOptions {
        iterations: Some(200),
        frames: Some(4),
        ..options(&out)
    };
    let summary = run_scene(&scene, &path, &opts, |_| Ok(())).unwrap();
    assert_eq!(summary.iterations, 200);
    assert_eq!(summary.frames.len(), 5);
    for f in ["summary.json", "series.csv", "run.pvd", "final.ply"] {
        assert!(out.join(f).exists(), "{f} missing");
    }
    let series = remembrane::io::run_dir::Series::read(&out).unwrap();
    assert_eq!(series.rows.len(), 5);
    let mesh = remembrane::mesh::io::read_mesh(&out.join("final.ply")).unwrap();
    assert_eq!(mesh.vertex_count(), 642);
    assert!(
        summary
            .timings
            .iter()
            .any(|t| t.system == "bending" && t.per_tick_us > 0.0)
    );
    // A second run into the same directory is refused, not mixed.
    let again = run_scene(&scene, &path, &opts, |_| Ok(())).unwrap_err();
    assert_eq!(again.exit_code(), 2);
    assert!(again.to_string().contains("already exists"));
}

/// The frame of a 50-iteration RBC run (its run directory stays alive).
fn rbc_frame() -> (tempfile::TempDir, PathBuf, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("rbc");
    let path = crate::common::scene("red_blood_cell.ron");
    let scene = Scene::load(&path).unwrap();
    let opts = RunOptions {
        iterations: Some(50),
        frames: Some(1),
        ..options(&out)
    };
    let summary = run_scene(&scene, &path, &opts, |_| Ok(())).unwrap();
    let frame = out.join(&summary.frames.last().unwrap().file);
    (dir, out, frame)
}

/// Needs nothing outside cargo: the frame parsed back by an independent
/// VTK XML reader (vtkio's), its points, triangles and point data checked.
#[test]
fn frames_are_read_back_by_a_vtk_xml_parser() {
    use vtkio::model::{Attribute, DataSet, VertexNumbers};
    let (_dir, out, frame) = rbc_frame();
    let vtk = vtkio::Vtk::import(&frame).unwrap();
    let DataSet::PolyData { pieces, .. } = vtk.data else {
        panic!("not PolyData")
    };
    let piece = pieces[0].load_piece_data(None).unwrap();
    let points: Vec<f64> = piece.points.cast_into().unwrap();
    assert_eq!(points.len(), 3 * 642);
    let Some(VertexNumbers::XML {
        connectivity,
        offsets,
    }) = &piece.polys
    else {
        panic!("no polygons")
    };
    assert_eq!(offsets.len(), 1280);
    assert_eq!(connectivity.len(), 3 * 1280);
    let arrays: Vec<(String, usize)> = piece
        .data
        .point
        .iter()
        .map(|a| match a {
            Attribute::DataArray(d) => (d.name.clone(), d.data.len() / d.elem.num_comp() as usize),
            Attribute::Field { name, .. } => (name.clone(), 0),
        })
        .collect();
    assert!(arrays.contains(&("force".to_string(), 642)), "{arrays:?}");
    assert!(
        arrays.contains(&("mean_curvature".to_string(), 642)),
        "{arrays:?}"
    );
    let mesh = remembrane::mesh::io::read_mesh(&out.join("final.ply")).unwrap();
    let p0 = mesh.positions[0];
    for (k, c) in [p0.x, p0.y, p0.z].iter().enumerate() {
        assert!((points[k] - c).abs() < 1e-12);
    }
}

/// VTK's own reader (Python's `vtk` package); `.ci/run` installs it and runs
/// the ignored tests.
#[test]
#[ignore = "needs Python's vtk package (.ci/run installs it and runs it)"]
fn frames_are_read_back_by_vtk() {
    let (_dir, out, frame) = rbc_frame();
    let script = crate::common::repo("tests/integration/common/read_vtp.py");
    let result = std::process::Command::new("python3")
        .arg(&script)
        .arg(&frame)
        .output()
        .expect("python3 runs");
    assert!(
        result.status.success(),
        "VTK could not read the frame (is the `vtk` Python package installed? .ci/run installs it): {}",
        String::from_utf8_lossy(&result.stderr)
    );
    let json: serde_json::Value = serde_json::from_slice(&result.stdout).unwrap();
    assert_eq!(json["points"], 642);
    assert_eq!(json["polys"], 1280);
    assert_eq!(json["arrays"]["force"]["components"], 3);
    assert_eq!(json["arrays"]["force"]["tuples"], 642);
    assert_eq!(json["arrays"]["mean_curvature"]["tuples"], 642);
    let mesh = remembrane::mesh::io::read_mesh(&out.join("final.ply")).unwrap();
    let p0 = mesh.positions[0];
    for (k, c) in [p0.x, p0.y, p0.z].iter().enumerate() {
        assert!((json["first_point"][k].as_f64().unwrap() - c).abs() < 1e-12);
    }
}

#[test]
fn a_step_that_folds_the_mesh_stops_the_run_with_finite_frames_only() {
    // A stiff volume penalty without V_in or displacement cap, stepped far
    // above its stability limit: before anything overflows, a vertex
    // crosses the opposite edge of a face (finite garbage), which stops the
    // run.
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("run");
    let err = run_unstable(dir.path(), &out, 1000.0);
    let msg = err.to_string();
    assert!(
        (msg.contains("mesh folded at iteration") || msg.contains("turned inside out"))
            && msg.contains("lower dynamics.dt_max"),
        "{msg}"
    );
    assert_eq!(err.exit_code(), 1);
    assert_eq!(common::summary(&out).status, RunStatus::BlewUp);
    // The final mesh is the last good one: no face turned over relative to
    // the initial mesh's orientation check.
    let mesh = remembrane::mesh::io::read_mesh(&out.join("final.ply")).unwrap();
    assert!(remembrane::mesh::check_mesh(&mesh.positions, &mesh.faces, None).is_ok());
}

#[test]
fn turned_faces_are_found() {
    use remembrane::mesh::step_check::check_step;
    let before = [DVec3::ZERO, DVec3::X, DVec3::Y];
    let faces = [[0u32, 1, 2]];
    // Moving vertex 2 across the edge 0-1 turns the face over.
    let after = [DVec3::ZERO, DVec3::X, DVec3::new(0.3, -0.2, 0.0)];
    assert_eq!(check_step(&faces, &before, &after).0, Some(0));
    let moved = [DVec3::ZERO, DVec3::X, DVec3::new(0.3, 0.4, 0.1)];
    assert_eq!(check_step(&faces, &before, &moved).0, None);
    // The volume is the enclosed volume of a closed mesh (unit icosphere
    // scaled to mean edge 1: 1212.66, SPEC reference values).
    let mesh = remembrane::mesh::icosphere(3, 1.0);
    let (turned, volume) = check_step(&mesh.faces, &mesh.positions, &mesh.positions);
    assert_eq!(turned, None);
    assert!((volume - 1212.66).abs() < 0.01, "{volume}");
    // A point reflection keeps every normal but turns the membrane inside out.
    let reflected: Vec<DVec3> = mesh.positions.iter().map(|p| -*p).collect();
    let (turned, volume) = check_step(&mesh.faces, &mesh.positions, &reflected);
    assert_eq!(turned, None);
    assert!(volume < 0.0);
}

/// Runs a stiff volume penalty without V_in, displacement cap or bending
/// stability bound, at
/// `mobility`, from `dir` into `out`; the run is expected to stop.
fn run_unstable(dir: &Path, out: &Path, mobility: f64) -> remembrane::workflow::run::RunError {
    let text = format!(
        r#"Scene(
        name: "unstable",
        membrane: Icosphere(level: 2, jitter: 0.05),
        energy: [Bending(kappa: 5.0), Volume(k: 100.0, target: OfInitial(0.5))],
        penalty_smoothing: 0,
        dynamics: (mobility: {mobility:e}, dt_max: 0.01, max_displacement: 1e300, iterations: 500, frames: 100,
            bending_step_limit: false),
    )"#
    );
    let path = dir.join("unstable.ron");
    std::fs::write(&path, text).unwrap();
    let scene = Scene::load(&path).unwrap();
    run_scene(&scene, &path, &options(out), |_| Ok(())).unwrap_err()
}

/// The edges measured once per tick (`VinEdgeSamples`) give the V_in force
/// and the time step exactly what measuring them in place gives, bit for
/// bit.
#[test]
fn measured_edge_samples_change_no_bit_of_the_vin_force_or_the_time_step() {
    use remembrane::energy::vin::VinEdgeSamples;
    use remembrane::engine::force::{ForceContext, ForceTerm};
    use std::sync::Arc;
    let seg = Arc::new(Segmentation::new(VinParams::default()));
    let mut mesh = icosphere(3, 1.0);
    mesh.jitter(0.25, 11);
    let mut m = Membrane::from_mesh(&mesh, false).unwrap();
    let t = m.topology().unwrap().clone();
    let mut samples = VinEdgeSamples::default();
    samples.measure(&t.edges, &mesh.positions, |l| seg.segment_of(l));
    let mut geometry = Vec::new();
    let in_place = ForceContext::new(&m.world, &t, &mesh.positions, &[], &mut geometry, false);
    let mut vin = remembrane::energy::vin::VinForces::new(
        seg.clone(),
        remembrane::energy::vin::VinForm::PiecewiseLinear,
    );
    let mut f_in_place = vec![DVec3::ZERO; mesh.positions.len()];
    let e_in_place = vin.accumulate(&in_place, &mut f_in_place);
    let mut inputs = remembrane::engine::term_inputs::TermInputs::default();
    inputs.insert(samples.clone());
    let measured = ForceContext {
        inputs: &inputs,
        ..in_place
    };
    let mut f_measured = vec![DVec3::ZERO; mesh.positions.len()];
    let e_measured = vin.accumulate(&measured, &mut f_measured);
    assert_eq!(e_in_place.to_bits(), e_measured.to_bits());
    assert!(
        f_in_place
            .iter()
            .zip(&f_measured)
            .all(|(a, b)| a.to_array().map(f64::to_bits) == b.to_array().map(f64::to_bits))
    );
    let choose = |s: &[remembrane::energy::vin::EdgeSample]| {
        choose_time_step(
            Some(&seg),
            &t.edges,
            s,
            &mesh.positions,
            &f_in_place,
            1000.0,
            1e9,
            1e9,
        )
    };
    let (a, b) = (choose(&[]), choose(&samples.0));
    assert!(matches!(a.limiter, Limiter::Edge(_)));
    assert_eq!((a.dt.to_bits(), a.limiter), (b.dt.to_bits(), b.limiter));
}
