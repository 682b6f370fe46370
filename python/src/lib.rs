//! `remembrane._core`: the compiled part of the `remembrane` Python package.
//!
//! It binds the engine's own types: [`remembrane::scene::Scene`] (with
//! parameter-path overrides), [`remembrane::engine::simulation::Simulation`] built
//! and run through the same code as the CLI, force terms written in Python,
//! the finite-difference checker, frame reading, sweeps and collection. The
//! pure-Python layer (`remembrane/__init__.py`) adds `load_run`, meshio
//! interop and the `Mesh` type.

mod convert;
mod errors;
mod force_term;
mod interrupt;
mod scene;
mod simulation;
mod species;
mod tools;

use pyo3::prelude::*;

/// The compiled module.
#[pymodule]
fn _core(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("SceneError", py.get_type::<errors::SceneError>())?;
    m.add("SimulationError", py.get_type::<errors::SimulationError>())?;
    m.add_class::<scene::PyScene>()?;
    m.add_class::<simulation::PySimulation>()?;
    m.add_class::<species::PySpecies>()?;
    m.add_function(wrap_pyfunction!(tools::check_force, m)?)?;
    m.add_function(wrap_pyfunction!(tools::icosphere, m)?)?;
    m.add_function(wrap_pyfunction!(tools::perturbed_icosphere, m)?)?;
    m.add_function(wrap_pyfunction!(tools::read_vtp, m)?)?;
    m.add_function(wrap_pyfunction!(tools::read_mesh, m)?)?;
    m.add_function(wrap_pyfunction!(tools::write_mesh, m)?)?;
    m.add_function(wrap_pyfunction!(tools::disc, m)?)?;
    m.add_function(wrap_pyfunction!(tools::spherical_cap, m)?)?;
    m.add_function(wrap_pyfunction!(tools::sweep, m)?)?;
    m.add_function(wrap_pyfunction!(tools::collect, m)?)?;
    m.add_function(wrap_pyfunction!(tools::check_run_dir, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
