//! Service types known at run time, service clients and servers, as rclpy
//! names them: `client = node.create_client(srv_type, name)`,
//! `client.wait_for_service(timeout_sec)`, `client.call(request)`, and
//! `node.create_service(srv_type, name, callback)`.

use std::path::PathBuf;
use std::time::Duration;

use pyo3::exceptions::{PyLookupError, PyTypeError, PyValueError};
use pyo3::prelude::*;
use shm_cdr::dynamic::DynamicType;
use shm_runtime::rmw::Distro;
use shm_runtime::service::{CallbackServiceServer, ServiceClient, ServiceRequest};
use shm_runtime::types::{local::LocalInterfaces, ResolvedService};
use shm_runtime::Serialized;
use zenoh::Wait;

use crate::convert;
use crate::errors::middleware;
use crate::message::{Payload, PyMessage, Root};
use crate::node::CALLBACK_ERRORS;
use crate::types::PyMessageType;

/// A ROS 2 service type: its `Request` and `Response` message types.
#[pyclass(name = "ServiceType", module = "shm_cdr", frozen)]
pub(crate) struct PyServiceType {
    pub(crate) service: ResolvedService,
    /// The service as one run-time type, where it is known whole (by name,
    /// from files): what a server of it describes to other nodes.
    pub(crate) described: Option<DynamicType>,
}

impl PyServiceType {
    /// The service type `obj` names: a `ServiceType`, or a name resolved as
    /// [`service_type`] resolves it.
    pub(crate) fn resolve(obj: &Bound<'_, PyAny>) -> PyResult<ResolvedService> {
        Ok(Self::resolve_described(obj)?.0)
    }

    /// [`resolve`](Self::resolve), with the service as one run-time type
    /// where it is known whole.
    pub(crate) fn resolve_described(
        obj: &Bound<'_, PyAny>,
    ) -> PyResult<(ResolvedService, Option<DynamicType>)> {
        if let Ok(ty) = obj.cast::<PyServiceType>() {
            let ty = ty.get();
            return Ok((ty.service.clone(), ty.described.clone()));
        }
        if let Ok(name) = obj.extract::<String>() {
            let ty = by_name(&name, &[])?;
            return Ok((ty.service, ty.described));
        }
        Err(PyTypeError::new_err(
            "a service type is a shm_cdr.ServiceType or its name (\"pkg/srv/Name\")",
        ))
    }
}

fn by_name(name: &str, interfaces: &[PathBuf]) -> PyResult<PyServiceType> {
    let distro = Distro::from_env().map_err(|e| PyValueError::new_err(e.to_string()))?;
    let ty = match shm_runtime::types::service_type_by_name(distro, name) {
        Some(ty) => ty.map_err(middleware)?,
        None => {
            let local = LocalInterfaces::load(interfaces).map_err(middleware)?;
            let full = match name.split('/').collect::<Vec<_>>()[..] {
                [package, short] => format!("{package}/srv/{short}"),
                _ => name.to_owned(),
            };
            match local.resolve_service_type(&full) {
                Some(ty) => ty.map_err(middleware)?,
                None => {
                    return Err(PyLookupError::new_err(format!(
                        "no service type {name}: it is not in the standard set of {} and no \
                         interface file given defines it (pass interfaces=[\"path/to/pkg\"] for \
                         your own .srv files)",
                        distro.name()
                    )))
                }
            }
        }
    };
    Ok(PyServiceType {
        service: ResolvedService::of_type(&ty).map_err(middleware)?,
        described: Some(ty),
    })
}

/// The service type `name` (`pkg/srv/Name` or `pkg/Name`): from the standard
/// set built in, as the distribution `ROS_DISTRO` names defines it (Kilted
/// if unset), else from the `.srv` files of `interfaces` (package
/// directories, or directories holding packages).
#[pyfunction]
#[pyo3(signature = (name, interfaces = None))]
pub(crate) fn service_type(
    name: &str,
    interfaces: Option<Vec<PathBuf>>,
) -> PyResult<PyServiceType> {
    by_name(name, interfaces.as_deref().unwrap_or_default())
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
        let message = convert::message_of(&self.service.request, request)?;
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
            described: None,
        }
    }
}

/// A server of a service: each call is answered by
/// `callback(request, response)`, on a thread of the node's executor, with
/// what it returns (the response given, filled, or another message of the
/// `Response` type, or a dict of its fields). An exception in the callback
/// is the client's error reply, and `shm_cdr.spin()` raises it.
#[pyclass(name = "Service", module = "shm_cdr", frozen)]
pub(crate) struct PyService {
    pub(crate) server: CallbackServiceServer<Serialized>,
    pub(crate) service: ResolvedService,
    pub(crate) described: Option<DynamicType>,
}

#[pymethods]
impl PyService {
    /// The service's type.
    #[getter]
    fn srv_type(&self) -> PyServiceType {
        PyServiceType {
            service: self.service.clone(),
            described: self.described.clone(),
        }
    }

    /// The service's key expression on Zenoh.
    #[getter]
    fn key_expr(&self) -> &str {
        self.server.key_expr()
    }

    /// How many requests were not valid (an attachment that is not
    /// rmw_zenoh's); each got an error reply.
    #[getter]
    fn malformed(&self) -> u64 {
        self.server.malformed()
    }

    fn __repr__(&self) -> String {
        format!(
            "<shm_cdr.Service {} of {}>",
            self.server.key_expr(),
            self.service.name
        )
    }
}

/// Answer `request` with `callback(request, response)`: run with the GIL on
/// an executor's thread; the reply goes out without it.
pub(crate) fn answer(
    service: &ResolvedService,
    callback: &Py<PyAny>,
    request: ServiceRequest<Serialized>,
) {
    // `None` while the interpreter shuts down: the call then ends unanswered,
    // which its client sees at once.
    let Some(outcome) = Python::try_attach(|py| {
        let outcome = respond(py, service, callback, &request);
        if let Err(error) = &outcome {
            let why = format!("the service callback raised {error}");
            CALLBACK_ERRORS.push(py, error.clone_ref(py));
            return Err(why);
        }
        outcome.map_err(|e| e.to_string())
    }) else {
        return;
    };
    match outcome {
        Ok(cdr) => {
            if let Err(e) = request.reply_serialized(&cdr).wait() {
                // No caller to raise to: `spin` raises it.
                Python::try_attach(|py| {
                    let error = middleware(format!("{}: the reply failed: {e}", service.name));
                    CALLBACK_ERRORS.push(py, error);
                });
            }
        }
        Err(why) => request.reply_err(why),
    }
}

/// The response's bytes: the request decoded, the callback called with it
/// and a default response, its answer taken as a response.
fn respond(
    py: Python<'_>,
    service: &ResolvedService,
    callback: &Py<PyAny>,
    request: &ServiceRequest<Serialized>,
) -> PyResult<Vec<u8>> {
    let bytes = request
        .serialized()
        .to_bytes()
        .into_owned()
        .into_boxed_slice();
    let request = PyMessage::new(Root::decode(&service.request, Payload::Copied(bytes))?);
    let response = PyMessage::new(Root::owned(service.response.default_message()));
    let answer = callback.call1(py, (request, response))?;
    let answer = answer.bind(py);
    if answer.is_none() {
        return Err(PyTypeError::new_err(format!(
            "the callback of a server of {} returned None: return the response",
            service.name
        )));
    }
    let message = convert::message_of(&service.response, answer)?;
    shm_cdr::to_vec(&message).map_err(middleware)
}
