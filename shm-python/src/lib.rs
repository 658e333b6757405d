//! `shm_cdr._native`: the Rust half of the Python package `shm_cdr`.
//!
//! Python sees nodes, publishers and subscriptions of any ROS 2 interface
//! (the standard set built in, interface files, a node's type description)
//! on rmw_zenoh_cpp's wire, with messages whose number arrays are numpy
//! arrays viewing the received sample where it lies: in the publisher's
//! shared memory when it came through it. The package's Python half
//! (`python/shm_cdr/__init__.py`) documents the API and adds what is plain
//! Python (`spin`, `QoSProfile`).

mod arrays;
mod context;
mod convert;
mod errors;
mod loan;
mod logging;
mod message;
mod node;
mod parameters;
mod services;
mod timers;
mod types;

use pyo3::prelude::*;

#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    errors::register(m)?;
    m.add_class::<types::PyMessageType>()?;
    m.add_class::<message::PyMessage>()?;
    m.add_class::<arrays::SampleMemory>()?;
    m.add_class::<loan::PyLoan>()?;
    m.add_class::<loan::LoanMemory>()?;
    m.add_class::<node::PyNode>()?;
    m.add_class::<logging::PyLogger>()?;
    m.add_class::<timers::PyTimer>()?;
    m.add_class::<timers::PyClock>()?;
    m.add_class::<timers::PyTime>()?;
    m.add_class::<node::PyPublisher>()?;
    m.add_class::<node::PySubscription>()?;
    m.add_class::<parameters::PyParameter>()?;
    m.add_class::<services::PyServiceType>()?;
    m.add_class::<services::PyClient>()?;
    m.add_class::<services::PyService>()?;
    m.add_class::<parameters::PySetParametersResult>()?;
    m.add_function(wrap_pyfunction!(types::message_type, m)?)?;
    m.add_function(wrap_pyfunction!(services::service_type, m)?)?;
    m.add_function(wrap_pyfunction!(context::shutdown, m)?)?;
    m.add_function(wrap_pyfunction!(context::ok, m)?)?;
    m.add_function(wrap_pyfunction!(node::spin, m)?)?;
    Ok(())
}
