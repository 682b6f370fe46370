//! The open engine: force terms and systems that a user's crate registers
//! through the public API act on the dynamics exactly like built-in ones,
//! and a system gets only the resources it declared.

use glam::DVec3;
use remembrane::engine::force::{ForceContext, ForceTerm};
use remembrane::engine::resources::{CheckedResources, FetchError, Res, ResMut};
use remembrane::engine::schedule::{DynamicSystem, Stage, System};
use remembrane::engine::simulation::{
    BuildError, Clock, DensePositions, SimBuilder, SimError, Simulation,
};
use remembrane::scene::Scene;
use std::path::Path;

/// A uniform external field: E = −Σ_i F·x_i, so every vertex feels F.
struct UniformField(DVec3);

impl ForceTerm for UniformField {
    fn name(&self) -> &str {
        "uniform_field"
    }
    fn evaluate(&mut self, ctx: &ForceContext<'_>, force: Option<&mut [DVec3]>) -> f64 {
        for f in force.into_iter().flatten() {
            *f += self.0;
        }
        -ctx.positions.iter().map(|p| self.0.dot(*p)).sum::<f64>()
    }
}

/// Bending only (its net force is zero: translation invariance), no
/// noise, no penalty smoothing: the centroid moves by the field alone.
const SCENE: &str = r#"Scene(
    name: "field",
    membrane: Icosphere(level: 2, jitter: 0.02),
    energy: [Bending(kappa: 1.0)],
    penalty_smoothing: 0,
    dynamics: (mobility: 1.0, temperature: 0.0, dt_max: 1e-3, max_displacement: 0.01, iterations: 200),
)"#;

const MOBILITY: f64 = 1.0;
const FIELD: DVec3 = DVec3::new(0.3, -0.2, 0.5);
/// The centroid moves by μ F t up to the rounding of the bending forces'
/// zero net sum (~1e-13 per step); 200 steps of ≤ 1e-3 s.
const CENTROID_TOLERANCE: f64 = 1e-9;

/// The scene's simulation with what `add` registers on its builder.
fn scene_sim_with(add: impl FnOnce(&mut SimBuilder)) -> Simulation {
    scene_builder_with(add).build().unwrap()
}

fn scene_builder_with(add: impl FnOnce(&mut SimBuilder)) -> SimBuilder {
    let path = Path::new("field.ron");
    let mut builder = Scene::from_ron_str(SCENE, path)
        .unwrap()
        .builder(path)
        .unwrap();
    add(&mut builder);
    builder
}

fn centroid(sim: &Simulation) -> DVec3 {
    let p = sim.positions();
    p.iter().copied().sum::<DVec3>() / p.len() as f64
}

/// Runs 200 ticks and checks the centroid moved by μ F t.
fn assert_centroid_follows_the_field(sim: &mut Simulation) {
    sim.evaluate_forces().unwrap();
    let start = centroid(sim);
    for _ in 0..200 {
        sim.tick().unwrap();
    }
    let t = sim.clock().time;
    assert!(t > 0.0);
    let moved = centroid(sim) - start;
    let predicted = MOBILITY * FIELD * t;
    assert!(
        (moved - predicted).length() < CENTROID_TOLERANCE,
        "moved {moved:?}, predicted μFt = {predicted:?} (t = {t})"
    );
}

#[test]
fn a_force_term_added_to_the_scenes_builder_moves_the_centroid_by_mu_f_t() {
    let mut sim = scene_sim_with(|b| {
        b.add_force_term(UniformField(FIELD)).unwrap();
    });
    assert_centroid_follows_the_field(&mut sim);
    // It is reported, timed and summed like a built-in term.
    let buffers = sim.evaluate_forces().unwrap();
    assert_eq!(buffers.names(), ["bending", "uniform_field"]);
    let total: DVec3 = buffers.evaluation.total.iter().copied().sum();
    let n = buffers.evaluation.total.len() as f64;
    assert!((total / n - FIELD).length() < 1e-9, "{total:?}");
    drop(buffers);
    let timings = sim.schedule().timings();
    assert!(timings.iter().any(|t| t.system == "uniform_field"
        && t.stage == "Forces"
        && t.part_of.as_deref() == Some("force_terms")));
    // The force stage has its own row; the rows that are no system's part
    // add up to the whole time.
    assert!(
        timings
            .iter()
            .any(|t| t.system == "force_terms" && t.part_of.is_none())
    );
    let whole: f64 = timings
        .iter()
        .filter(|t| t.part_of.is_none())
        .map(|t| t.share)
        .sum();
    assert!((whole - 1.0).abs() < 1e-9, "shares add up to {whole}");
}

