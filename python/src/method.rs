//! Methods written in Python: `register_method(name, step, ...)` adds an integrator to
//! softbench's registry whose step calls the Python function `step(model, q, v, t, dt)` and
//! takes the `(q, v)` it returns. Scene and study files then name it like a built-in method;
//! it runs (slowly: one Python call per step) under `simulate`, studies and their verdicts.
//!
//! During the call, `model` is a [`StepModel`]: the run's own model (energy, gradient,
//! Hessian, mass, accelerations with damping and the mass solve), valid only inside the call.

use std::sync::Mutex;

use numpy::{IntoPyArray, PyArray1, PyReadonlyArray1};
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use softbench::integrate::methods::{IntegratorSettings, MethodEntry};
use softbench::integrate::newton::NewtonContact;
use softbench::integrate::{
    Dynamics, Integrator, Method, State, StepError, StepReport, register_method as register,
};
use softbench::model::Model as FemModel;
use softbench::registry::Entry;
// A step model is evaluated on the run's thread, in the run's pool.
use softbench::threads::Threads;

use crate::errors::IntoPy;
use crate::model::{self, Csc};

/// The Python step functions, by method name.
static STEPS: Mutex<Vec<(&'static str, Py<PyAny>)>> = Mutex::new(Vec::new());

/// Register `step` as the method `name`. `order` is its formal order (what convergence
/// studies check it against); `explicit` says it never solves with the stiffness.
#[pyfunction]
#[pyo3(signature = (name, step, order, description, explicit=true))]
pub fn register_method(
    name: String,
    step: Py<PyAny>,
    order: u32,
    description: String,
    explicit: bool,
) -> PyResult<()> {
    let name: &'static str = Box::leak(name.into_boxed_str());
    let description: &'static str = Box::leak(description.into_boxed_str());
    register(MethodEntry {
        name,
        description,
        order,
        explicit,
        newton: false,
        linear_solver: false,
        constrained_contact: false,
        adaptive: false,
        build: build_python_method,
        peer: None,
    })
    .py_err()?;
    STEPS
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .push((name, step));
    Ok(())
}

/// Every registered method: `(name, order, explicit, description)`, built-in ones first.
#[pyfunction]
pub fn methods() -> Vec<(String, u32, bool, String)> {
    Method::all()
        .iter()
        .map(|m| {
            let e = m.entry();
            (
                e.name().to_owned(),
                e.order,
                e.explicit,
                e.description().to_owned(),
            )
        })
        .collect()
}

fn build_python_method(
    settings: &IntegratorSettings,
    _contact: Option<NewtonContact>,
) -> Box<dyn Integrator> {
    let entry = settings.method.entry();
    let step = Python::attach(|py| {
        STEPS
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .iter()
            .find(|(n, _)| *n == entry.name)
            .map(|(_, s)| s.clone_ref(py))
            .expect("a Python method's step is stored when it is registered")
    });
    Box::new(PythonMethod {
        name: entry.name,
        order: entry.order,
        explicit: entry.explicit,
        step,
        dynamics: Dynamics::default(),
    })
}

/// An integrator whose step is a Python function.
struct PythonMethod {
    name: &'static str,
    order: u32,
    explicit: bool,
    step: Py<PyAny>,
    dynamics: Dynamics,
}

impl Integrator for PythonMethod {
    fn name(&self) -> &'static str {
        self.name
    }
    fn order(&self) -> u32 {
        self.order
    }
    fn is_explicit(&self) -> bool {
        self.explicit
    }

    fn advance(
        &mut self,
        model: &mut FemModel,
        state: &mut State,
        dt: f64,
        report: &mut StepReport,
    ) -> Result<(), StepError> {
        let n = state.q.len();
        let failed = |e: String| StepError::Method(format!("{}: {e}", self.name));
        Python::attach(|py| -> Result<(), StepError> {
            let q = PyArray1::from_slice(py, &state.q);
            let v = PyArray1::from_slice(py, &state.v);
            let handle = Bound::new(
                py,
                StepModel {
                    model: model as *mut FemModel,
                    dynamics: &mut self.dynamics as *mut Dynamics,
                    report: report as *mut StepReport,
                    t: state.t,
                },
            )
            .map_err(|e| failed(e.to_string()))?;
            let result = self.step.call1(py, (handle.clone(), q, v, state.t, dt));
            // The model is the run's: nothing may reach it after the call.
            handle.borrow_mut().invalidate();
            let result = result.map_err(|e| failed(python_error(py, e)))?;
            let (q_new, v_new): (PyReadonlyArray1<f64>, PyReadonlyArray1<f64>) =
                result.extract(py).map_err(|_| {
                    failed(
                        "step must return (q, v), two float64 arrays of the input's length".into(),
                    )
                })?;
            let (q_new, v_new) = (q_new.as_slice(), v_new.as_slice());
            let (Ok(q_new), Ok(v_new)) = (q_new, v_new) else {
                return Err(failed("step returned non-contiguous arrays".into()));
            };
            if q_new.len() != n || v_new.len() != n {
                return Err(failed(format!(
                    "step returned arrays of lengths {} and {}; the model has {n} free DOFs",
                    q_new.len(),
                    v_new.len()
                )));
            }
            state.q.copy_from_slice(q_new);
            state.v.copy_from_slice(v_new);
            Ok(())
        })?;
        report.substeps = 1;
        Ok(())
    }
}

