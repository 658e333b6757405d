//! Timers and clocks as rclpy's: `node.create_timer(period_sec, callback)`,
//! `node.get_clock().now().to_msg()`.

use std::sync::Mutex;
use std::time::Duration;

use pyo3::prelude::*;
use shm_cdr::dynamic::Value;
use shm_runtime::time::{Clock, RosTime, Timer};
use shm_runtime::RosNode;

use crate::errors::middleware;
use crate::message::{PyMessage, Root};
use crate::node::CALLBACK_ERRORS;

/// A timer calling its callback every period, on a thread of its own (the
/// node's ROS time: simulated time while the node uses it). Its node keeps
/// it until `destroy_timer`; `cancel()` stops it.
#[pyclass(name = "Timer", module = "shm_cdr", frozen)]
pub(crate) struct PyTimer {
    timer: Mutex<Option<Timer>>,
    period: Duration,
}

impl PyTimer {
    /// Call `callback()` every `period` of `node`'s ROS time; an exception
    /// it raises goes to `spin`, and the timer goes on.
    pub(crate) fn start(node: &RosNode, period: Duration, callback: Py<PyAny>) -> PyResult<Self> {
        let timer = node
            .create_timer(period, move || {
                // Not while the interpreter shuts down.
                Python::try_attach(|py| {
                    if let Err(error) = callback.call0(py) {
                        CALLBACK_ERRORS.push(py, error);
                    }
                });
            })
            .map_err(middleware)?;
        Ok(Self {
            timer: Mutex::new(Some(timer)),
            period,
        })
    }

    fn with<R>(&self, f: impl FnOnce(Option<&Timer>) -> R) -> R {
        let timer = self.timer.lock().unwrap_or_else(|p| p.into_inner());
        f(timer.as_ref())
    }

    /// Stop the timer and wait for its thread, without the GIL (its
    /// callback may be waiting for it).
    pub(crate) fn stop(&self, py: Python<'_>) {
        let timer = self.timer.lock().unwrap_or_else(|p| p.into_inner()).take();
        if let Some(timer) = timer {
            timer.cancel();
            py.detach(|| drop(timer));
        }
    }
}

impl Drop for PyTimer {
    fn drop(&mut self) {
        let timer = self
            .timer
            .get_mut()
            .unwrap_or_else(|p| p.into_inner())
            .take();
        if let Some(timer) = timer {
            timer.cancel();
            // Freed by Python, which holds the GIL: let the timer's thread
            // finish a callback that waits for it. (Without an interpreter
            // the closure, and the timer with it, is dropped at once.)
            let _ = Python::try_attach(|py| py.detach(|| drop(timer)));
        }
    }
}

#[pymethods]
impl PyTimer {
    /// Stop: the callback is not called again (one running now finishes).
    fn cancel(&self) {
        self.with(|t| t.map(Timer::cancel));
    }

    /// Whether the timer was canceled.
    fn is_canceled(&self) -> bool {
        self.with(|t| t.is_none_or(Timer::is_canceled))
    }

    /// The period in nanoseconds, as rclpy's `timer_period_ns`.
    #[getter]
    fn timer_period_ns(&self) -> u128 {
        self.period.as_nanos()
    }

    /// How many times the callback was called.
    #[getter]
    fn fired(&self) -> u64 {
        self.with(|t| t.map_or(0, Timer::fired))
    }

    fn __repr__(&self) -> String {
        format!("<shm_cdr.Timer every {:?}>", self.period)
    }
}

/// A node's clock, as rclpy's `node.get_clock()`: ROS time, simulated while
/// the node uses it (`use_sim_time`).
#[pyclass(name = "Clock", module = "shm_cdr", frozen)]
pub(crate) struct PyClock {
    pub(crate) clock: Clock,
}

#[pymethods]
impl PyClock {
    /// The time now.
    fn now(&self) -> PyTime {
        PyTime {
            time: self.clock.now(),
        }
    }
}

/// A point in time, as rclpy's `Time`: `nanoseconds`, and `to_msg()` for a
/// `builtin_interfaces/msg/Time` stamp.
#[pyclass(name = "Time", module = "shm_cdr", frozen, eq, ord)]
#[derive(PartialEq, PartialOrd)]
pub(crate) struct PyTime {
    time: RosTime,
}

#[pymethods]
impl PyTime {
    /// Nanoseconds since the clock's origin (the Unix epoch for system
    /// time).
    #[getter]
    fn nanoseconds(&self) -> i64 {
        self.time.nanos()
    }

    /// Whole seconds and the nanoseconds past them.
    fn seconds_nanoseconds(&self) -> (i64, i64) {
        let nanos = self.time.nanos();
        (
            nanos.div_euclid(1_000_000_000),
            nanos.rem_euclid(1_000_000_000),
        )
    }

    /// As a `builtin_interfaces/msg/Time` message (a stamp).
    fn to_msg(&self) -> PyResult<PyMessage> {
        let ty = crate::types::by_name("builtin_interfaces/msg/Time", &[])?;
        let stamp = self.time.to_msg();
        let mut message = ty.default_message();
        message
            .set("sec", Value::I32(stamp.sec))
            .and_then(|()| message.set("nanosec", Value::U32(stamp.nanosec)))
            .map_err(middleware)?;
        Ok(PyMessage::new(Root::owned(message)))
    }

    fn __repr__(&self) -> String {
        format!("shm_cdr.Time(nanoseconds={})", self.time.nanos())
    }
}