#[test]
fn a_plugin_registering_a_force_term_on_the_builder_moves_the_centroid_by_mu_f_t() {
    use remembrane::scene::plugins;
    let mesh = remembrane::mesh::icosphere(2, 1.0);
    let membrane = remembrane::mesh::membrane::Membrane::from_mesh(&mesh, false).unwrap();
    let initial = remembrane::engine::simulation::InitialState {
        vertices: mesh.vertex_count(),
        lipid_total: mesh.vertex_count() as f64,
        area: remembrane::mesh::geometry::total_area(&mesh.positions, &mesh.faces),
        volume: remembrane::mesh::geometry::enclosed_volume(
            &mesh.positions,
            &mesh.faces,
            DVec3::ZERO,
        ),
    };
    let field = |b: &mut SimBuilder| -> Result<(), BuildError> {
        b.add_force_term(UniformField(FIELD))?;
        Ok(())
    };
    let mut builder = SimBuilder::new(membrane, initial);
    builder
        .add_plugin(plugins::core(plugins::CoreSettings {
            dynamics: remembrane::params::DynamicsParams {
                mobility: MOBILITY,
                temperature: 0.0,
                dt_max: 1e-3,
                ..Default::default()
            },
            seed: 1,
            penalty_smoothing: 0,
            remesh: Default::default(),
        }))
        .unwrap()
        .add_plugin(remembrane::energy::bending::plugin(Default::default()))
        .unwrap()
        .add_plugin(field)
        .unwrap();
    assert_centroid_follows_the_field(&mut builder.build().unwrap());
}

#[test]
fn a_force_term_without_the_core_plugin_is_refused_with_the_reason() {
    let mesh = remembrane::mesh::icosphere(1, 1.0);
    let membrane = remembrane::mesh::membrane::Membrane::from_mesh(&mesh, false).unwrap();
    let initial = remembrane::engine::simulation::InitialState {
        vertices: 0,
        lipid_total: 0.0,
        area: 0.0,
        volume: 0.0,
    };
    let mut b = SimBuilder::new(membrane, initial);
    let err = b.add_force_term(UniformField(FIELD)).err().unwrap();
    assert!(err.to_string().contains("ForceBuffers"), "{err}");
    assert!(err.to_string().contains("core plugin"), "{err}");
}

#[test]
fn a_custom_term_that_goes_non_finite_stops_the_run_naming_it() {
    let mut sim = scene_sim_with(|b| {
        b.add_force_term(UniformField(DVec3::new(f64::NAN, 0.0, 0.0)))
            .unwrap();
    });
    let err = sim.tick().unwrap_err();
    assert!(
        matches!(&err, SimError::BlowUp { term, .. } if term == "uniform_field"),
        "{err}"
    );
    assert_eq!(sim.clock().iteration, 0);
}

#[test]
fn a_custom_term_passes_the_finite_difference_check() {
    let mut mesh = remembrane::mesh::icosphere(2, 1.0);
    mesh.jitter(0.05, 3);
    let mut membrane = remembrane::mesh::membrane::Membrane::from_mesh(&mesh, false).unwrap();
    let topology = membrane.topology().unwrap().clone();
    let report = remembrane::fd::check_force_term(
        &mut UniformField(FIELD),
        &membrane.world,
        &topology,
        &mesh.positions,
        &[],
        None,
        remembrane::fd::FdOptions::default(),
    );
    assert!(report.passed(), "{report:?}");
}

/// Counts ticks into its own resource: a plugin's own state without any
/// engine field.
struct TickCount(u64);
struct CountTicks;

