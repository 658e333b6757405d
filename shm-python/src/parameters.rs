//! A node's parameters from Python, as rclpy gives them: declared with a
//! default (or the value `--ros-args -p` gave), read, set; served to other
//! nodes and tools (`ros2 param`, `shm-ros2 param`) by the node's six
//! parameter services.

use pyo3::exceptions::{PyLookupError, PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyByteArray, PyBytes, PyDict, PyFloat, PyInt, PyList, PyString};
use shm_runtime::parameters::ParameterValue;

/// A parameter: its name and value (`None` when it is not set).
#[pyclass(name = "Parameter", module = "shm_cdr", frozen, get_all)]
pub(crate) struct PyParameter {
    /// The parameter's name.
    name: String,
    /// Its value: bool, int, float, str, bytes, a list of one of those, or
    /// None.
    value: Py<PyAny>,
}

#[pymethods]
impl PyParameter {
    #[new]
    #[pyo3(signature = (name, value = None))]
    fn new(py: Python<'_>, name: String, value: Option<Py<PyAny>>) -> Self {
        Self {
            name,
            value: value.unwrap_or_else(|| py.None()),
        }
    }

    fn __repr__(&self, py: Python<'_>) -> PyResult<String> {
        Ok(format!(
            "Parameter({:?}, {})",
            self.name,
            self.value.bind(py).repr()?
        ))
    }
}

/// Whether `set_parameters` applied a value, and why not.
#[pyclass(name = "SetParametersResult", module = "shm_cdr", frozen, get_all)]
pub(crate) struct PySetParametersResult {
    /// Whether the values were applied.
    successful: bool,
    /// Why not (empty when they were).
    reason: String,
}

#[pymethods]
impl PySetParametersResult {
    fn __repr__(&self) -> String {
        format!(
            "SetParametersResult(successful={}, reason={:?})",
            if self.successful { "True" } else { "False" },
            self.reason
        )
    }
}

impl PyParameter {
    pub(crate) fn of(py: Python<'_>, name: &str, value: &ParameterValue) -> PyResult<Self> {
        Ok(Self {
            name: name.to_owned(),
            value: to_py(py, value)?.unbind(),
        })
    }
}

impl PySetParametersResult {
    pub(crate) fn new(successful: bool, reason: String) -> Self {
        Self { successful, reason }
    }
}

/// A parameter value as Python sees it.
pub(crate) fn to_py<'py>(py: Python<'py>, value: &ParameterValue) -> PyResult<Bound<'py, PyAny>> {
    Ok(match value {
        ParameterValue::NotSet => py.None().into_bound(py),
        ParameterValue::Bool(v) => PyBool::new(py, *v).to_owned().into_any(),
        ParameterValue::Integer(v) => v.into_pyobject(py)?.into_any(),
        ParameterValue::Double(v) => PyFloat::new(py, *v).into_any(),
        ParameterValue::String(v) => PyString::new(py, v).into_any(),
        ParameterValue::ByteArray(v) => PyBytes::new(py, v).into_any(),
        ParameterValue::BoolArray(v) => PyList::new(py, v)?.into_any(),
        ParameterValue::IntegerArray(v) => PyList::new(py, v)?.into_any(),
        ParameterValue::DoubleArray(v) => PyList::new(py, v)?.into_any(),
        ParameterValue::StringArray(v) => PyList::new(py, v)?.into_any(),
        // ParameterValue may gain kinds; none is made by this package.
        #[allow(unreachable_patterns)]
        _ => py.None().into_bound(py),
    })
}

