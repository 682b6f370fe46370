//! `remembrane.Simulation`: a scene's simulation, stepped or run from
//! Python through the same code as the CLI.

use crate::convert::{index_array, json_to_py, vec3_array};
use crate::errors::{scene_error, simulation_error};
use crate::force_term::{PyForceTerm, TermErrors};
use crate::interrupt::run_detached;
use crate::scene::PyScene;
use glam::DVec3;
use numpy::{PyArray1, PyArray2};
use pyo3::exceptions::{PyFileExistsError, PyKeyError, PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use remembrane::engine::force::ForceBuffers;
use remembrane::engine::resources::Res;
use remembrane::engine::simulation::SimError;
use remembrane::engine::simulation::{Clock, Simulation};
use remembrane::io::report::EnergyReport;
use remembrane::mesh::membrane::Membrane;
use remembrane::mesh::quality::MeshQuality;
use remembrane::remesh::RemeshStats;
use remembrane::workflow::run::{
    PendingRun, PreparedRun, Progress, RunError, RunOptions, drive_run,
};
use std::path::PathBuf;
use std::sync::{Mutex, MutexGuard, TryLockError};
use std::time::Instant;

/// The simulation's life: a builder until it is first evaluated, stepped or
/// run, then the sealed simulation.
enum State {
    /// The scene's builder; Python force terms join it.
    Pending(PendingRun),
    /// Built and sealed.
    Built(PreparedRun),
    /// Only while the builder is being sealed.
    Sealing,
}

/// Everything behind the lock: the engine's simulation (or its builder) and
/// what a changed scene needs to be built again.
pub(crate) struct Inner {
    state: State,
    scene: PyScene,
    check_invariants: bool,
    python_terms: Vec<(String, Py<PyAny>)>,
    errors: TermErrors,
    /// Set once `run()` has been called: the simulation cannot be stepped
    /// again.
    ran: bool,
}

/// Run options with the scene's own seed, iterations, frames and membrane.
fn run_options(
    out: PathBuf,
    overwrite: bool,
    progress: Progress,
    check_invariants: bool,
) -> RunOptions {
    RunOptions {
        overwrite,
        progress,
        // `False` keeps the build's default (off in a release build).
        check_invariants: check_invariants.then_some(true),
        ..RunOptions::quiet(out)
    }
}

impl Inner {
    fn options(&self, out: PathBuf, overwrite: bool, progress: Progress) -> RunOptions {
        run_options(out, overwrite, progress, self.check_invariants)
    }

    /// The scene's builder again, with the Python terms added in their
    /// order: after a change of the scene (`minimise()` settings).
    fn restart(&mut self, py: Python<'_>) -> PyResult<()> {
        let options = self.options(PathBuf::new(), false, Progress::Quiet);
        let mut pending = prepare(py, &self.scene, &options)?;
        for (name, f) in &self.python_terms {
            let term = PyForceTerm::new(name.clone(), f.clone_ref(py), self.errors.clone());
            pending
                .builder
                .add_force_term(term)
                .map_err(simulation_error)?;
        }
        self.state = State::Pending(pending);
        Ok(())
    }

    /// The sealed run, built from the builder on first use.
    fn run_mut(&mut self, py: Python<'_>) -> PyResult<&mut PreparedRun> {
        if let State::Pending(_) = self.state {
            let State::Pending(pending) = std::mem::replace(&mut self.state, State::Sealing) else {
                unreachable!("checked above")
            };
            let built = pending.build(&self.scene.path).map_err(|e| match e {
                RunError::Scene(e) => scene_error(py, &e),
                other => simulation_error(other),
            })?;
            self.state = State::Built(built);
        }
        match &mut self.state {
            State::Built(run) => Ok(run),
            _ => Err(simulation_error("the simulation could not be built")),
        }
    }

    /// The sealed simulation, built from the builder on first use.
    fn sim(&mut self, py: Python<'_>) -> PyResult<&mut Simulation> {
        Ok(&mut self.run_mut(py)?.sim)
    }

    /// The simulation once built (`None` before its first use).
    fn built(&self) -> Option<&Simulation> {
        match &self.state {
            State::Built(run) => Some(&run.sim),
            _ => None,
        }
    }

    /// The membrane (world and topology cache).
    pub(crate) fn membrane(&self) -> PyResult<Res<'_, Membrane>> {
        match &self.state {
            State::Built(run) => Ok(run.sim.membrane()),
            State::Pending(p) => p
                .builder
                .resources()
                .get::<Membrane>()
                .map_err(simulation_error),
            State::Sealing => Err(simulation_error("the simulation could not be built")),
        }
    }

    /// The membrane, mutably (to bring its topology cache up to date).
    pub(crate) fn membrane_mut(&mut self) -> PyResult<&mut Membrane> {
        match &mut self.state {
            State::Built(run) => Ok(run.sim.membrane_mut()),
            State::Pending(p) => p
                .builder
                .resource_mut::<Membrane>()
                .ok_or_else(|| simulation_error("the scene built no membrane")),
            State::Sealing => Err(simulation_error("the simulation could not be built")),
        }
    }

    /// The resources (of the builder until the simulation is built).
    fn resources(&self) -> Option<&remembrane::engine::resources::Resources> {
        match &self.state {
            State::Built(run) => Some(run.sim.resources()),
            State::Pending(p) => Some(p.builder.resources()),
            State::Sealing => None,
        }
    }

    /// Resource `T`, if there is one.
    pub(crate) fn resource<T: remembrane::engine::resources::Resource>(
        &self,
    ) -> Option<Res<'_, T>> {
        self.resources()?.get::<T>().ok()
    }

    /// Calls `f` on resource `T`, if there is one.
    pub(crate) fn with_resource_mut<T: remembrane::engine::resources::Resource>(
        &self,
        f: impl FnOnce(&mut T),
    ) {
        if let Some(mut r) = self.resources().and_then(|r| r.get_mut::<T>().ok()) {
            f(&mut r);
        }
    }

    /// Simulated time and iterations (zero before the first step).
    fn clock(&self) -> Clock {
        self.built().map(|s| s.clock()).unwrap_or_default()
    }

    /// The error to raise for a failed step: the Python term's own
    /// exception when one caused it, else the engine's.
    fn step_error(&self, e: impl std::fmt::Display) -> PyErr {
        self.errors.take().unwrap_or_else(|| simulation_error(e))
    }

    /// Brings the topology cache up to date and returns the positions by
    /// dense slot, gathered from the world (the source of truth).
    fn positions(&mut self) -> PyResult<Vec<DVec3>> {
        let membrane = self.membrane_mut()?;
        membrane.topology().map_err(simulation_error)?;
        let mut p = Vec::new();
        membrane.gather_positions(&mut p);
        Ok(p)
    }

    pub(crate) fn topology(&mut self) -> PyResult<&remembrane::mesh::topology::Topology> {
        self.membrane_mut()?.topology().map_err(simulation_error)
    }
}

