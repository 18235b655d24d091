//! Peer methods: `register_peer(name, make, ...)` adds a method that runs another package's
//! own implementation (see `softbench.peers`). Unlike `register_method`, a peer keeps state
//! of its own: on a run's first step softbench calls `make(problem)` with the run's model —
//! rest positions, tets, fixed vertices, lumped masses, density, the material's name and Lamé
//! parameters, gravity, the step and the peer's resolved `[integrator.peer]` settings — and
//! then, every step, `stepper.step(x, v, dt)` with every vertex's positions and velocities
//! (`(n, 3)` float64, fixed vertices at their prescribed positions and zero velocity). It
//! returns the end-of-step `(x, v)`, optionally with a dict of counts
//! (`{"iterations": k, "substeps": s, "gradient_passes": g, "hessian_passes": h}`, the last two
//! the element passes the step made). softbench keeps the free vertices' rows.

use std::collections::BTreeMap;
use std::sync::Mutex;

use numpy::ndarray::Array2;
use numpy::{IntoPyArray, PyArray1, PyReadonlyArray2};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use softbench::integrate::methods::{IntegratorSettings, MethodEntry};
use softbench::integrate::newton::NewtonContact;
use softbench::integrate::peer::{PeerConventions, PeerFacts, PeerSetting, PeerValue};
use softbench::integrate::{Integrator, State, StepError, StepReport, register_method};
use softbench::model::Model as FemModel;

use crate::errors::IntoPy;

/// The Python `make` functions, by method name.
static MAKERS: Mutex<Vec<(&'static str, Py<PyAny>)>> = Mutex::new(Vec::new());

/// Register a peer method. `settings` is a list of dicts: `key`, `default`, `description`
/// and optionally `choices`, `positive`, `twin_key`, `twin_values` (a dict from this setting's
/// values to the twin's) and `neutral` (see [`PeerSetting`]); `explicit`: it never solves with the stiffness (Newton's semi-implicit
/// Euler), which decides the stability checks studies make; `version` is `None` when the package is not installed (scenes naming the
/// method are then refused with `install` as the remedy).
#[pyfunction]
#[pyo3(signature = (name, make, package, version, install, description, order, materials, settings, twin=None, explicit=false))]
#[allow(clippy::too_many_arguments)]
pub fn register_peer(
    name: String,
    make: Py<PyAny>,
    package: String,
    version: Option<String>,
    install: String,
    description: String,
    order: u32,
    materials: Vec<String>,
    settings: Vec<Bound<'_, PyDict>>,
    twin: Option<String>,
    explicit: bool,
) -> PyResult<()> {
    let settings = settings
        .iter()
        .map(peer_setting)
        .collect::<PyResult<Vec<_>>>()?;
    let facts: &'static PeerFacts = Box::leak(Box::new(PeerFacts {
        package,
        version,
        install,
        twin,
        materials,
        settings,
    }));
    let name: &'static str = Box::leak(name.into_boxed_str());
    register_method(MethodEntry {
        name,
        description: Box::leak(description.into_boxed_str()),
        order,
        explicit,
        newton: false,
        linear_solver: false,
        constrained_contact: false,
        adaptive: false,
        build: build_peer,
        peer: Some(facts),
    })
    .py_err()?;
    MAKERS
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .push((name, make));
    Ok(())
}

/// One setting from its dict.
fn peer_setting(d: &Bound<'_, PyDict>) -> PyResult<PeerSetting> {
    let item = |key: &str| d.get_item(key).ok().flatten().filter(|v| !v.is_none());
    let key: String = item("key")
        .ok_or_else(|| PyValueError::new_err("a setting needs a `key`"))?
        .extract()?;
    let value = |v: &Bound<'_, PyAny>| {
        peer_value(v).ok_or_else(|| {
            PyValueError::new_err(format!(
                "setting `{key}`: values must be bool, int, float or str"
            ))
        })
    };
    let default = value(
        &item("default")
            .ok_or_else(|| PyValueError::new_err(format!("setting `{key}` needs a `default`")))?,
    )?;
    let twin_values = match item("twin_values") {
        None => Vec::new(),
        Some(map) => map
            .downcast::<PyDict>()?
            .iter()
            .map(|(from, to)| Ok((value(&from)?, value(&to)?)))
            .collect::<PyResult<Vec<_>>>()?,
    };
    Ok(PeerSetting {
        default,
        choices: item("choices")
            .map(|c| c.extract())
            .transpose()?
            .unwrap_or_default(),
        positive: item("positive")
            .map(|p| p.extract())
            .transpose()?
            .unwrap_or(false),
        description: item("description")
            .map(|t| t.extract())
            .transpose()?
            .unwrap_or_default(),
        twin_key: item("twin_key").map(|t| t.extract()).transpose()?,
        twin_values,
        neutral: item("neutral").map(|n| value(&n)).transpose()?,
        key,
    })
}

