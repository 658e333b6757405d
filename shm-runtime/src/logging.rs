//! Where the runtime's warnings go: `tracing`, shown by a subscriber the
//! application installs.

use std::io::IsTerminal;

use tracing::field::{Field, Visit};
use tracing::{Event, Metadata};
use tracing_subscriber::filter::FilterExt;
use tracing_subscriber::layer::{Context, Filter};
use tracing_subscriber::prelude::*;
use tracing_subscriber::EnvFilter;

use crate::receive_failure_layer;

/// What is shown when `RUST_LOG` is not set: warnings, without Zenoh's notice
/// that an unprivileged process cannot raise its watchdog threads' priority
/// (harmless, and printed by every process that is not root), and without
/// the lines of [`QUIET_BY_DEFAULT`].
pub const DEFAULT_LOG_FILTER: &str = "warn,zenoh_shm::watchdog::periodic_task=error";

/// Zenoh's warnings that a working setup prints every time, and which tell
/// its user nothing, as (target, message): left out when `RUST_LOG` is not
/// set, shown by any `RUST_LOG` that shows warnings of their target.
///
/// - A peer session that connects to a router waits, while it opens, for
///   the peers the router tells it of; past `scouting/delay` (500 ms) Zenoh
///   says "Scouting delay elapsed before start conditions are met" and goes
///   on, connecting to them as they come. With no router there, the
///   program's own message says so ([`rmw::config::wait_for_router`](crate::rmw::config::wait_for_router)).
/// - A router that refuses the program's Zenoh session (its user and password, its
///   transport) closes the link as it opens; Zenoh logs an ERROR with the
///   link's internals at every retry. The router check says what happened
///   in the program's own words ([`rmw::config::why_unreached`](crate::rmw::config::why_unreached)).
///
/// A message matches when it starts with the listed text.
pub const QUIET_BY_DEFAULT: &[(&str, &str)] = &[
    (
        "zenoh::net::runtime::orchestrator",
        "Scouting delay elapsed before start conditions are met.",
    ),
    (
        "zenoh_transport::unicast::establishment::open",
        "Received a close message",
    ),
];

/// Show the runtime's and Zenoh's log on stderr, filtered by `RUST_LOG`
/// (`RUST_LOG=info` shows more: the pool chosen and why), or by
/// [`DEFAULT_LOG_FILTER`] when it is not set. Colours only on a terminal,
/// and not with `NO_COLOR` set. Without a subscriber such as
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
    let ansi = std::io::stderr().is_terminal() && std::env::var_os("NO_COLOR").is_none();
    let layer = tracing_subscriber::fmt::layer()
        .with_writer(std::io::stderr)
        .with_ansi(ansi);
    // An error means a subscriber is installed already: the application's wins.
    let _ = match EnvFilter::try_from_default_env() {
        Ok(filter) => tracing_subscriber::registry()
            .with(layer.with_filter(filter).boxed())
            .with(receive_failure_layer())
            .try_init(),
        Err(_) => tracing_subscriber::registry()
            .with(
                layer
                    .with_filter(EnvFilter::new(DEFAULT_LOG_FILTER).and(QuietByDefault))
                    .boxed(),
            )
            .with(receive_failure_layer())
            .try_init(),
    };
}

/// Leaves out the events of [`QUIET_BY_DEFAULT`].
struct QuietByDefault;

impl<S> Filter<S> for QuietByDefault {
    fn enabled(&self, _: &Metadata<'_>, _: &Context<'_, S>) -> bool {
        true
    }

    fn event_enabled(&self, event: &Event<'_>, _: &Context<'_, S>) -> bool {
        let target = event.metadata().target();
        if !QUIET_BY_DEFAULT.iter().any(|(t, _)| *t == target) {
            return true;
        }
        let mut message = Message(String::new());
        event.record(&mut message);
        !QUIET_BY_DEFAULT
            .iter()
            .any(|(t, m)| *t == target && message.0.starts_with(m))
    }
}

/// An event's message, as text.
struct Message(String);

impl Visit for Message {
    fn record_str(&mut self, field: &Field, value: &str) {
        if field.name() == "message" {
            self.0 = value.to_owned();
        }
    }

    fn record_debug(&mut self, field: &Field, value: &dyn std::fmt::Debug) {
        if field.name() == "message" {
            self.0 = format!("{value:?}");
        }
    }
}