fn prepare(py: Python<'_>, scene: &PyScene, options: &RunOptions) -> PyResult<PendingRun> {
    PendingRun::new(&scene.scene, &scene.path, options).map_err(|e| match e {
        RunError::Scene(e) => scene_error(py, &e),
        other => simulation_error(other),
    })
}

/// A simulation of a scene.
///
/// `Simulation(scene, threads=None, check_invariants=False)`. `threads`
/// sets the size of this simulation's own thread pool (default: the
/// process-wide pool, one thread per core); results are identical for any
/// thread count. `check_invariants` checks every mesh invariant after each
/// remesh edit (slow).
///
/// Advance it with `step(n)`, or `run(out=...)` to write the same run
/// directory as `remembrane run`. Both release the GIL and stop on Ctrl-C
/// with `KeyboardInterrupt`.
#[pyclass(name = "Simulation", module = "remembrane")]
pub struct PySimulation {
    inner: Mutex<Inner>,
    pool: Option<rayon::ThreadPool>,
}

impl PySimulation {
    pub(crate) fn lock(&self) -> PyResult<MutexGuard<'_, Inner>> {
        match self.inner.try_lock() {
            Ok(g) => Ok(g),
            Err(TryLockError::Poisoned(p)) => Ok(p.into_inner()),
            Err(TryLockError::WouldBlock) => Err(simulation_error(
                "the simulation is busy: it was called from inside its own step or run \
                 (e.g. from one of its Python force terms, which get the positions as their argument)",
            )),
        }
    }

    /// Evaluates the forces of the current state (all terms, as a tick
    /// would) without moving anything, detached from the interpreter.
    fn evaluate(&self, py: Python<'_>, inner: &mut Inner) -> PyResult<()> {
        inner.errors.take();
        let sim = inner.sim(py)?;
        let (result, raised) = run_detached(py, self.pool.as_ref(), |_| {
            sim.evaluate_forces().map(|_| ())
        });
        if let Some(e) = raised {
            return Err(e);
        }
        result.map_err(|e| inner.step_error(e))
    }
}

