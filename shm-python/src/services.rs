//! Service types known at run time and service clients, as rclpy names
//! them: `client = node.create_client(srv_type, name)`,
//! `client.wait_for_service(timeout_sec)`, `client.call(request)`.

use std::time::Duration;

use pyo3::exceptions::{PyLookupError, PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use shm_runtime::rmw::Distro;
use shm_runtime::service::ServiceClient;
use shm_runtime::types::ResolvedService;
use shm_runtime::Serialized;

use crate::convert;
use crate::errors::middleware;
use crate::message::{Payload, PyMessage, Root};
use crate::types::PyMessageType;

/// A ROS 2 service type: its `Request` and `Response` message types.
#[pyclass(name = "ServiceType", module = "shm_cdr", frozen)]
pub(crate) struct PyServiceType {
    pub(crate) service: ResolvedService,
}

impl PyServiceType {
    /// The service type `obj` names: a `ServiceType`, or a name resolved as
    /// [`service_type`] resolves it.
    pub(crate) fn resolve(obj: &Bound<'_, PyAny>) -> PyResult<ResolvedService> {
        if let Ok(ty) = obj.cast::<PyServiceType>() {
            return Ok(ty.get().service.clone());
        }
        if let Ok(name) = obj.extract::<String>() {
            return by_name(&name);
        }
        Err(PyTypeError::new_err(
            "a service type is a shm_cdr.ServiceType or its name (\"pkg/srv/Name\")",
        ))
    }
}

fn by_name(name: &str) -> PyResult<ResolvedService> {
    let distro = Distro::from_env().map_err(|e| PyValueError::new_err(e.to_string()))?;
    match shm_runtime::types::service_by_name(distro, name) {
        Some(Ok(service)) => Ok(service),
        Some(Err(e)) => Err(middleware(e)),
        None => Err(PyLookupError::new_err(format!(
            "no service type {name} in the standard set of {}",
            distro.name()
        ))),
    }
}

/// The service type `name` (`pkg/srv/Name` or `pkg/Name`) from the standard
/// set built in, as the distribution `ROS_DISTRO` names defines it.
#[pyfunction]
pub(crate) fn service_type(name: &str) -> PyResult<PyServiceType> {
    Ok(PyServiceType {
        service: by_name(name)?,
    })
}

#[pymethods]
impl PyServiceType {
    /// `pkg/srv/Name`.
    #[getter]
    fn name(&self) -> &str {
        &self.service.name
    }

    /// The service's RIHS01 hash, as rosidl computes it.
    #[getter]
    fn hash(&self) -> &str {
        &self.service.hash
    }

    /// The request's message type.
    #[getter(Request)]
    fn request(&self) -> PyMessageType {
        PyMessageType {
            ty: self.service.request.clone(),
        }
    }

    /// The response's message type.
    #[getter(Response)]
    fn response(&self) -> PyMessageType {
        PyMessageType {
            ty: self.service.response.clone(),
        }
    }

    fn __repr__(&self) -> String {
        format!("shm_cdr.service_type({:?})", self.service.name)
    }
}

/// A client of a service: `call(request)` with a request message or a dict
/// of its fields, waiting for the response as long as the server is there.
#[pyclass(name = "Client", module = "shm_cdr", frozen)]
pub(crate) struct PyClient {
    pub(crate) client: ServiceClient<Serialized>,
    pub(crate) service: ResolvedService,
}

#[pymethods]
impl PyClient {
    /// Send `request` and wait for the response (a message of the
    /// service's `Response` type). Raises `ShmCdrError` if the server goes
    /// away or answers with an error.
    fn call(&self, py: Python<'_>, request: &Bound<'_, PyAny>) -> PyResult<PyMessage> {
        let ty = &self.service.request;
        let message = if let Ok(message) = request.cast::<PyMessage>() {
            message.get().to_message_in(ty.default_message())?
        } else if let Ok(dict) = request.cast::<PyDict>() {
            convert::fill(ty.default_message(), ty, 0, dict)?
        } else {
            return Err(PyTypeError::new_err(format!(
                "call takes a {} or a dict of its fields",
                ty.name()
            )));
        };
        let cdr = shm_cdr::to_vec(&message).map_err(middleware)?;
        let reply = py
            .detach(|| self.client.call_serialized(&cdr))
            .map_err(|e| middleware(format!("{}: {e}", self.service.name)))?;
        let bytes = reply.payload().to_bytes().into_owned().into_boxed_slice();
        Ok(PyMessage::new(Root::decode(
            &self.service.response,
            Payload::Copied(bytes),
        )?))
    }

    /// Wait up to `timeout_sec` seconds (for ever if `None`) for a server;
    /// whether one is there.
    #[pyo3(signature = (timeout_sec = None))]
    fn wait_for_service(&self, py: Python<'_>, timeout_sec: Option<f64>) -> PyResult<bool> {
        let timeout = match timeout_sec {
            None => Duration::MAX,
            Some(t) => Duration::try_from_secs_f64(t)
                .map_err(|_| PyValueError::new_err("timeout_sec: give seconds, 0 or more"))?,
        };
        Ok(py.detach(|| self.client.wait_for_service(timeout)))
    }

    /// Whether a server is there now.
    fn service_is_ready(&self) -> bool {
        self.client.is_service_available()
    }

    /// The service's type.
    #[getter]
    fn srv_type(&self) -> PyServiceType {
        PyServiceType {
            service: self.service.clone(),
        }
    }
}
