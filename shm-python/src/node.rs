//! Nodes, publishers and subscriptions, as rclpy names them.

use std::collections::VecDeque;
use std::path::PathBuf;
use std::sync::{Arc, Condvar, Mutex, OnceLock};
use std::time::{Duration, Instant};

use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use shm_cdr::dynamic::{DynamicType, Message};
use shm_runtime::graph::Graph;
use shm_runtime::parameters::ParameterValue;
use shm_runtime::rmw::{Durability, History, Qos, Reliability};
use shm_runtime::types::{self, local::LocalInterfaces, ResolvedService};
use shm_runtime::{CallbackSubscriber, RosNode, RosPublisher, RosSubscriber, RosoutLayer};
use zenoh::Wait;

use crate::context::{self, Context};
use crate::convert;
use crate::errors::middleware;
use crate::loan::PyLoan;
use crate::logging::PyLogger;
use crate::message::{Payload, PyMessage, Root};
use crate::parameters::{self, PyParameter, PySetParametersResult};
use crate::services::{self, PyClient, PyService, PyServiceType};
use crate::timers::{PyClock, PyTimer};
use crate::types::PyMessageType;

/// How often a blocking wait looks for Ctrl-C (`KeyboardInterrupt`).
const SIGNAL_CHECK: Duration = Duration::from_millis(100);

/// Exceptions raised by subscription callbacks, for `spin` to raise.
pub(crate) struct CallbackErrors {
    errors: Mutex<VecDeque<PyErr>>,
    arrived: Condvar,
}

pub(crate) static CALLBACK_ERRORS: CallbackErrors = CallbackErrors {
    errors: Mutex::new(VecDeque::new()),
    arrived: Condvar::new(),
};

/// How many callback exceptions wait for `spin`; past them, each is printed
/// with its traceback (as Python prints an exception of a thread) and let
/// go, so that a program that never spins holds no more.
const KEPT_CALLBACK_ERRORS: usize = 16;

impl CallbackErrors {
    pub(crate) fn push(&self, py: Python<'_>, error: PyErr) {
        let mut errors = self.errors.lock().unwrap_or_else(|p| p.into_inner());
        if errors.len() < KEPT_CALLBACK_ERRORS {
            errors.push_back(error);
            self.arrived.notify_all();
        } else {
            drop(errors);
            error.print(py);
        }
    }

    /// The first exception a callback raised, waiting up to `timeout`.
    pub(crate) fn wait(&self, timeout: Duration) -> Option<PyErr> {
        let errors = self.errors.lock().unwrap_or_else(|p| p.into_inner());
        let (mut errors, _) = self
            .arrived
            .wait_timeout_while(errors, timeout, |e| e.is_empty())
            .unwrap_or_else(|p| p.into_inner());
        errors.pop_front()
    }
}