#[pymethods]
impl PySimulation {
    #[new]
    #[pyo3(signature = (scene, threads=None, check_invariants=false))]
    fn new(
        py: Python<'_>,
        scene: &Bound<'_, PyScene>,
        threads: Option<usize>,
        check_invariants: bool,
    ) -> PyResult<Self> {
        let scene = scene.get().clone();
        let pool = match threads {
            None => None,
            Some(0) => return Err(PyValueError::new_err("threads must be at least 1")),
            Some(n) => Some(
                rayon::ThreadPoolBuilder::new()
                    .num_threads(n)
                    .build()
                    .map_err(|e| PyValueError::new_err(format!("threads={n}: {e}")))?,
            ),
        };
        let options = run_options(PathBuf::new(), false, Progress::Quiet, check_invariants);
        let pending = prepare(py, &scene, &options)?;
        Ok(Self {
            inner: Mutex::new(Inner {
                state: State::Pending(pending),
                scene,
                check_invariants,
                python_terms: Vec::new(),
                errors: TermErrors::default(),
                ran: false,
            }),
            pool,
        })
    }

    /// Adds a force term written in Python, before the first step or force
    /// evaluation (the simulation is sealed then).
    ///
    /// `fn(positions) -> (energy, forces)` is called once per force
    /// evaluation with the vertex positions (N×3 float64, l̄) and returns the
    /// energy (float, Ē = 10 k_BT) and the force −∇E (N×3 float64, Ē/l̄). It
    /// joins the schedule like a scene's terms: the same finite checks,
    /// timing (`summary.json`) and per-term forces (`forces(name)`). An
    /// exception inside it stops the step and is re-raised.
    fn add_force_term(&self, py: Python<'_>, name: String, r#fn: Py<PyAny>) -> PyResult<()> {
        if !r#fn.bind(py).is_callable() {
            return Err(PyTypeError::new_err(
                "the force term must be callable: fn(positions) -> (energy, forces)",
            ));
        }
        let mut inner = self.lock()?;
        let term = PyForceTerm::new(name.clone(), r#fn.clone_ref(py), inner.errors.clone());
        let State::Pending(pending) = &mut inner.state else {
            return Err(simulation_error(format!(
                "add_force_term({name:?}): terms are added before the first step or force \
                 evaluation (energies, forces, report, minimise, run); build a new Simulation"
            )));
        };
        pending
            .builder
            .add_force_term(term)
            .map_err(|e| PyValueError::new_err(e.to_string()))?;
        inner.python_terms.push((name, r#fn));
        Ok(())
    }

    /// Advances `n` ticks (each: forces, time step, integration, barrier
    /// check, remeshing, diffusion, as the scene declares).
    #[pyo3(signature = (n=1))]
    fn step(&self, py: Python<'_>, n: u64) -> PyResult<()> {
        let mut guard = self.lock()?;
        let inner = &mut *guard;
        if inner.ran {
            return Err(simulation_error(
                "this simulation has done its run(); build a new Simulation to step",
            ));
        }
        inner.errors.take();
        let errors = inner.errors.clone();
        let sim = inner.sim(py)?;
        let (result, raised) = run_detached(py, self.pool.as_ref(), |stop| {
            for _ in 0..n {
                sim.tick()?;
                if stop() || errors.interrupted() {
                    break;
                }
            }
            Ok::<(), SimError>(())
        });
        if let Some(e) = raised {
            return Err(e);
        }
        result.map_err(|e| inner.step_error(e))
    }

    /// Runs the scene's iterations (or duration) from the start and writes
    /// the run directory `out` exactly as `remembrane run` does (frames,
    /// series.csv, summary.json, final.ply, state.json, ...). Returns the
    /// summary as a dict. A run that blows up raises `SimulationError`
    /// (its outputs up to the last good frame are in `out`); Ctrl-C raises
    /// `KeyboardInterrupt` and leaves `out.incomplete`.
    #[pyo3(signature = (out, progress=true, overwrite=false))]
    fn run<'py>(
        &self,
        py: Python<'py>,
        out: PathBuf,
        progress: bool,
        overwrite: bool,
    ) -> PyResult<Bound<'py, PyAny>> {
        let mut guard = self.lock()?;
        let inner = &mut *guard;
        if inner.ran {
            return Err(simulation_error(
                "this simulation has done its run(); build a new Simulation",
            ));
        }
        let done = inner.clock().iteration;
        if done > 0 {
            return Err(simulation_error(format!(
                "run() starts at iteration 0, but this simulation has stepped {done} iterations; \
                 build a new Simulation"
            )));
        }
        if out.exists() && !overwrite {
            return Err(PyFileExistsError::new_err(format!(
                "{}: the run directory exists (pass overwrite=True to replace it)",
                out.display()
            )));
        }
        let progress = Progress::for_stderr(!progress);
        let options = inner.options(out, overwrite, progress);
        inner.errors.take();
        let path = inner.scene.path.clone();
        let errors = inner.errors.clone();
        inner.ran = true;
        let run = inner.run_mut(py)?;
        let started = Instant::now();
        let (result, raised) = run_detached(py, self.pool.as_ref(), |stop| {
            drive_run(run, &path, &options, started, &|| {
                stop() || errors.interrupted()
            })
        });
        match result {
            Ok(summary) => {
                let value = serde_json::to_value(&summary).map_err(simulation_error)?;
                json_to_py(py, &value)
            }
            Err(RunError::Interrupted { .. }) if raised.is_some() => Err(raised.expect("checked")),
            Err(RunError::Scene(e)) => Err(scene_error(py, &e)),
            Err(e) => Err(inner.step_error(e)),
        }
    }