/// A Python value as a setting's value (bool before int: Python's bool is an int).
fn peer_value(v: &Bound<'_, PyAny>) -> Option<PeerValue> {
    if let Ok(b) = v.extract::<bool>()
        && v.is_instance_of::<pyo3::types::PyBool>()
    {
        return Some(PeerValue::Bool(b));
    }
    if v.is_instance_of::<pyo3::types::PyInt>() {
        return v.extract::<i64>().ok().map(PeerValue::Int);
    }
    if v.is_instance_of::<pyo3::types::PyFloat>() {
        return v.extract::<f64>().ok().map(PeerValue::Float);
    }
    v.extract::<String>().ok().map(PeerValue::Text)
}

fn build_peer(
    settings: &IntegratorSettings,
    _contact: Option<NewtonContact>,
) -> Box<dyn Integrator> {
    let entry = settings.method.entry();
    let make = Python::attach(|py| {
        MAKERS
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .iter()
            .find(|(n, _)| *n == entry.name)
            .map(|(_, m)| m.clone_ref(py))
            .expect("a peer's make is stored when it is registered")
    });
    Box::new(PeerMethod {
        name: entry.name,
        order: entry.order,
        explicit: entry.explicit,
        make,
        settings: settings.peer.values().clone(),
        stepper: None,
    })
}

/// An integrator whose steps are another package's.
struct PeerMethod {
    name: &'static str,
    order: u32,
    explicit: bool,
    make: Py<PyAny>,
    settings: BTreeMap<String, PeerValue>,
    /// Made on the first step, from the run's model.
    stepper: Option<Py<PyAny>>,
}

impl Integrator for PeerMethod {
    fn name(&self) -> &'static str {
        self.name
    }
    fn order(&self) -> u32 {
        self.order
    }
    fn is_explicit(&self) -> bool {
        self.explicit
    }

    fn peer_conventions(
        &mut self,
        model: &mut FemModel,
        positions: &[nalgebra::Vector3<f64>],
        dt: f64,
    ) -> Option<Result<PeerConventions, StepError>> {
        Python::attach(|py| self.conventions(py, model, positions, dt)).transpose()
    }

    fn advance(
        &mut self,
        model: &mut FemModel,
        state: &mut State,
        dt: f64,
        report: &mut StepReport,
    ) -> Result<(), StepError> {
        let name = self.name;
        let failed = |e: String| StepError::Method(format!("{name}: {e}"));
        Python::attach(|py| -> Result<(), StepError> {
            let stepper = self.stepper(py, model, dt)?;
            let x = to_rows(&model.full_positions(&state.q));
            let mut v = Array2::<f64>::zeros((model.rest_positions().len(), 3));
            for (k, &vertex) in model.dofs().free_vertices().iter().enumerate() {
                for c in 0..3 {
                    v[(vertex, c)] = state.v[3 * k + c];
                }
            }
            let result = stepper
                .call_method1(py, "step", (x.into_pyarray(py), v.into_pyarray(py), dt))
                .map_err(|e| failed(crate::method::python_error(py, e)))?;
            read_step(result.bind(py), model, state, report).map_err(failed)
        })?;
        Ok(())
    }
}

impl PeerMethod {
    /// The peer's stepper, made from the run's model on first use.
    fn stepper(
        &mut self,
        py: Python<'_>,
        model: &FemModel,
        dt: f64,
    ) -> Result<Py<PyAny>, StepError> {
        let name = self.name;
        let failed =
            |e: PyErr| StepError::Method(format!("{name}: {}", crate::method::python_error(py, e)));
        if self.stepper.is_none() {
            let problem = problem(py, model, &self.settings, dt).map_err(failed)?;
            self.stepper = Some(self.make.call1(py, (problem,)).map_err(failed)?);
        }
        Ok(self.stepper.as_ref().expect("made above").clone_ref(py))
    }

    /// `stepper.conventions(x)`, if the stepper has it, as [`PeerConventions`].
    fn conventions(
        &mut self,
        py: Python<'_>,
        model: &FemModel,
        positions: &[nalgebra::Vector3<f64>],
        dt: f64,
    ) -> Result<Option<PeerConventions>, StepError> {
        let name = self.name;
        let failed =
            |e: PyErr| StepError::Method(format!("{name}: {}", crate::method::python_error(py, e)));
        let stepper = self.stepper(py, model, dt)?;
        let stepper = stepper.bind(py);
        if !stepper.hasattr("conventions").map_err(failed)? {
            return Ok(None);
        }
        let found = stepper
            .call_method1("conventions", (to_rows(positions).into_pyarray(py),))
            .map_err(failed)?;
        let get = |key: &str| -> Option<Bound<'_, PyAny>> {
            found.get_item(key).ok().filter(|v| !v.is_none())
        };
        let wrong = |key: &str| {
            StepError::Method(format!(
                "{name}: conventions()[\"{key}\"] has the wrong type"
            ))
        };
        let vector = |key: &str| -> Result<Option<Vec<f64>>, StepError> {
            get(key)
                .map(|v| {
                    let a: numpy::PyReadonlyArrayDyn<f64> = v.extract().map_err(|_| wrong(key))?;
                    Ok(a.as_array().iter().copied().collect())
                })
                .transpose()
        };
        Ok(Some(PeerConventions {
            masses: vector("masses")?,
            fixed: get("fixed")
                .map(|v| v.extract::<Vec<usize>>().map_err(|_| wrong("fixed")))
                .transpose()?,
            elastic_energy: get("elastic_energy")
                .map(|v| v.extract::<f64>().map_err(|_| wrong("elastic_energy")))
                .transpose()?,
            elastic_forces: vector("elastic_forces")?,
            note: get("note")
                .map(|v| v.extract::<String>().map_err(|_| wrong("note")))
                .transpose()?,
        }))
    }
}