/// A Python value as a parameter value: the kinds rcl_interfaces has.
pub(crate) fn from_py(name: &str, value: &Bound<'_, PyAny>) -> PyResult<ParameterValue> {
    let wrong = || {
        PyTypeError::new_err(format!(
            "parameter {name}: a value is a bool, int, float, str, bytes, a list of one of those, \
             or None, not {}",
            value
                .get_type()
                .name()
                .map_or_else(|_| "?".to_owned(), |n| n.to_string())
        ))
    };
    if value.is_none() {
        return Ok(ParameterValue::NotSet);
    }
    if let Ok(b) = value.cast::<PyBool>() {
        return Ok(ParameterValue::Bool(b.is_true()));
    }
    if value.is_instance_of::<PyInt>() {
        return value
            .extract::<i64>()
            .map(ParameterValue::Integer)
            .map_err(|_| {
                PyValueError::new_err(format!("parameter {name}: {value} is beyond int64"))
            });
    }
    if let Ok(f) = value.cast::<PyFloat>() {
        return Ok(ParameterValue::Double(f.value()));
    }
    if let Ok(s) = value.cast::<PyString>() {
        return Ok(ParameterValue::String(s.to_str()?.to_owned()));
    }
    if let Ok(b) = value.cast::<PyBytes>() {
        return Ok(ParameterValue::ByteArray(b.as_bytes().to_vec()));
    }
    if let Ok(b) = value.cast::<PyByteArray>() {
        return Ok(ParameterValue::ByteArray(b.to_vec()));
    }
    let Ok(list) = value
        .try_iter()
        .and_then(|items| items.collect::<PyResult<Vec<_>>>())
    else {
        return Err(wrong());
    };
    // A list takes its kind from its elements, all of one kind; an empty
    // list is an empty string array, as rclpy makes it.
    let all = |check: &dyn Fn(&Bound<'_, PyAny>) -> bool| list.iter().all(check);
    if all(&|v| v.is_instance_of::<PyBool>()) && !list.is_empty() {
        return Ok(ParameterValue::BoolArray(
            list.iter()
                .map(|v| v.is_truthy())
                .collect::<PyResult<_>>()?,
        ));
    }
    if all(&|v| v.is_instance_of::<PyInt>() && !v.is_instance_of::<PyBool>()) && !list.is_empty() {
        return Ok(ParameterValue::IntegerArray(
            list.iter()
                .map(|v| v.extract::<i64>())
                .collect::<PyResult<_>>()?,
        ));
    }
    if all(&|v| v.is_instance_of::<PyFloat>()) && !list.is_empty() {
        return Ok(ParameterValue::DoubleArray(
            list.iter()
                .map(|v| v.extract::<f64>())
                .collect::<PyResult<_>>()?,
        ));
    }
    if all(&|v| v.is_instance_of::<PyString>()) {
        return Ok(ParameterValue::StringArray(
            list.iter()
                .map(|v| v.extract::<String>())
                .collect::<PyResult<_>>()?,
        ));
    }
    Err(PyTypeError::new_err(format!(
        "parameter {name}: a list holds values of one kind (all bool, int, float or str)"
    )))
}

/// The parameters `parameters` gives: a list of `Parameter`s or a dict of
/// names to values.
pub(crate) fn set_list(parameters: &Bound<'_, PyAny>) -> PyResult<Vec<(String, ParameterValue)>> {
    if let Ok(dict) = parameters.cast::<PyDict>() {
        return dict
            .iter()
            .map(|(k, v)| {
                let name: String = k.extract()?;
                let value = from_py(&name, &v)?;
                Ok((name, value))
            })
            .collect();
    }
    parameters
        .try_iter()
        .map_err(|_| PyTypeError::new_err("set_parameters takes a list of Parameter or a dict"))?
        .map(|item| {
            let item = item?;
            let parameter = item.cast::<PyParameter>().map_err(|_| {
                PyTypeError::new_err("set_parameters takes a list of Parameter or a dict")
            })?;
            let parameter = parameter.get();
            let value = from_py(&parameter.name, parameter.value.bind(item.py()))?;
            Ok((parameter.name.clone(), value))
        })
        .collect()
}

/// The error for a parameter that is not declared, as rclpy raises it.
pub(crate) fn not_declared(name: &str) -> PyErr {
    PyLookupError::new_err(format!(
        "parameter {name} is not declared: declare it first (node.declare_parameter({name:?}, \
         default))"
    ))
}
