//! The package's exceptions. Wrong values raise Python's own (`TypeError`,
//! `ValueError`, `OverflowError`); what fails in the middleware raises these.

use pyo3::create_exception;
use pyo3::exceptions::PyException;
use pyo3::prelude::*;

create_exception!(
    shm_cdr,
    ShmCdrError,
    PyException,
    "A failure of the middleware: a session that cannot open, a name that is not a ROS name, \
     a message that cannot be decoded."
);
create_exception!(
    shm_cdr,
    SessionClosedError,
    ShmCdrError,
    "The Zenoh session was closed (`shm_cdr.shutdown()`) and cannot be used any more."
);

pub(crate) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("ShmCdrError", py.get_type::<ShmCdrError>())?;
    m.add("SessionClosedError", py.get_type::<SessionClosedError>())?;
    Ok(())
}

/// A middleware error as [`ShmCdrError`], with its message.
pub(crate) fn middleware(error: impl std::fmt::Display) -> PyErr {
    ShmCdrError::new_err(error.to_string())
}
