//! Where the runtime's warnings go: `tracing`, shown by a subscriber the
//! application installs.

use tracing_subscriber::prelude::*;
use tracing_subscriber::EnvFilter;

use crate::receive_failure_layer;

/// What is shown when `RUST_LOG` is not set: warnings, without Zenoh's notice
/// that an unprivileged process cannot raise its watchdog threads' priority
/// (harmless, and printed by every process that is not root).
pub const DEFAULT_LOG_FILTER: &str = "warn,zenoh_shm::watchdog::periodic_task=error";

/// Show the runtime's and Zenoh's log on stderr, filtered by `RUST_LOG`
/// (`RUST_LOG=info` shows more: the pool chosen and why), or by
/// [`DEFAULT_LOG_FILTER`] when it is not set. Without a subscriber such as
/// this one, `tracing` drops every event: a heap fallback, a missed message or
/// a pool sized down to the memory-lock limit would go unseen. It also counts
/// and reports the messages Zenoh drops when this process cannot map their
/// shared memory ([`receive_failure_layer`]). Does nothing if the application
/// installed a subscriber already (add [`receive_failure_layer`] to yours).
///
/// ```
/// shm_runtime::init_logging();
/// ```
pub fn init_logging() {
    let filter =
        EnvFilter::try_from_default_env().unwrap_or_else(|_| EnvFilter::new(DEFAULT_LOG_FILTER));
    // An error means a subscriber is installed already: the application's wins.
    let _ = tracing_subscriber::registry()
        .with(
            tracing_subscriber::fmt::layer()
                .with_writer(std::io::stderr)
                .with_filter(filter),
        )
        .with(receive_failure_layer())
        .try_init();
}
