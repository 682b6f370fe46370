//! A force term written in Python: `fn(positions) -> (energy, forces)`.
//!
//! The engine calls it once per force evaluation with the dense vertex
//! positions (an N×3 float64 array, l̄) and expects the energy (Ē) and the
//! force −∇E (an N×3 array, Ē/l̄). It joins the schedule like any term: the
//! same finite checks, per-term timing and per-term force output.
//!
//! A Python exception inside the function cannot travel through the
//! engine's `ForceTerm` interface, so the term keeps the first one in its
//! [`TermErrors`] slot and returns non-finite values; the engine's finite
//! check then stops the step, and the binding re-raises the kept exception.

use crate::convert::vec3_array;
use glam::DVec3;
use numpy::{PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use remembrane::engine::force::{ForceContext, ForceTerm};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};

/// The first exception raised by a Python term since the slot was emptied,
/// and whether it was a `KeyboardInterrupt` (Ctrl-C inside the term), so
/// that a run treats it as an interrupt rather than a blow-up.
#[derive(Clone, Default)]
pub struct TermErrors {
    kept: Arc<Mutex<Option<PyErr>>>,
    interrupted: Arc<AtomicBool>,
}

impl TermErrors {
    /// Keeps `err` unless an earlier one is kept.
    fn keep(&self, err: PyErr) {
        let mut slot = self.kept.lock().unwrap_or_else(|p| p.into_inner());
        if slot.is_none() {
            let interrupt = Python::attach(|py| {
                err.is_instance_of::<pyo3::exceptions::PyKeyboardInterrupt>(py)
            });
            self.interrupted.store(interrupt, Ordering::Relaxed);
            *slot = Some(err);
        }
    }

    /// Whether an exception is kept (later calls then skip Python).
    fn is_set(&self) -> bool {
        self.kept
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .is_some()
    }

    /// Whether the kept exception is a `KeyboardInterrupt`.
    pub fn interrupted(&self) -> bool {
        self.interrupted.load(Ordering::Relaxed)
    }

    /// Takes the kept exception, if any, and empties the slot.
    pub fn take(&self) -> Option<PyErr> {
        self.interrupted.store(false, Ordering::Relaxed);
        self.kept.lock().unwrap_or_else(|p| p.into_inner()).take()
    }
}

/// A force term backed by a Python callable.
pub struct PyForceTerm {
    name: String,
    function: Py<PyAny>,
    errors: TermErrors,
}

impl PyForceTerm {
    /// A term named `name` calling `function`.
    pub fn new(name: String, function: Py<PyAny>, errors: TermErrors) -> Self {
        Self {
            name,
            function,
            errors,
        }
    }

    /// Calls the function at `positions`; adds its force into `force` when
    /// given and returns its energy.
    fn call(&self, positions: &[DVec3], force: Option<&mut [DVec3]>) -> PyResult<f64> {
        if self.errors.is_set() {
            // An earlier call failed: the evaluation is lost anyway.
            return Err(PyValueError::new_err(
                "an earlier call of a Python term failed",
            ));
        }
        Python::attach(|py| {
            let x = vec3_array(py, positions)?;
            let result = self.function.bind(py).call1((x,))?;
            let (energy, forces): (f64, PyReadonlyArray2<'_, f64>) =
                result.extract().map_err(|_| {
                    PyValueError::new_err(format!(
                        "force term {:?} must return (energy: float, forces: N×3 float64 array)",
                        self.name
                    ))
                })?;
            let shape = forces.shape();
            if shape != [positions.len(), 3] {
                return Err(PyValueError::new_err(format!(
                    "force term {:?} returned forces of shape {shape:?}; expected ({}, 3)",
                    self.name,
                    positions.len()
                )));
            }
            if let Some(force) = force {
                for (f, r) in force.iter_mut().zip(forces.as_array().rows()) {
                    *f += DVec3::new(r[0], r[1], r[2]);
                }
            }
            Ok(energy)
        })
    }
}

impl ForceTerm for PyForceTerm {
    fn name(&self) -> &str {
        &self.name
    }

    fn evaluate(&mut self, ctx: &ForceContext<'_>, mut force: Option<&mut [DVec3]>) -> f64 {
        match self.call(ctx.positions, force.as_deref_mut()) {
            Ok(energy) => energy,
            Err(e) => {
                self.errors.keep(e);
                // The finite check names this term and stops the step.
                if let Some(f) = force.and_then(|f| f.first_mut()) {
                    *f = DVec3::NAN;
                }
                f64::NAN
            }
        }
    }
}
