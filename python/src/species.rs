//! `Simulation.species`: the protein species' area fractions, by name, as
//! numpy arrays (at the current shape), settable.

use crate::simulation::PySimulation;
use numpy::{PyArray1, PyReadonlyArray1};
use pyo3::exceptions::{PyKeyError, PyValueError};
use pyo3::prelude::*;
use remembrane::species::model::{SpeciesModel, SpeciesStatus};
use remembrane::species::params::Reservoir;
use remembrane::species::state::{SpeciesAmounts, fractions_at, write_fractions};

/// The species of a simulation as a mapping from name to area fractions
/// φ (float64 arrays of length N, by vertex): `sim.species["bar"]` reads
/// the fractions at the current shape; `sim.species["bar"] = phi` sets
/// them (each in (0, 1), the species' sum below 1 at every vertex). Setting
/// a conserved species sets its count: the count the minimiser then holds.
#[pyclass(name = "Species", module = "remembrane")]
pub struct PySpecies {
    sim: Py<PySimulation>,
}

impl PySpecies {
    pub fn new(sim: Py<PySimulation>) -> Self {
        Self { sim }
    }
}

/// What [`read`] finds: the species' names, the index of the one asked
/// for, and every species' fractions (by species, then vertex).
struct Fields {
    names: Vec<String>,
    index: Option<usize>,
    phi: Vec<Vec<f64>>,
}

/// The species' fields of `sim`, and the index of `name`.
fn read(sim: &PySimulation, name: Option<&str>) -> PyResult<Fields> {
    let mut inner = sim.lock()?;
    inner.topology()?;
    let Some((set, form)) = inner
        .resource::<SpeciesModel>()
        .map(|m| (m.set.clone(), m.base.discretisation))
    else {
        return Ok(Fields {
            names: Vec::new(),
            index: None,
            phi: Vec::new(),
        });
    };
    let names: Vec<String> = set.species.iter().map(|s| s.name.clone()).collect();
    let index = name.and_then(|n| set.index(n));
    let membrane = inner.membrane()?;
    let t = membrane.cached_topology();
    let mut amounts = SpeciesAmounts::default();
    amounts.gather(&membrane.world, t, set.species.len());
    let mut positions = Vec::new();
    membrane.gather_positions(&mut positions);
    let phi = fractions_at(&set, &amounts.0, &positions, &t.faces, form);
    Ok(Fields { names, index, phi })
}

fn missing(name: &str, names: &[String]) -> PyErr {
    PyKeyError::new_err(format!(
        "no species {name:?} (species: {})",
        if names.is_empty() {
            "none".to_string()
        } else {
            names.join(", ")
        }
    ))
}

#[pymethods]
impl PySpecies {
    /// The species' names, in declaration order.
    fn keys(&self, py: Python<'_>) -> PyResult<Vec<String>> {
        Ok(read(&self.sim.borrow(py), None)?.names)
    }

    fn __len__(&self, py: Python<'_>) -> PyResult<usize> {
        Ok(self.keys(py)?.len())
    }

    fn __contains__(&self, py: Python<'_>, name: &str) -> PyResult<bool> {
        Ok(self.keys(py)?.iter().any(|n| n == name))
    }

    fn __iter__(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        let names = self.keys(py)?;
        Ok(names.into_pyobject(py)?.try_iter()?.into_any().unbind())
    }

    fn __getitem__<'py>(&self, py: Python<'py>, name: &str) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let Fields {
            names,
            index,
            mut phi,
        } = read(&self.sim.borrow(py), Some(name))?;
        let k = index.ok_or_else(|| missing(name, &names))?;
        Ok(PyArray1::from_vec(py, std::mem::take(&mut phi[k])))
    }

    fn __setitem__(
        &self,
        py: Python<'_>,
        name: &str,
        values: PyReadonlyArray1<'_, f64>,
    ) -> PyResult<()> {
        let values = values.as_slice()?.to_vec();
        let sim = self.sim.borrow(py);
        let mut inner = sim.lock()?;
        let Some((set, form)) = inner
            .resource::<SpeciesModel>()
            .map(|m| (m.set.clone(), m.base.discretisation))
        else {
            return Err(missing(name, &[]));
        };
        let k = set.index(name).ok_or_else(|| {
            let names: Vec<String> = set.species.iter().map(|s| s.name.clone()).collect();
            missing(name, &names)
        })?;
        let count = write_fractions(inner.membrane_mut()?, &set, form, k, &values)
            .map_err(|e| PyValueError::new_err(format!("species {name:?}: {e}")))?;
        inner.with_resource_mut::<SpeciesStatus>(|status| {
            if set.species[k].reservoir == Reservoir::Conserved {
                status.initial_counts[k] = count;
            }
            status.counts[k] = count;
        });
        Ok(())
    }
}