impl System for CountTicks {
    type Data<'a> = (Res<'a, Clock>, ResMut<'a, TickCount>);
    fn name(&self) -> &str {
        "count_ticks"
    }
    fn run(&mut self, (clock, mut count): Self::Data<'_>) -> Result<(), SimError> {
        // Observe sees the state before the tick's step.
        assert_eq!(count.0, clock.iteration);
        count.0 += 1;
        Ok(())
    }
}

#[test]
fn a_plugin_adds_its_own_resource_and_system() {
    let mut sim = scene_sim_with(|b| {
        b.insert_resource(TickCount(0));
        b.add_system(Stage::Observe, CountTicks);
    });
    for _ in 0..5 {
        sim.tick().unwrap();
    }
    assert_eq!(sim.resource::<TickCount>().0, 5);
}

#[test]
fn a_system_declaring_a_resource_nobody_inserted_is_refused_by_build() {
    let builder = scene_builder_with(|b| {
        b.add_system(Stage::Observe, CountTicks);
    });
    let err = builder.build().err().unwrap();
    assert!(err.to_string().contains("TickCount"), "{err}");
}

/// A dynamic system that declares a read of the clock but then writes the
/// positions.
struct Undeclared;

impl DynamicSystem for Undeclared {
    fn name(&self) -> &str {
        "undeclared"
    }
    fn access(&self) -> remembrane::engine::resources::Access {
        remembrane::engine::resources::Access::default().read::<Clock>()
    }
    fn run(&mut self, res: &CheckedResources<'_>) -> Result<(), SimError> {
        let _clock = res.get::<Clock>().unwrap();
        let resource_error = |source| SimError::Resource {
            system: "undeclared".into(),
            source,
        };
        let mut p = res.get_mut::<DensePositions>().map_err(resource_error)?;
        p.0.clear();
        Ok(())
    }
}

#[test]
fn a_system_touching_a_resource_it_did_not_declare_is_rejected() {
    let mut sim = scene_sim_with(|b| {
        b.add_dynamic_system(Stage::Prepare, Undeclared);
    });
    sim.evaluate_forces().unwrap();
    let before = sim.positions();
    assert!(!before.is_empty());
    let err = sim.tick().unwrap_err();
    match &err {
        SimError::Resource {
            system,
            source: FetchError::Undeclared { resource, write },
        } => {
            assert_eq!(system, "undeclared");
            assert_eq!(resource.name(), "DensePositions");
            assert!(*write);
        }
        other => panic!("expected an undeclared access, got {other}"),
    }
    assert_eq!(sim.positions(), before, "nothing was written");
    assert_eq!(sim.clock().iteration, 0);
}

/// Parameters of the scene-declared uniform field.
#[derive(serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct FieldParams {
    /// The force on every vertex (Ē/l̄).
    force: (f64, f64, f64),
}

/// Parameters of the scene-declared tick counter (none).
#[derive(serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct NoParams {}

fn registry() -> remembrane::scene::registry::PluginRegistry {
    let mut r = remembrane::scene::registry::PluginRegistry::new();
    r.register_term("uniform_field", |p: FieldParams, b: &mut SimBuilder| {
        let (x, y, z) = p.force;
        b.add_force_term(UniformField(DVec3::new(x, y, z)))?;
        Ok(())
    });
    r.register_system("count_ticks", |_: NoParams, stage, b: &mut SimBuilder| {
        b.insert_resource(TickCount(0));
        b.add_system(stage, CountTicks);
        Ok(())
    });
    r
}

fn declared_scene(field: &str) -> String {
    SCENE.replace(
        "energy: [Bending(kappa: 1.0)],",
        &format!(
            "energy: [Bending(kappa: 1.0), {field}],\n    systems: [Custom(name: \"count_ticks\", stage: Observe)],"
        ),
    )
}

const DECLARED_FIELD: &str = "Custom(name: \"uniform_field\", params: (force: (0.3, -0.2, 0.5)))";

#[test]
fn a_scene_declared_plugin_term_moves_the_centroid_by_mu_f_t() {
    let path = Path::new("declared.ron");
    let scene =
        Scene::from_ron_str_with(&declared_scene(DECLARED_FIELD), path, &registry()).unwrap();
    let mut sim = scene.build(path).unwrap();
    assert_centroid_follows_the_field(&mut sim);
    assert_eq!(sim.resource::<TickCount>().0, 200);
}

