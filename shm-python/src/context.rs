//! The process's Zenoh session and shared-memory pool, as rclpy's context:
//! opened on first use as rmw_zenoh_cpp opens a ROS 2 process's session
//! (`ZENOH_SESSION_CONFIG_URI`, `ZENOH_CONFIG_OVERRIDE`, the router check of
//! `ZENOH_ROUTER_CHECK_ATTEMPTS`), with the pool configured as in Rust
//! (`ZENOH_SHM_ALLOC_SIZE`, `ZENOH_SHM_MESSAGE_SIZE_THRESHOLD`, within the
//! memory-lock limit), and closed by `shutdown()`.

use std::sync::{Arc, Mutex, MutexGuard};

use pyo3::prelude::*;
use shm_runtime::rmw::config;
use shm_runtime::{ShmConfig, ShmContext};
use zenoh::{Session, Wait};

use crate::errors::{middleware, SessionClosedError};

/// What every node of the process shares.
pub(crate) struct Context {
    pub(crate) session: Session,
    pub(crate) shm: ShmContext,
}

enum State {
    Unopened,
    Open(Arc<Context>),
    Closed,
}

static STATE: Mutex<State> = Mutex::new(State::Unopened);

fn state() -> MutexGuard<'static, State> {
    // A panic while the lock was held left nothing half-changed: each change
    // is one assignment.
    STATE
        .lock()
        .unwrap_or_else(|poisoned| poisoned.into_inner())
}

/// The process's context, opened now if it is not yet.
pub(crate) fn get(py: Python<'_>) -> PyResult<Arc<Context>> {
    match &*state() {
        State::Open(context) => return Ok(context.clone()),
        State::Closed => return Err(closed()),
        State::Unopened => {}
    }
    // Opening waits for the router (a second by default): without the GIL,
    // so other Python threads run meanwhile.
    let (opened, unreached) = py.detach(open).map_err(middleware)?;
    if let Some(why) = unreached {
        // rmw_zenoh_cpp warns and goes on when no router answers: so does this.
        let category = py.get_type::<pyo3::exceptions::PyRuntimeWarning>();
        PyErr::warn(
            py,
            &category,
            &std::ffi::CString::new(why).unwrap_or_default(),
            1,
        )?;
    }
    let mut state = state();
    match &*state {
        // Another thread opened one meanwhile: use it, drop ours.
        State::Open(context) => Ok(context.clone()),
        State::Closed => Err(closed()),
        State::Unopened => {
            let context = Arc::new(opened);
            *state = State::Open(context.clone());
            Ok(context)
        }
    }
}

pub(crate) fn closed() -> PyErr {
    SessionClosedError::new_err(
        "the Zenoh session of this process was closed by shm_cdr.shutdown(); \
         nodes cannot be created or used after it",
    )
}

/// The opened context, and why no router answered if none did.
fn open() -> Result<(Context, Option<String>), String> {
    let session_config = config::session_config().map_err(|e| e.to_string())?;
    let session = zenoh::open(session_config).wait().map_err(|e| {
        format!(
            "cannot open a Zenoh session: {}. Check ZENOH_SESSION_CONFIG_URI and \
             ZENOH_CONFIG_OVERRIDE",
            config::zenoh_reason(&e)
        )
    })?;
    let check = config::RouterCheck::from_env().map_err(|e| e.to_string())?;
    let found = config::wait_for_router(&session, check, |_| {});
    config::router_looked_for(&session);
    let unreached = (!found).then(|| config::why_unreached(&session));
    let shm_config = ShmConfig::enabled().with_env().map_err(|e| e.to_string())?;
    let shm = ShmContext::new(shm_config).map_err(|e| e.to_string())?;
    Ok((Context { session, shm }, unreached))
}

/// Close the process's Zenoh session: every node, publisher and
/// subscription stops, and using them raises `SessionClosedError`. Messages
/// already received stay readable, their arrays too.
#[pyfunction]
pub(crate) fn shutdown(py: Python<'_>) -> PyResult<()> {
    let previous = std::mem::replace(&mut *state(), State::Closed);
    if let State::Open(context) = previous {
        py.detach(|| context.session.close().wait())
            .map_err(middleware)?;
    }
    Ok(())
}

/// Whether the process's session is usable: not yet opened, or open.
#[pyfunction]
pub(crate) fn ok() -> bool {
    !matches!(&*state(), State::Closed)
}
