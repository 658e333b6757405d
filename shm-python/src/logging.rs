//! Loggers as rclpy's: `node.get_logger().info("...")` prints to stderr as
//! rcutils' console does and publishes on `/rosout` under the node's logger
//! name, for `rqt_console` and `ros2 topic echo /rosout`; levels as
//! `--ros-args --log-level` and `~/set_logger_levels` set them.

use std::sync::Arc;
use std::time::{SystemTime, UNIX_EPOCH};

use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use shm_cdr::msgs::rcl_interfaces::msg::Log;
use shm_runtime::log_levels::{self, LogLevel};
use shm_runtime::{LogSite, RosoutLayer};

use crate::errors::middleware;

/// A node's logger, or a child of it (`get_child`), as rclpy's
/// `RcutilsLogger`: `debug`, `info`, `warning` (`warn`), `error` and
/// `fatal` print what the logger's effective level admits to stderr, as
/// `[INFO] [1700000000.000000000] [demo.talker]: message`, and publish it on
/// `/rosout` with the caller's file, function and line.
#[pyclass(name = "Logger", module = "shm_cdr", frozen)]
pub(crate) struct PyLogger {
    pub(crate) rosout: Arc<RosoutLayer>,
    pub(crate) name: String,
}

impl PyLogger {
    /// Log `message` at `severity`, from the Python frame that called the
    /// method; whether the level admitted it.
    fn log(&self, py: Python<'_>, severity: u8, message: &str) -> PyResult<bool> {
        if !log_levels::effective_logger_level(&self.name).admits(severity) {
            return Ok(false);
        }
        // Where it was logged; a record that cannot say still goes out.
        let (file, function, line) = caller(py).unwrap_or_default();
        let now = SystemTime::now()
            .duration_since(UNIX_EPOCH)
            .unwrap_or_default();
        eprintln!(
            "[{}] [{}.{:09}] [{}]: {message}",
            severity_name(severity),
            now.as_secs(),
            now.subsec_nanos(),
            self.name
        );
        let site = LogSite {
            file: &file,
            function: &function,
            line,
        };
        Ok(self.rosout.log(&self.name, severity, message, site))
    }
}

/// The file, function and line of the Python code that called: a method of
/// a native class has no frame of its own, so frame 0 is the caller's.
fn caller(py: Python<'_>) -> PyResult<(String, String, u32)> {
    let frame = py.import("sys")?.getattr("_getframe")?.call1((0,))?;
    let code = frame.getattr("f_code")?;
    Ok((
        code.getattr("co_filename")?.extract()?,
        code.getattr("co_name")?.extract()?,
        frame.getattr("f_lineno")?.extract().unwrap_or(0),
    ))
}

/// rcutils' console name of a severity.
fn severity_name(severity: u8) -> &'static str {
    match severity {
        Log::DEBUG => "DEBUG",
        Log::INFO => "INFO",
        Log::WARN => "WARN",
        Log::ERROR => "ERROR",
        _ => "FATAL",
    }
}

#[pymethods]
impl PyLogger {
    /// Log at DEBUG; whether the logger's level admitted it.
    fn debug(&self, py: Python<'_>, message: &str) -> PyResult<bool> {
        self.log(py, Log::DEBUG, message)
    }

    /// Log at INFO.
    fn info(&self, py: Python<'_>, message: &str) -> PyResult<bool> {
        self.log(py, Log::INFO, message)
    }

    /// Log at WARN.
    fn warning(&self, py: Python<'_>, message: &str) -> PyResult<bool> {
        self.log(py, Log::WARN, message)
    }

    /// Log at WARN (rclpy's other name).
    fn warn(&self, py: Python<'_>, message: &str) -> PyResult<bool> {
        self.log(py, Log::WARN, message)
    }

    /// Log at ERROR.
    fn error(&self, py: Python<'_>, message: &str) -> PyResult<bool> {
        self.log(py, Log::ERROR, message)
    }

    /// Log at FATAL.
    fn fatal(&self, py: Python<'_>, message: &str) -> PyResult<bool> {
        self.log(py, Log::FATAL, message)
    }

    /// The logger's name (`demo.talker`).
    fn get_name(&self) -> &str {
        &self.name
    }

    /// The logger `<name>.<child>`, publishing with this one.
    fn get_child(&self, child: &str) -> PyResult<Self> {
        if child.is_empty() {
            return Err(PyValueError::new_err("a child logger needs a name"));
        }
        Ok(Self {
            rosout: self.rosout.clone(),
            name: format!("{}.{child}", self.name),
        })
    }

    /// Set this logger's level (rclpy's `LoggingSeverity`: 0 unset, 10
    /// debug, 20 info, 30 warn, 40 error, 50 fatal).
    fn set_level(&self, level: u32) -> PyResult<()> {
        let level = LogLevel::from_number(level).ok_or_else(|| {
            PyValueError::new_err(format!(
                "level {level}: give 0 (unset), 10 (debug), 20 (info), 30 (warn), 40 (error) or 50 (fatal)"
            ))
        })?;
        log_levels::set_logger_level(&self.name, level).map_err(middleware)
    }

    /// The level that applies: the logger's own, else its nearest
    /// ancestor's, else the default.
    fn get_effective_level(&self) -> u32 {
        u32::from(log_levels::effective_logger_level(&self.name) as u8)
    }

    /// Whether a message of `severity` would be logged.
    fn is_enabled_for(&self, severity: u32) -> bool {
        u8::try_from(severity)
            .is_ok_and(|s| log_levels::effective_logger_level(&self.name).admits(s))
    }

    /// Messages not published on `/rosout` because its queue was full.
    #[getter]
    fn dropped(&self) -> u64 {
        self.rosout.dropped()
    }

    fn __repr__(&self) -> String {
        format!("<shm_cdr.Logger {}>", self.name)
    }
}