#[test]
fn an_unknown_plugin_is_reported_at_its_position_with_the_registered_names() {
    let path = Path::new("declared.ron");
    let text = declared_scene("Custom(name: \"bar_domian\", params: ())");
    let err = Scene::from_ron_str_with(&text, path, &registry())
        .unwrap_err()
        .to_string();
    let line = text.lines().position(|l| l.contains("bar_domian")).unwrap() + 1;
    assert!(
        err.starts_with(&format!("declared.ron:{line}:"))
            && err.contains("field `energy[1].Custom.name`")
            && err.contains("unknown plugin \"bar_domian\" (registered: uniform_field)"),
        "{err}"
    );
    // Without a registry nothing is registered.
    let err = Scene::from_ron_str(&text, path).unwrap_err().to_string();
    assert!(err.contains("(registered: none)"), "{err}");
}

#[test]
fn plugin_params_are_validated_as_strictly_as_built_in_ones() {
    let path = Path::new("declared.ron");
    let text = declared_scene(
        "Custom(name: \"uniform_field\", params: (force: (0.3, -0.2, 0.5), strength: 2.0))",
    );
    let err = Scene::from_ron_str_with(&text, path, &registry())
        .unwrap_err()
        .to_string();
    let line = text.lines().position(|l| l.contains("strength")).unwrap() + 1;
    assert!(
        err.starts_with(&format!("declared.ron:{line}:"))
            && err.contains("energy[1].Custom.params")
            && err.contains("strength"),
        "{err}"
    );
    let text = declared_scene("Custom(name: \"uniform_field\", params: (force: 1.0))");
    let err = Scene::from_ron_str_with(&text, path, &registry())
        .unwrap_err()
        .to_string();
    assert!(err.contains("energy[1].Custom.params.force"), "{err}");
    // A system plugin needs its stage.
    let text = SCENE.replace(
        "energy: [Bending(kappa: 1.0)],",
        "energy: [Bending(kappa: 1.0)],\n    systems: [Custom(name: \"count_ticks\")],",
    );
    let err = Scene::from_ron_str_with(&text, path, &registry())
        .unwrap_err()
        .to_string();
    assert!(err.contains("systems[0]") && err.contains("stage"), "{err}");
}

#[test]
fn main_with_runs_a_scene_declaring_a_plugin_and_rejects_unknown_ones() {
    use remembrane::cli::main_with_args;
    use std::process::ExitCode;
    let dir = tempfile::tempdir().unwrap();
    let scene_file = dir.path().join("declared.ron");
    std::fs::write(&scene_file, declared_scene(DECLARED_FIELD)).unwrap();
    let out = dir.path().join("run");
    let args = [
        "my_membranes".as_ref(),
        "run".as_ref(),
        scene_file.as_os_str(),
        "--out".as_ref(),
        out.as_os_str(),
        "--quiet".as_ref(),
    ];
    assert_eq!(main_with_args(registry(), args), ExitCode::SUCCESS);
    let summary = crate::common::summary(&out);
    let t = summary.simulated_time;
    let energies: Vec<&str> = summary
        .last
        .energies
        .iter()
        .map(|e| e.term.as_str())
        .collect();
    assert_eq!(energies, ["bending", "uniform_field"]);
    let initial =
        Scene::from_ron_str_with(&declared_scene(DECLARED_FIELD), &scene_file, &registry())
            .unwrap()
            .initial_mesh(&scene_file)
            .unwrap();
    let last = remembrane::mesh::io::read_mesh(&out.join("final.ply")).unwrap();
    let mean = |p: &[DVec3]| p.iter().copied().sum::<DVec3>() / p.len() as f64;
    let moved = mean(&last.positions) - mean(&initial.positions);
    assert!(
        (moved - MOBILITY * FIELD * t).length() < CENTROID_TOLERANCE,
        "moved {moved:?} in t = {t}"
    );
    // The same scene with a misspelt plugin: bad input, exit 2, no output.
    let bad = dir.path().join("bad.ron");
    std::fs::write(&bad, declared_scene("Custom(name: \"nope\", params: ())")).unwrap();
    let out_bad = dir.path().join("bad_run");
    let args = [
        "my_membranes".as_ref(),
        "run".as_ref(),
        bad.as_os_str(),
        "--out".as_ref(),
        out_bad.as_os_str(),
        "--quiet".as_ref(),
    ];
    assert_eq!(main_with_args(registry(), args), ExitCode::from(2));
    assert!(!out_bad.exists());
    let check = ["my_membranes".as_ref(), "check".as_ref(), bad.as_os_str()];
    assert_eq!(main_with_args(registry(), check), ExitCode::from(2));
}