fn to_rows<P: std::ops::Index<usize, Output = f64>>(points: &[P]) -> Array2<f64> {
    Array2::from_shape_fn((points.len(), 3), |(i, c)| points[i][c])
}

/// The stepper's `(x, v[, counts])` into the state's free DOFs and the report.
fn read_step(
    result: &Bound<'_, PyAny>,
    model: &mut FemModel,
    state: &mut State,
    report: &mut StepReport,
) -> Result<(), String> {
    let shape = "step must return (x, v) or (x, v, counts): (n, 3) float64 arrays";
    let n = model.rest_positions().len();
    let parts: Vec<Bound<'_, PyAny>> = result.extract().map_err(|_| shape.to_owned())?;
    if !(2..=3).contains(&parts.len()) {
        return Err(shape.into());
    }
    let x: PyReadonlyArray2<f64> = parts[0].extract().map_err(|_| shape.to_owned())?;
    let v: PyReadonlyArray2<f64> = parts[1].extract().map_err(|_| shape.to_owned())?;
    let (x, v) = (x.as_array(), v.as_array());
    if x.dim() != (n, 3) || v.dim() != (n, 3) {
        return Err(format!(
            "step returned arrays of shapes {:?} and {:?}; the model has {n} vertices",
            x.dim(),
            v.dim()
        ));
    }
    for (k, &vertex) in model.dofs().free_vertices().iter().enumerate() {
        for c in 0..3 {
            state.q[3 * k + c] = x[(vertex, c)];
            state.v[3 * k + c] = v[(vertex, c)];
        }
    }
    report.substeps = 1;
    if let Some(counts) = parts.get(2) {
        let get = |key: &str| -> Result<Option<u32>, String> {
            match counts.get_item(key) {
                Ok(value) => value
                    .extract::<u32>()
                    .map(Some)
                    .map_err(|_| format!("counts[\"{key}\"] must be a non-negative integer")),
                Err(_) => Ok(None),
            }
        };
        if let Some(iterations) = get("iterations")? {
            report.local_iterations = iterations;
        }
        if let Some(substeps) = get("substeps")? {
            report.substeps = substeps.max(1);
        }
        // Element passes, counted as softbench's own local solvers count theirs (a VBD sweep
        // evaluates every element's gradient and Hessian, an XPBD sweep every constraint's
        // gradient), so a suite's evaluation budgets and profiles treat both alike.
        let gradient = get("gradient_passes")?.unwrap_or(0);
        let hessian = get("hessian_passes")?.unwrap_or(0);
        model.count_local_passes(u64::from(gradient), u64::from(hessian));
    }
    Ok(())
}

/// What `make` is given: the run's model as arrays and numbers.
fn problem<'py>(
    py: Python<'py>,
    model: &FemModel,
    settings: &BTreeMap<String, PeerValue>,
    dt: f64,
) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item(
        "rest_positions",
        to_rows(model.rest_positions()).into_pyarray(py),
    )?;
    let tets = model.tets();
    let tets = Array2::from_shape_fn((tets.len(), 4), |(e, k)| tets[e][k] as i64);
    d.set_item("tets", tets.into_pyarray(py))?;
    let n = model.rest_positions().len();
    let fixed: Vec<i64> = (0..n)
        .filter(|&v| model.dofs().is_fixed(v))
        .map(|v| v as i64)
        .collect();
    d.set_item("fixed", PyArray1::from_vec(py, fixed))?;
    d.set_item(
        "vertex_masses",
        PyArray1::from_slice(py, model.vertex_masses()),
    )?;
    d.set_item("density", model.density())?;
    let material = model.material();
    d.set_item("material", material.map(|m| m.name()))?;
    let lame = material.map(|m| m.lame());
    d.set_item("mu", lame.map(|l| l.mu))?;
    d.set_item("lambda", lame.map(|l| l.lambda))?;
    let g = model.gravity().unwrap_or_default();
    d.set_item("gravity", PyArray1::from_slice(py, g.as_slice()))?;
    d.set_item("dt", dt)?;
    let s = PyDict::new(py);
    for (key, value) in settings {
        match value {
            PeerValue::Bool(b) => s.set_item(key, b)?,
            PeerValue::Int(i) => s.set_item(key, i)?,
            PeerValue::Float(x) => s.set_item(key, x)?,
            PeerValue::Text(t) => s.set_item(key, t)?,
        }
    }
    d.set_item("settings", s)?;
    Ok(d)
}