/// A Python exception as one line: its type and message.
pub(crate) fn python_error(py: Python<'_>, e: PyErr) -> String {
    let kind = e
        .get_type(py)
        .name()
        .map_or_else(|_| "Exception".to_owned(), |n| n.to_string());
    format!("{kind}: {}", e.value(py))
}

/// The run's model as a Python step function sees it, valid only during the call.
#[pyclass(module = "softbench._native", unsendable)]
pub struct StepModel {
    model: *mut FemModel,
    dynamics: *mut Dynamics,
    report: *mut StepReport,
    t: f64,
}

impl StepModel {
    fn invalidate(&mut self) {
        self.model = std::ptr::null_mut();
        self.dynamics = std::ptr::null_mut();
        self.report = std::ptr::null_mut();
    }

    fn parts(&mut self) -> PyResult<(&mut FemModel, &mut Dynamics, &mut StepReport)> {
        if self.model.is_null() {
            return Err(PyRuntimeError::new_err(
                "this model is only valid inside the step call it was passed to",
            ));
        }
        // SAFETY: the pointers are set by `PythonMethod::advance` from the `&mut` it holds
        // for the duration of the Python call, and cleared before it returns; the class is
        // unsendable, so only the calling thread reaches them, and one method at a time.
        unsafe { Ok((&mut *self.model, &mut *self.dynamics, &mut *self.report)) }
    }

    fn model(&mut self) -> PyResult<&mut FemModel> {
        Ok(self.parts()?.0)
    }
}

#[pymethods]
impl StepModel {
    /// The step's start time.
    #[getter]
    fn t(&self) -> f64 {
        self.t
    }
    fn num_dofs(&mut self) -> PyResult<usize> {
        Ok(self.model()?.num_dofs())
    }
    fn counts<'py>(&mut self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        model::counts(py, self.model()?)
    }
    fn vertex_masses<'py>(&mut self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<f64>>> {
        Ok(PyArray1::from_slice(py, self.model()?.vertex_masses()))
    }
    fn full_positions<'py>(
        &mut self,
        py: Python<'py>,
        q: PyReadonlyArray1<'py, f64>,
    ) -> PyResult<Bound<'py, numpy::PyArray2<f64>>> {
        model::full_positions(py, self.model()?, q)
    }
    fn energy(&mut self, q: PyReadonlyArray1<'_, f64>) -> PyResult<f64> {
        model::energy(self.model()?, q, &Threads::default())
    }
    fn gradient<'py>(
        &mut self,
        py: Python<'py>,
        q: PyReadonlyArray1<'py, f64>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        model::gradient(py, self.model()?, q, &Threads::default())
    }
    #[pyo3(signature = (q, projected=false))]
    fn hessian<'py>(
        &mut self,
        py: Python<'py>,
        q: PyReadonlyArray1<'py, f64>,
        projected: bool,
    ) -> PyResult<Csc<'py>> {
        model::hessian(py, self.model()?, q, projected, &Threads::default())
    }
    fn mass<'py>(&mut self, py: Python<'py>) -> PyResult<Csc<'py>> {
        Ok(model::mass(py, self.model()?))
    }
    /// `a = M⁻¹(−∇V(q) − D v)` at time `t` (default: the step's start), with the scene's
    /// damping and mass (a consistent mass is factored once per run).
    #[pyo3(signature = (q, v, t=None))]
    fn acceleration<'py>(
        &mut self,
        py: Python<'py>,
        q: PyReadonlyArray1<'py, f64>,
        v: PyReadonlyArray1<'py, f64>,
        t: Option<f64>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let t = t.unwrap_or(self.t);
        let (model, dynamics, report) = self.parts()?;
        let n = model.num_dofs();
        let (Ok(q), Ok(v)) = (q.as_slice(), v.as_slice()) else {
            return Err(PyValueError::new_err(
                "q and v must be contiguous float64 arrays",
            ));
        };
        if q.len() != n || v.len() != n {
            return Err(PyValueError::new_err(format!(
                "q and v have {} and {} entries; the model has {n} free DOFs",
                q.len(),
                v.len()
            )));
        }
        let mut a = vec![0.0; n];
        model.set_time(t);
        dynamics
            .acceleration(model, q, v, &mut a, report)
            .map_err(|e| PyRuntimeError::new_err(e.to_string()))?;
        Ok(a.into_pyarray(py))
    }
}