/// Counts its evaluations (zero force) and records a column and a field.
struct Counting(std::sync::Arc<std::sync::atomic::AtomicU64>);

impl ForceTerm for Counting {
    fn name(&self) -> &str {
        "counting"
    }
    fn evaluate(&mut self, _: &ForceContext<'_>, force: Option<&mut [DVec3]>) -> f64 {
        if force.is_some() {
            self.0.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        }
        0.0
    }
}

/// A column `height` (max z) and a point array `height_field` (z).
struct Height;

impl remembrane::engine::recorder::Recorder for Height {
    type Data<'a> = Res<'a, DensePositions>;
    fn name(&self) -> &str {
        "height"
    }
    fn record(
        &mut self,
        p: Self::Data<'_>,
        frame: &mut remembrane::engine::recorder::FrameData,
    ) -> Result<(), SimError> {
        let z: Vec<f64> = p.0.iter().map(|p| p.z).collect();
        frame.column("height", z.iter().copied().fold(f64::MIN, f64::max));
        frame.scalars("height_field", z);
        Ok(())
    }
}

#[test]
fn a_recorder_adds_a_column_and_point_data_and_frames_reuse_the_ticks_forces() {
    use remembrane::workflow::run::{RunOptions, run_scene};
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("field.ron");
    std::fs::write(&path, SCENE).unwrap();
    let scene = Scene::load(&path).unwrap();
    let out = dir.path().join("run");
    let options = RunOptions {
        iterations: Some(100),
        frames: Some(10),
        ..RunOptions::quiet(&out)
    };
    let calls = std::sync::Arc::new(std::sync::atomic::AtomicU64::new(0));
    let counter = calls.clone();
    let summary = run_scene(&scene, &path, &options, move |sim| {
        sim.add_force_term(Counting(counter))?;
        sim.add_recorder(Height);
        Ok(())
    })
    .unwrap();
    assert_eq!(summary.frames.len(), 11);
    // One evaluation per tick plus the final state's: frames add none.
    assert_eq!(calls.load(std::sync::atomic::Ordering::Relaxed), 100 + 1);
    let series = remembrane::io::run_dir::Series::read(&out).unwrap();
    assert_eq!(series.columns.last().map(String::as_str), Some("height"));
    assert!(series.index("energy_counting").is_ok());
    assert_eq!(series.rows.len(), 11);
    let frame = std::fs::read_to_string(out.join(&summary.frames[3].file)).unwrap();
    assert!(
        frame.contains("Name=\"height_field\""),
        "no height_field array"
    );
    assert!(
        summary
            .timings
            .iter()
            .any(|t| t.system == "frames" && t.stage == "Output")
    );
    assert!(
        summary
            .timings
            .iter()
            .any(|t| t.system == "record_height" && t.stage == "Observe")
    );
}

/// A field that grows by `step` with every evaluation: its count is state
/// the term carries from one tick to the next.
struct GrowingField {
    step: DVec3,
    evaluations: u64,
}

impl ForceTerm for GrowingField {
    fn name(&self) -> &str {
        "growing_field"
    }
    fn evaluate(&mut self, ctx: &ForceContext<'_>, force: Option<&mut [DVec3]>) -> f64 {
        if let Some(force) = force {
            self.evaluations += 1;
            let f = self.step * self.evaluations as f64;
            for x in force.iter_mut() {
                *x += f;
            }
        }
        let f = self.step * self.evaluations as f64;
        -ctx.positions.iter().map(|p| f.dot(*p)).sum::<f64>()
    }
    fn save_state(&self) -> Option<serde_json::Value> {
        Some(serde_json::json!(self.evaluations))
    }
    fn restore_state(
        &mut self,
        state: serde_json::Value,
    ) -> Result<(), remembrane::engine::error::StateError> {
        self.evaluations = state.as_u64().ok_or("expected a count")?;
        Ok(())
    }
}