/// The QoS `qos` gives: a depth (keep last, reliable, volatile), or a
/// profile with rclpy's attributes (`depth`, `history`, `reliability`,
/// `durability`, each an int as rclpy's enums are) such as rclpy's own
/// `QoSProfile` or `shm_cdr.QoSProfile`.
fn qos_from(qos: &Bound<'_, PyAny>) -> PyResult<Qos> {
    if let Ok(depth) = qos.extract::<usize>() {
        return Ok(Qos::with_history(
            Reliability::Reliable,
            Durability::Volatile,
            History::KeepLast(depth),
        ));
    }
    let policy = |name: &str| -> PyResult<i64> {
        let value = qos.getattr(name).map_err(|_| {
            PyTypeError::new_err(format!(
                "qos is a depth (int) or a QoS profile with depth, history, reliability and \
                 durability (shm_cdr.QoSProfile, rclpy's QoSProfile), not {}",
                qos.get_type()
                    .name()
                    .map_or_else(|_| "?".to_owned(), |n| n.to_string())
            ))
        })?;
        value.extract::<i64>().map_err(|_| {
            PyTypeError::new_err(format!(
                "the QoS profile's {name} is not an int or an IntEnum"
            ))
        })
    };
    let depth = usize::try_from(policy("depth")?)
        .map_err(|_| PyValueError::new_err("the QoS profile's depth is negative"))?;
    // rmw's numbering: 0 system default, 1 the first, 2 the second.
    let history = match policy("history")? {
        0 | 1 => History::KeepLast(depth),
        2 => History::KeepAll,
        n => {
            return Err(PyValueError::new_err(format!(
                "history {n}: give 1 (keep last) or 2 (keep all)"
            )))
        }
    };
    let reliability = match policy("reliability")? {
        0 | 1 => Reliability::Reliable,
        2 => Reliability::BestEffort,
        n => {
            return Err(PyValueError::new_err(format!(
                "reliability {n}: give 1 (reliable) or 2 (best effort)"
            )))
        }
    };
    let durability = match policy("durability")? {
        1 => Durability::TransientLocal,
        0 | 2 => Durability::Volatile,
        n => {
            return Err(PyValueError::new_err(format!(
                "durability {n}: give 1 (transient local) or 2 (volatile)"
            )))
        }
    };
    Ok(Qos::with_history(reliability, durability, history))
}

/// A ROS 2 node (the package's `shm_cdr.Node` wraps it with rclpy's
/// signatures, so that it can be subclassed as rclpy's).
#[pyclass(name = "Node", module = "shm_cdr._native", frozen)]
pub(crate) struct PyNode {
    node: Arc<RosNode>,
    /// Its `/rosout` publisher, made by the first `get_logger`.
    rosout: OnceLock<Arc<RosoutLayer>>,
    /// Its timers, kept as rclpy's node keeps them, until `destroy_timer`.
    timers: Mutex<Vec<Py<PyTimer>>>,
    /// Its callbacks' subscriptions and its services, kept as rclpy's node
    /// keeps them (they work without a reference of the caller's), until
    /// `destroy_subscription`, `destroy_service` or `destroy_node`.
    kept: Mutex<Vec<Py<PyAny>>>,
    /// Kept for as long as the node: its session and pool.
    _context: Arc<Context>,
}

#[pymethods]
impl PyNode {
    #[new]
    #[pyo3(signature = (name, namespace = None, *, args = None))]
    fn new(
        py: Python<'_>,
        name: &str,
        namespace: Option<&str>,
        args: Option<Vec<String>>,
    ) -> PyResult<Self> {
        let context = context::get(py)?;
        let node = py
            .detach(|| {
                let mut builder = RosNode::builder(&context.session, name).shm(&context.shm);
                if let Some(namespace) = namespace {
                    builder = builder.namespace(namespace);
                }
                if let Some(args) = &args {
                    builder = builder.ros_args(args);
                }
                builder.wait()
            })
            .map_err(middleware)?;
        Ok(Self {
            node: Arc::new(node),
            rosout: OnceLock::new(),
            timers: Mutex::new(Vec::new()),
            kept: Mutex::new(Vec::new()),
            _context: context,
        })
    }

    /// The node's name.
    fn get_name(&self) -> String {
        self.node.info().name.clone()
    }

    /// The node's namespace (`/` for the root).
    fn get_namespace(&self) -> String {
        self.node.info().namespace.clone()
    }

    /// `/namespace/name`.
    fn get_fully_qualified_name(&self) -> String {
        self.node.info().fqn()
    }