    /// Minimises the energy with the FIRE minimiser (`dynamics.method:
    /// Minimise`) until a convergence criterion holds or `max_iterations`
    /// more iterations (default: the scene's `iterations`) have run; the
    /// state stays at the result. Remeshing, flips, constraints and
    /// Python force terms take part as in a run.
    ///
    /// Keyword settings (`force_tolerance=`, `energy_tolerance=`,
    /// `energy_window=`, `constraint_tolerance=`, `max_step=`, `dt_start=`,
    /// `dt_max=`, `preconditioner=` (`"None"` or `{"Sobolev": {...}}`, the
    /// metric whose iterations hardly grow with the mesh), `axisymmetric=`
    /// (an axis `[x, y, z]`)) override the scene's minimiser settings. A
    /// scene whose method is `Overdamped` is switched to the minimiser;
    /// both need a simulation that has not stepped yet.
    ///
    /// Returns a dict: `stopped_by` (`force_residual`, `energy_change` or
    /// `iteration_cap`), `converged`, `iterations` (in all),
    /// `force_residual` (Ē/l̄), `energy_change`, `constraint_violation`,
    /// `restarts`, `folds_undone`, `factorisations` (of the
    /// preconditioner), `energy` (Ē), with constraints `tension` σ (Ē/l̄²)
    /// and `pressure` Δp (Ē/l̄³), and with `axisymmetric` the
    /// `axial_reaction` (Ē/l̄).
    #[pyo3(signature = (max_iterations=None, **settings))]
    fn minimise<'py>(
        &self,
        py: Python<'py>,
        max_iterations: Option<u64>,
        settings: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Bound<'py, PyAny>> {
        use remembrane::params::Method;
        let mut guard = self.lock()?;
        let inner = &mut *guard;
        if inner.ran {
            return Err(simulation_error(
                "this simulation has done its run(); build a new Simulation to minimise",
            ));
        }
        let mut changes = serde_json::Map::new();
        for (k, v) in settings.into_iter().flat_map(|d| d.iter()) {
            changes.insert(k.extract()?, crate::convert::py_to_json(&v)?);
        }
        let current = inner.scene.scene.dynamics.method;
        if !changes.is_empty() || !matches!(current, Method::Minimise(_)) {
            let done = inner.clock().iteration;
            if done > 0 {
                return Err(simulation_error(format!(
                    "minimise(): this simulation has stepped {done} iterations of its {} \
                     method; changing the method or its settings needs a new Simulation (or a \
                     scene with `dynamics: (method: Minimise(...))`)",
                    if matches!(current, Method::Minimise(_)) {
                        "minimiser"
                    } else {
                        "overdamped"
                    }
                )));
            }
            let params = match current {
                Method::Minimise(p) => p,
                Method::Overdamped => Default::default(),
            };
            let mut value = serde_json::to_value(params).map_err(simulation_error)?;
            if let Some(map) = value.as_object_mut() {
                map.extend(changes);
            }
            let changed = remembrane::scene::overrides::set_parameters(
                &inner.scene.scene,
                &inner.scene.path,
                &[(
                    "dynamics.method".to_string(),
                    serde_json::json!({ "Minimise": value }),
                )],
            )
            .map_err(|e| scene_error(py, &e))?;
            inner.scene = PyScene {
                scene: changed,
                path: inner.scene.path.clone(),
            };
            inner.restart(py)?;
        }
        let cap = max_iterations.unwrap_or(inner.scene.scene.dynamics.iterations);
        inner.errors.take();
        let errors = inner.errors.clone();
        let sim = inner.sim(py)?;
        let (result, raised) = run_detached(py, self.pool.as_ref(), |stop| {
            let start = sim.clock().iteration;
            while sim.clock().iteration - start < cap {
                sim.tick()?;
                let done = sim
                    .resource::<remembrane::engine::simulation::StopRequest>()
                    .0
                    .is_some();
                if done || stop() || errors.interrupted() {
                    break;
                }
            }
            sim.evaluate_forces().map(|_| ())
        });
        if let Some(e) = raised {
            return Err(e);
        }
        result.map_err(|e| inner.step_error(e))?;
        let sim = inner.sim(py)?;
        let summary = remembrane::workflow::run::minimiser_summary(sim)
            .ok_or_else(|| simulation_error("the minimiser is not part of this simulation"))?;
        let mut value = serde_json::to_value(&summary).map_err(simulation_error)?;
        let buffers = sim.resource::<ForceBuffers>();
        if let Some(map) = value.as_object_mut() {
            map.insert("iterations".into(), sim.clock().iteration.into());
            map.insert("energy".into(), buffers.evaluation.total_energy().into());
            if let Some(c) = buffers.evaluation.constraint {
                map.insert("tension".into(), c.reactions.tension.into());
                map.insert("pressure".into(), c.reactions.pressure.into());
            }
        }
        json_to_py(py, &value)
    }

    /// Simulated time (s).
    #[getter]
    fn time(&self) -> PyResult<f64> {
        Ok(self.lock()?.clock().time)
    }

    /// Completed iterations.
    #[getter]
    fn iteration(&self) -> PyResult<u64> {
        Ok(self.lock()?.clock().iteration)
    }

    /// The scene being simulated.
    #[getter]
    fn scene(&self) -> PyResult<PyScene> {
        Ok(self.lock()?.scene.clone())
    }

    /// Threads of this simulation's own pool (None: the process-wide pool).
    #[getter]
    fn threads(&self) -> Option<usize> {
        self.pool.as_ref().map(|p| p.current_num_threads())
    }

    /// Vertex positions, N×3 float64 (l̄), by vertex index.
    #[getter]
    fn positions<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let p = self.lock()?.positions()?;
        vec3_array(py, &p)
    }

    /// Triangles, F×3 int64 vertex indices (counter-clockwise seen from
    /// outside).
    #[getter]
    fn faces<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<i64>>> {
        let mut inner = self.lock()?;
        index_array(py, &inner.topology()?.faces)
    }

    /// The boundary loops of an open membrane, each an int64 array of
    /// vertex indices in the direction of its edges (empty when closed).
    #[getter]
    fn boundary_loops<'py>(&self, py: Python<'py>) -> PyResult<Vec<Bound<'py, PyArray1<i64>>>> {
        let mut inner = self.lock()?;
        let loops = inner.topology()?.boundary_loops();
        Ok(loops
            .iter()
            .map(|l| PyArray1::from_iter(py, l.iter().map(|&v| i64::from(v))))
            .collect())
    }

    /// Edges, E×2 int64 vertex indices.
    #[getter]
    fn edges<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<i64>>> {
        let mut inner = self.lock()?;
        index_array(py, &inner.topology()?.edges)
    }

    /// Names of the per-vertex fields (e.g. `lipid_density`, or a
    /// plugin's).
    #[getter]
    fn field_names(&self) -> PyResult<Vec<String>> {
        let inner = self.lock()?;
        Ok(inner
            .membrane()?
            .fields()
            .iter()
            .map(|f| f.name().to_string())
            .collect())
    }

    /// The protein species' area fractions by name (a mapping of float64
    /// arrays of length N at the current shape; settable).
    #[getter]
    fn species(slf: Py<Self>) -> crate::species::PySpecies {
        crate::species::PySpecies::new(slf)
    }

    /// A per-vertex field by name, float64 array of length N.
    fn field<'py>(
        &self,
        py: Python<'py>,
        name: &str,
    ) -> PyResult<Bound<'py, numpy::PyArray1<f64>>> {
        let mut inner = self.lock()?;
        inner.topology()?;
        let membrane = inner.membrane()?;
        let field = membrane
            .fields()
            .iter()
            .find(|f| f.name() == name)
            .cloned()
            .ok_or_else(|| {
                let names: Vec<&str> = membrane.fields().iter().map(|f| f.name()).collect();
                PyKeyError::new_err(format!(
                    "no per-vertex field {name:?} (fields: {})",
                    if names.is_empty() {
                        "none".to_string()
                    } else {
                        names.join(", ")
                    }
                ))
            })?;
        let t = membrane.cached_topology();
        let values: Vec<f64> = t
            .vertex_entities
            .iter()
            .map(|&e| field.get(&membrane.world, e))
            .collect();
        Ok(numpy::PyArray1::from_vec(py, values))
    }

    /// Energy of each term at the current state (Ē = 10 k_BT), as a dict in
    /// evaluation order.
    fn energies<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let mut inner = self.lock()?;
        self.evaluate(py, &mut inner)?;
        let buffers = inner.sim(py)?.resource::<ForceBuffers>();
        let d = PyDict::new(py);
        for t in remembrane::io::report::term_energies(&buffers) {
            d.set_item(t.term, t.energy)?;
        }
        Ok(d)
    }

    /// Force at the current state, N×3 float64 (Ē/l̄): the total the
    /// dynamics uses (penalty terms smoothed as the scene says), or one
    /// term's exact −∇E by name.
    #[pyo3(signature = (term=None))]
    fn forces<'py>(
        &self,
        py: Python<'py>,
        term: Option<&str>,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let mut inner = self.lock()?;
        self.evaluate(py, &mut inner)?;
        let buffers = inner.sim(py)?.resource::<ForceBuffers>();
        let e = &buffers.evaluation;
        match term {
            None => vec3_array(py, &e.total),
            Some(name) => {
                let names = buffers.names();
                let k = names.iter().position(|n| n == name).ok_or_else(|| {
                    PyKeyError::new_err(format!(
                        "no force term {name:?} (terms: {})",
                        names.join(", ")
                    ))
                })?;
                vec3_array(py, &e.term_forces[k])
            }
        }
    }

    /// The state report of `remembrane energy`: energies by term, total,
    /// area, volume, reduced volume and mesh quality, as a dict.
    fn report<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let mut inner = self.lock()?;
        self.evaluate(py, &mut inner)?;
        let name = inner.scene.name();
        let report = EnergyReport::new(&name, inner.sim(py)?);
        json_to_py(
            py,
            &serde_json::to_value(&report).map_err(simulation_error)?,
        )
    }

    /// Mesh quality: edge lengths (min/mean/max/std, l̄), smallest angle
    /// (degrees) and the valence histogram, as a dict.
    fn mesh_quality<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let mut inner = self.lock()?;
        let p = inner.positions()?;
        let q = MeshQuality::measure(inner.membrane()?.cached_topology(), &p);
        json_to_py(py, &serde_json::to_value(&q).map_err(simulation_error)?)
    }

    /// Remeshing counts so far (split/merge × success/cancel/impossible/
    /// failure, unresolved and capped ticks, events), or None when the
    /// scene has no remeshing.
    fn remesh_stats<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyAny>>> {
        let mut inner = self.lock()?;
        let Ok(stats) = inner.sim(py)?.resources().get::<RemeshStats>() else {
            return Ok(None);
        };
        let value = serde_json::json!({
            "split": stats.split,
            "merge": stats.merge,
            "events": stats.successes(),
            "overflow_ticks": stats.overflow_ticks,
            "unresolved_ticks": stats.unresolved_ticks,
            "unresolved_edges": stats.unresolved_edges,
            "relax_iterations": stats.relax_iterations,
        });
        json_to_py(py, &value).map(Some)
    }

    /// Edge-flip counts so far (proposed, accepted, rejected_topology,
    /// rejected_geometry, rejected_energy), or None when the scene declares
    /// no `edge_flips`.
    fn flip_stats<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyAny>>> {
        let mut inner = self.lock()?;
        let Ok(stats) = inner
            .sim(py)?
            .resources()
            .get::<remembrane::engine::shared_resources::FlipStats>()
        else {
            return Ok(None);
        };
        let value = serde_json::to_value(*stats).map_err(simulation_error)?;
        json_to_py(py, &value).map(Some)
    }

    fn __repr__(&self) -> String {
        match self.inner.try_lock() {
            Ok(inner) => {
                let c = inner.clock();
                let vertices = inner
                    .membrane()
                    .map(|m| {
                        m.world
                            .query::<&remembrane::mesh::components::Position>()
                            .iter()
                            .count()
                    })
                    .unwrap_or(0);
                format!(
                    "Simulation({:?}, vertices={}, iteration={}, time={:.6e})",
                    inner.scene.name(),
                    vertices,
                    c.iteration,
                    c.time
                )
            }
            Err(_) => "Simulation(<busy>)".to_string(),
        }
    }
}