/// A plugin term's own state goes into the checkpoint's persisted
/// resources and comes back: a run restored from it after 10 ticks
/// continues with the same bits as the run that went on.
#[test]
fn a_force_terms_own_state_is_saved_and_restored_with_the_run() {
    use remembrane::engine::persisted::PersistedResources;
    let make = || {
        scene_sim_with(|b| {
            b.add_force_term(GrowingField {
                step: FIELD * 1e-3,
                evaluations: 0,
            })
            .unwrap();
        })
    };
    let mut straight = make();
    for _ in 0..10 {
        straight.tick().unwrap();
    }
    let saved = {
        let p = straight.resources().get::<PersistedResources>().unwrap();
        p.save(straight.resources()).unwrap()
    };
    assert_eq!(
        saved["force terms"],
        serde_json::json!({"growing_field": 10})
    );
    let mut resumed = make();
    let snapshot =
        remembrane::io::world_snapshot::WorldSnapshot::capture(&straight.membrane()).unwrap();
    snapshot.restore(resumed.membrane_mut()).unwrap();
    {
        let p = resumed.resources().get::<PersistedResources>().unwrap();
        p.restore(resumed.resources(), &saved).unwrap();
    }
    for _ in 0..5 {
        straight.tick().unwrap();
        resumed.tick().unwrap();
    }
    assert_eq!(straight.positions(), resumed.positions());
}

/// A plugin's own section of `summary.json`: the centroid of the final
/// state, written beside the summary's fields and read back typed.
struct CentroidSection(&'static str);

impl remembrane::engine::summary_section::SummarySection for CentroidSection {
    fn name(&self) -> &str {
        self.0
    }
    fn measure(&self, sim: &Simulation) -> Option<serde_json::Value> {
        Some(serde_json::json!({ "centroid": centroid(sim).to_array() }))
    }
}

#[test]
fn a_plugin_adds_its_own_section_to_the_summary() {
    use remembrane::workflow::run::{RunError, RunOptions, run_scene};
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("field.ron");
    std::fs::write(&path, SCENE).unwrap();
    let scene = Scene::load(&path).unwrap();
    let out = dir.path().join("run");
    let summary = run_scene(&scene, &path, &RunOptions::quiet(&out), |b| {
        b.add_summary_section(CentroidSection("field_probe"))?;
        Ok(())
    })
    .unwrap();
    #[derive(serde::Deserialize)]
    struct Probe {
        centroid: [f64; 3],
    }
    let written = crate::common::summary(&out);
    let probe: Probe = written.section("field_probe").unwrap().unwrap();
    assert_eq!(
        probe.centroid,
        summary
            .section::<Probe>("field_probe")
            .unwrap()
            .unwrap()
            .centroid
    );
    assert!(probe.centroid.iter().all(|c| c.is_finite()));
    // At the top level of the file, beside the summary's own fields.
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    assert!(json["field_probe"]["centroid"].is_array());
    assert!(written.section::<Probe>("absent").unwrap().is_none());

    // A section may not take a name the summary has, nor one another
    // section has, nor one that is not letters, digits and `_`.
    let refused = run_scene(
        &scene,
        &path,
        &RunOptions::quiet(dir.path().join("taken")),
        |b| {
            b.add_summary_section(CentroidSection("energies"))?;
            Ok(())
        },
    )
    .unwrap_err();
    assert!(matches!(refused, RunError::Scene(_)), "{refused}");
    assert!(refused.to_string().contains("`energies`"), "{refused}");
    assert!(!dir.path().join("taken").exists());
    let mut builder = scene_builder_with(|_| {});
    builder
        .add_summary_section(CentroidSection("twice"))
        .unwrap();
    let twice = builder
        .add_summary_section(CentroidSection("twice"))
        .err()
        .unwrap();
    assert!(twice.to_string().contains("another section"), "{twice}");
    let spaced = builder
        .add_summary_section(CentroidSection("a b"))
        .err()
        .unwrap();
    assert!(spaced.to_string().contains("letters, digits"), "{spaced}");
}