    /// A publisher of `msg_type` (a `MessageType` or its name) on `topic`,
    /// with `qos` (a depth, or a QoS profile).
    #[pyo3(signature = (msg_type, topic, qos = None))]
    fn create_publisher(
        &self,
        py: Python<'_>,
        msg_type: &Bound<'_, PyAny>,
        topic: &str,
        qos: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<PyPublisher> {
        let ty = PyMessageType::resolve(msg_type)?;
        let qos = qos.map(qos_from).transpose()?.unwrap_or_default();
        let publisher = py
            .detach(|| self.node.declare_dynamic_publisher(topic, &ty, qos).wait())
            .map_err(middleware)?;
        Ok(PyPublisher { publisher, ty })
    }

    /// A subscription to `msg_type` on `topic`. With a `callback`, each
    /// message is given to it on a thread of the node's executor (run
    /// `shm_cdr.spin()` to see the exceptions it raises); without, read the
    /// messages with `recv()` or by iterating over the subscription.
    #[pyo3(signature = (msg_type, topic, callback = None, qos = None))]
    fn create_subscription(
        &self,
        py: Python<'_>,
        msg_type: &Bound<'_, PyAny>,
        topic: &str,
        callback: Option<Py<PyAny>>,
        qos: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Py<PySubscription>> {
        let ty = PyMessageType::resolve(msg_type)?;
        let qos = qos.map(qos_from).transpose()?.unwrap_or_default();
        let builder = self.node.declare_dynamic_subscriber(topic, &ty, qos);
        let receiver = match callback {
            // Read through the caller's reference, so not kept: samples it
            // no longer reads would hold their shared memory.
            None => {
                let queue = py.detach(|| builder.wait()).map_err(middleware)?;
                return Py::new(
                    py,
                    PySubscription {
                        receiver: Receiver::Queue(queue),
                        ty,
                    },
                );
            }
            Some(callback) => {
                let decode_as = ty.clone();
                let subscriber = py
                    .detach(|| {
                        builder
                            .callback(move |sample| {
                                // Not while the interpreter shuts down: the
                                // sample is dropped then, as Python is gone.
                                Python::try_attach(|py| {
                                    let outcome = Root::decode(&decode_as, Payload::of(sample))
                                        .and_then(|root| {
                                            callback.call1(py, (PyMessage::new(root),))
                                        });
                                    if let Err(error) = outcome {
                                        CALLBACK_ERRORS.push(py, error);
                                    }
                                });
                            })
                            .wait()
                    })
                    .map_err(middleware)?;
                Receiver::Callback(subscriber)
            }
        };
        self.keep(py, PySubscription { receiver, ty })
    }

    /// A client of the service `srv_type` (a `ServiceType` or its name) on
    /// `srv_name`.
    fn create_client(
        &self,
        py: Python<'_>,
        srv_type: &Bound<'_, PyAny>,
        srv_name: &str,
    ) -> PyResult<PyClient> {
        let service = PyServiceType::resolve(srv_type)?;
        let client = py
            .detach(|| {
                self.node
                    .declare_serialized_client(srv_name, &service.name, &service.hash)
                    // As rclpy's `call`: the answer is awaited as long as
                    // the server is there.
                    .timeout(Duration::MAX)
                    .wait()
            })
            .map_err(middleware)?;
        Ok(PyClient { client, service })
    }

    /// A server of the service `srv_type` (a `ServiceType` or its name) on
    /// `srv_name`: each call is answered by `callback(request, response)`,
    /// which returns the response (as rclpy's servers do), on a thread of the
    /// node's executor. An exception it raises is the client's error reply,
    /// and `shm_cdr.spin()` raises it.
    fn create_service(
        &self,
        py: Python<'_>,
        srv_type: &Bound<'_, PyAny>,
        srv_name: &str,
        callback: Py<PyAny>,
    ) -> PyResult<Py<PyService>> {
        let (service, described) = PyServiceType::resolve_described(srv_type)?;
        let for_calls = service.clone();
        let server = py
            .detach(|| {
                // Described to other nodes where the type is known whole.
                let builder = match &described {
                    Some(ty) => self.node.declare_dynamic_service(srv_name, ty),
                    None => {
                        self.node
                            .declare_serialized_service(srv_name, &service.name, &service.hash)
                    }
                };
                builder
                    .callback(move |request| services::answer(&for_calls, &callback, request))
                    .wait()
            })
            .map_err(middleware)?;
        self.keep(
            py,
            PyService {
                server,
                service,
                described,
            },
        )
    }

    /// The message type of `topic` as its publishers (else its subscribers)
    /// announce it: the standard type of that hash, else the type of the
    /// `.msg` files of `interfaces`, else the description the announcing
    /// node gives through its type-description service (Jazzy and later).
    /// Waits up to `timeout_sec` seconds for the topic and the node's answer.
    #[pyo3(signature = (topic, timeout_sec = 5.0, interfaces = None))]
    fn get_topic_type(
        &self,
        py: Python<'_>,
        topic: &str,
        timeout_sec: f64,
        interfaces: Option<Vec<PathBuf>>,
    ) -> PyResult<PyMessageType> {
        let timeout = seconds("timeout_sec", timeout_sec)?;
        let local =
            LocalInterfaces::load(interfaces.as_deref().unwrap_or_default()).map_err(middleware)?;
        let topic = self
            .node
            .resolve_topic_name(topic)
            .map_err(|e| PyValueError::new_err(e.to_string()))?;
        let resolved = py
            .detach(|| {
                let (graph, left) = self.graph_with(timeout, |graph| {
                    !graph.publishers(&topic).is_empty() || !graph.subscribers(&topic).is_empty()
                })?;
                types::of_topic(&self.node, left, &graph, &topic, &local)
            })
            .map_err(middleware)?;
        Ok(PyMessageType { ty: resolved.ty })
    }

    /// The type of service `srv_name` as its servers announce it: the
    /// standard type of that hash, else the description the server's node
    /// gives. Waits up to `timeout_sec` seconds for a server and the answer.
    #[pyo3(signature = (srv_name, timeout_sec = 5.0))]
    fn get_service_type(
        &self,
        py: Python<'_>,
        srv_name: &str,
        timeout_sec: f64,
    ) -> PyResult<PyServiceType> {
        let timeout = seconds("timeout_sec", timeout_sec)?;
        let service = self
            .node
            .resolve_service_name(srv_name)
            .map_err(|e| PyValueError::new_err(e.to_string()))?;
        let resolved = py
            .detach(|| {
                let (graph, left) =
                    self.graph_with(timeout, |graph| !graph.servers(&service).is_empty())?;
                types::service_type_of(&self.node, left, &graph, &service, None)
            })
            .map_err(middleware)?;
        Ok(PyServiceType {
            service: ResolvedService::of_type(&resolved).map_err(middleware)?,
            described: Some(resolved),
        })
    }

    /// Call `callback()` every `timer_period_sec` seconds of the node's ROS
    /// time, on a thread of the timer's own, as rclpy's `create_timer`; an
    /// exception it raises is raised by `shm_cdr.spin()`. The node keeps the
    /// timer until `destroy_timer`.
    fn create_timer(
        &self,
        py: Python<'_>,
        timer_period_sec: f64,
        callback: Py<PyAny>,
    ) -> PyResult<Py<PyTimer>> {
        let period = seconds("timer_period_sec", timer_period_sec)?;
        if period.is_zero() {
            return Err(PyValueError::new_err(
                "timer_period_sec: give a period above 0 seconds",
            ));
        }
        let timer = Py::new(py, PyTimer::start(&self.node, period, callback)?)?;
        self.timers
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .push(timer.clone_ref(py));
        Ok(timer)
    }

    /// Stop `timer` and let the node forget it; whether the node had it.
    fn destroy_timer(&self, py: Python<'_>, timer: &Bound<'_, PyTimer>) -> bool {
        timer.get().stop(py);
        let mut timers = self.timers.lock().unwrap_or_else(|p| p.into_inner());
        let before = timers.len();
        timers.retain(|t| !t.is(timer));
        timers.len() < before
    }

    /// The node's clock (ROS time, simulated while the node uses it).
    fn get_clock(&self) -> PyClock {
        PyClock {
            clock: self.node.clock().clone(),
        }
    }

    /// The node's logger (`demo.talker` for `/demo/talker`), as rclpy's:
    /// what it logs goes to stderr and to `/rosout`.
    fn get_logger(&self, py: Python<'_>) -> PyResult<PyLogger> {
        let rosout = match self.rosout.get() {
            Some(rosout) => rosout.clone(),
            None => {
                let made = Arc::new(py.detach(|| self.node.rosout_layer()).map_err(middleware)?);
                // Another thread may have made one meanwhile: keep the first.
                self.rosout.get_or_init(|| made).clone()
            }
        };
        let name = rosout.logger_name().to_owned();
        Ok(PyLogger { rosout, name })
    }

    /// Declare parameter `name` with its default `value` (the value
    /// `--ros-args -p name:=…` gave wins); returns the parameter.
    #[pyo3(signature = (name, value = None))]
    fn declare_parameter(
        &self,
        py: Python<'_>,
        name: &str,
        value: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<PyParameter> {
        let default = match value {
            Some(value) => parameters::from_py(name, value)?,
            None => ParameterValue::NotSet,
        };
        let declared = py
            .detach(|| self.node.declare_parameter(name, default))
            .map_err(|e| PyValueError::new_err(e.to_string()))?;
        PyParameter::of(py, name, &declared)
    }

    /// The declared parameter `name`.
    fn get_parameter(&self, py: Python<'_>, name: &str) -> PyResult<PyParameter> {
        let value = self
            .node
            .parameter(name)
            .ok_or_else(|| parameters::not_declared(name))?;
        PyParameter::of(py, name, &value)
    }

    /// Whether parameter `name` is declared.
    fn has_parameter(&self, name: &str) -> bool {
        self.node.parameter(name).is_some()
    }

    /// Set parameters, all or none (a list of `Parameter`s or a dict of
    /// names to values); one result per parameter, as rclpy's.
    fn set_parameters(
        &self,
        py: Python<'_>,
        parameters: &Bound<'_, PyAny>,
    ) -> PyResult<Vec<PySetParametersResult>> {
        let set = parameters::set_list(parameters)?;
        let result = py.detach(|| self.node.set_parameters_atomically(&set));
        Ok(set
            .iter()
            .map(|_| PySetParametersResult::new(result.successful, result.reason.clone()))
            .collect())
    }

    /// Let the node forget `subscription` (it ends when Python frees it);
    /// whether the node had it.
    fn destroy_subscription(&self, subscription: &Bound<'_, PySubscription>) -> bool {
        self.forget(subscription.as_any())
    }

    /// Let the node forget `service` (it ends when Python frees it);
    /// whether the node had it.
    fn destroy_service(&self, service: &Bound<'_, PyService>) -> bool {
        self.forget(service.as_any())
    }

    /// Stop the node's timers and let it forget its subscriptions and
    /// services (each ends when Python frees it), as rclpy's
    /// `destroy_node`.
    fn destroy_node(&self, py: Python<'_>) {
        let timers = std::mem::take(&mut *self.timers.lock().unwrap_or_else(|p| p.into_inner()));
        for timer in &timers {
            timer.get().stop(py);
        }
        let kept = std::mem::take(&mut *self.kept.lock().unwrap_or_else(|p| p.into_inner()));
        drop((timers, kept));
    }

    fn __repr__(&self) -> String {
        format!("shm_cdr.Node({:?})", self.node.info().fqn())
    }
}

/// A publisher: `publish(msg)` with a message of its type or a dict of its
/// fields. Messages at or above the pool's threshold are written straight
/// into shared memory.
#[pyclass(name = "Publisher", module = "shm_cdr", frozen)]
pub(crate) struct PyPublisher {
    publisher: RosPublisher<DynamicType>,
    ty: DynamicType,
}

impl PyNode {
    /// `entity` as Python holds it, kept by the node too.
    fn keep<T>(&self, py: Python<'_>, entity: T) -> PyResult<Py<T>>
    where
        T: pyo3::PyClass + Into<pyo3::PyClassInitializer<T>>,
    {
        let entity = Py::new(py, entity)?;
        self.kept
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .push(entity.clone_ref(py).into_any());
        Ok(entity)
    }

    /// Let go of a kept entity; whether the node had it.
    fn forget(&self, entity: &Bound<'_, PyAny>) -> bool {
        let mut kept = self.kept.lock().unwrap_or_else(|p| p.into_inner());
        let before = kept.len();
        kept.retain(|e| !e.is(entity));
        kept.len() < before
    }

    /// A snapshot of the graph once `ready` holds of it, or once `timeout`
    /// passed; with the time left of `timeout` (at least a little, for a
    /// node's answer).
    fn graph_with(
        &self,
        timeout: Duration,
        ready: impl Fn(&Graph) -> bool,
    ) -> zenoh::Result<(Graph, Duration)> {
        const POLL: Duration = Duration::from_millis(20);
        let deadline = Instant::now() + timeout;
        loop {
            let graph = self.node.graph(timeout)?;
            let left = deadline.saturating_duration_since(Instant::now());
            if ready(&graph) || left.is_zero() {
                return Ok((graph, left.max(POLL * 10)));
            }
            std::thread::sleep(POLL.min(left));
        }
    }
}

/// `value` seconds as a duration, or a `ValueError` naming `name`.
fn seconds(name: &str, value: f64) -> PyResult<Duration> {
    Duration::try_from_secs_f64(value)
        .map_err(|_| PyValueError::new_err(format!("{name}: give seconds, 0 or more")))
}

#[pymethods]
impl PyPublisher {
    /// Publish `msg`; returns where its bytes went, as the runtime's
    /// `PayloadKind` in snake case: `shm` (written into shared memory),
    /// `heap` (below the pool's threshold), `receiver_pending` (a new
    /// subscriber's session is being asked whether it maps the pool: this
    /// message goes by the network), and the runtime's other kinds.
    fn publish(slf: &Bound<'_, Self>, msg: &Bound<'_, PyAny>) -> PyResult<String> {
        let py = slf.py();
        let this = slf.get();
        if let Ok(loan) = msg.cast::<PyLoan>() {
            let payload = loan.get().take_for(py, slf.as_any())?;
            return py
                .detach(|| this.publisher.publish_loaned(payload))
                .map(|outcome| kind(&outcome))
                .map_err(middleware);
        }
        this.publish_message(py, msg)
    }

    /// Lend a buffer for one message whose sequences of numbers named in
    /// `lengths` (`data=640 * 480 * 3`) are filled in place: a `Loan`, whose
    /// arrays are writable numpy arrays where the message will be sent from
    /// (shared memory at or above the pool's threshold), its other fields
    /// taken from `msg` (a message of this type or a dict; defaults if
    /// `None`) and settable until `publish(loan)`. The arrays are zeroed
    /// unless `zeroed=False` (then they hold what the buffer held, as
    /// `numpy.empty`'s do: write every element).
    #[pyo3(signature = (msg = None, *, zeroed = true, **lengths))]
    fn loan(
        slf: &Bound<'_, Self>,
        msg: Option<&Bound<'_, PyAny>>,
        zeroed: bool,
        lengths: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<PyLoan> {
        let py = slf.py();
        let this = slf.get();
        let message = match msg {
            None => this.ty.default_message(),
            Some(msg) => this.message_of(msg)?,
        };
        let empty = PyDict::new(py);
        PyLoan::new(
            py,
            slf.clone().into_any().unbind(),
            &this.ty,
            |size| this.publisher.loan_buffer(size),
            message,
            lengths.unwrap_or(&empty),
            zeroed,
        )
    }

    /// The publisher's message type.
    #[getter]
    fn msg_type(&self) -> PyMessageType {
        PyMessageType {
            ty: self.ty.clone(),
        }
    }

    /// Whether a subscription matches (across processes).
    fn has_subscribers(&self) -> bool {
        self.publisher.has_subscribers()
    }

    /// Each subscribing session (its Zenoh id) and how this publisher's
    /// messages reach it: `shared_memory` (in place), `checking` (the
    /// publisher is asking whether the session maps its pool; messages go
    /// by the network meanwhile), `bytes` (the link carries no shared
    /// memory, each message is copied into it), and the runtime's other
    /// reaches, in snake case.
    fn receivers(&self) -> Vec<(String, String)> {
        self.publisher
            .receivers()
            .into_iter()
            .map(|r| (r.session.to_string(), snake_case(&format!("{:?}", r.reach))))
            .collect()
    }

    /// Wait up to `timeout` seconds for a subscription to match; whether
    /// one did.
    fn wait_for_subscribers(&self, py: Python<'_>, timeout: f64) -> PyResult<bool> {
        let timeout = Duration::try_from_secs_f64(timeout)
            .map_err(|_| PyValueError::new_err("timeout: give seconds, 0 or more"))?;
        Ok(py.detach(|| self.publisher.wait_for_subscribers(timeout)))
    }
}

impl PyPublisher {
    fn message_of(&self, msg: &Bound<'_, PyAny>) -> PyResult<Message<'static>> {
        convert::message_of(&self.ty, msg)
    }

    fn publish_message(&self, py: Python<'_>, msg: &Bound<'_, PyAny>) -> PyResult<String> {
        if let Ok(message) = msg.cast::<PyMessage>() {
            let message = message.get();
            if let Some(root) = message.root() {
                if root.message.is_of(&self.ty) {
                    return self.send(py, &root.message);
                }
            }
            let converted = message.to_message_in(self.ty.default_message())?;
            return self.send(py, &converted);
        }
        if let Ok(dict) = msg.cast::<PyDict>() {
            let message = convert::fill(self.ty.default_message(), &self.ty, 0, dict)?;
            return self.send(py, &message);
        }
        Err(PyTypeError::new_err(format!(
            "publish takes a {} or a dict of its fields",
            self.ty.name()
        )))
    }

    /// Publish `message` (of this publisher's type) without the GIL; where
    /// its bytes went.
    fn send(&self, py: Python<'_>, message: &Message<'_>) -> PyResult<String> {
        py.detach(|| self.publisher.publish_dynamic(message).wait())
            .map(|outcome| kind(&outcome))
            .map_err(middleware)
    }
}

enum Receiver {
    Queue(RosSubscriber<DynamicType>),
    Callback(CallbackSubscriber<DynamicType>),
}

/// A subscription. Without a callback it is an iterator of messages:
/// `for msg in sub:` (or `sub.recv(timeout)`).
#[pyclass(name = "Subscription", module = "shm_cdr", frozen)]
pub(crate) struct PySubscription {
    receiver: Receiver,
    ty: DynamicType,
}

impl PySubscription {
    fn queue(&self) -> PyResult<&RosSubscriber<DynamicType>> {
        match &self.receiver {
            Receiver::Queue(queue) => Ok(queue),
            Receiver::Callback(_) => Err(PyTypeError::new_err(
                "this subscription gives its messages to its callback; create one without a \
                 callback to recv() or iterate",
            )),
        }
    }
}

#[pymethods]
impl PySubscription {
    /// The next message, waiting for it up to `timeout` seconds (for ever
    /// if `None`); `None` if none came in time.
    #[pyo3(signature = (timeout = None))]
    fn recv(&self, py: Python<'_>, timeout: Option<f64>) -> PyResult<Option<PyMessage>> {
        let queue = self.queue()?;
        let deadline = match timeout {
            None => None,
            Some(t) => Some(
                Instant::now()
                    + Duration::try_from_secs_f64(t).map_err(|_| {
                        PyValueError::new_err(format!("timeout {t}: give seconds, 0 or more"))
                    })?,
            ),
        };
        loop {
            let wait = match deadline {
                None => SIGNAL_CHECK,
                Some(deadline) => deadline
                    .saturating_duration_since(Instant::now())
                    .min(SIGNAL_CHECK),
            };
            let sample = py.detach(|| queue.recv_timeout(wait)).map_err(|e| {
                if context::ok() {
                    middleware(e)
                } else {
                    context::closed()
                }
            })?;
            if let Some(sample) = sample {
                return Ok(Some(PyMessage::new(Root::decode(
                    &self.ty,
                    Payload::of(sample),
                )?)));
            }
            py.check_signals()?;
            if deadline.is_some_and(|d| Instant::now() >= d) {
                return Ok(None);
            }
        }
    }

    fn __iter__(slf: Bound<'_, Self>) -> Bound<'_, Self> {
        slf
    }

    fn __next__(&self, py: Python<'_>) -> PyResult<Option<PyMessage>> {
        self.recv(py, None)
    }

    /// Messages dropped because the subscription's queue was full.
    #[getter]
    fn lost(&self) -> u64 {
        match &self.receiver {
            Receiver::Queue(q) => q.lost(),
            Receiver::Callback(c) => c.lost(),
        }
    }

    /// Messages publishers sent that never arrived (gaps in their sequence
    /// numbers).
    #[getter]
    fn missed(&self) -> u64 {
        match &self.receiver {
            Receiver::Queue(q) => q.missed(),
            Receiver::Callback(c) => c.missed(),
        }
    }

    /// Samples refused because their type was not the subscription's.
    #[getter]
    fn wrong_type(&self) -> u64 {
        match &self.receiver {
            Receiver::Queue(q) => q.wrong_type(),
            Receiver::Callback(c) => c.wrong_type(),
        }
    }

    /// The subscription's message type.
    #[getter]
    fn msg_type(&self) -> PyMessageType {
        PyMessageType {
            ty: self.ty.clone(),
        }
    }

    /// Wait up to `timeout` seconds for a publisher to match; whether one
    /// did.
    fn wait_for_publishers(&self, py: Python<'_>, timeout: f64) -> PyResult<bool> {
        let timeout = Duration::try_from_secs_f64(timeout)
            .map_err(|_| PyValueError::new_err("timeout: give seconds, 0 or more"))?;
        let queue = self.queue()?;
        Ok(py.detach(|| queue.wait_for_publishers(timeout)))
    }
}

fn kind(outcome: &shm_runtime::PublishOutcome) -> String {
    kind_name(outcome.kind)
}

/// A `PayloadKind` as Python sees it: `HeapFallback` as `heap_fallback`.
pub(crate) fn kind_name(kind: shm_runtime::PayloadKind) -> String {
    snake_case(&format!("{kind:?}"))
}

/// `SharedMemoryUnprobed` as `shared_memory_unprobed`.
fn snake_case(name: &str) -> String {
    let mut out = String::with_capacity(name.len() + 4);
    for (i, c) in name.chars().enumerate() {
        if c.is_ascii_uppercase() {
            if i > 0 {
                out.push('_');
            }
            out.push(c.to_ascii_lowercase());
        } else {
            out.push(c);
        }
    }
    out
}

/// Wait for callbacks until `timeout` seconds pass (for ever if `None`), a
/// callback raises (its exception is raised here), or Ctrl-C.
#[pyfunction]
#[pyo3(signature = (timeout = None))]
pub(crate) fn spin(py: Python<'_>, timeout: Option<f64>) -> PyResult<()> {
    let deadline = timeout
        .map(|t| {
            Duration::try_from_secs_f64(t)
                .map(|t| Instant::now() + t)
                .map_err(|_| PyValueError::new_err(format!("timeout {t}: give seconds, 0 or more")))
        })
        .transpose()?;
    loop {
        let wait = deadline.map_or(SIGNAL_CHECK, |d| {
            d.saturating_duration_since(Instant::now())
                .min(SIGNAL_CHECK)
        });
        if let Some(error) = py.detach(|| CALLBACK_ERRORS.wait(wait)) {
            return Err(error);
        }
        py.check_signals()?;
        if deadline.is_some_and(|d| Instant::now() >= d) || !context::ok() {
            return Ok(());
        }
    }
}
