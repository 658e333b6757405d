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
/// - A session that closes while a peer's link to it closes too (two nodes'
///   sessions in one process, or a peer that exits at the same moment) may
///   still be handed that link's event after it stopped taking publications;
///   Zenoh (1.8 and later) then logs an ERROR "Unable to publish transport
///   event: session closed" (eclipse-zenoh/zenoh#2492). Nothing was lost:
///   the event was for Zenoh's own admin space, of a session that is gone.
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
    (
        "zenoh::api::admin",
        "Unable to publish transport event: session closed",
    ),
    (
        "zenoh::api::admin",
        "Unable to publish link event: session closed",
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
            .with(layer.with_filter(default_filter()).boxed())
            .with(receive_failure_layer())
            .try_init(),
    };
}

/// [`DEFAULT_LOG_FILTER`] without the events of [`QUIET_BY_DEFAULT`].
fn default_filter<S>() -> impl Filter<S>
where
    S: tracing::Subscriber + for<'a> tracing_subscriber::registry::LookupSpan<'a>,
{
    EnvFilter::new(DEFAULT_LOG_FILTER).and(QuietByDefault)
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

#[cfg(test)]
mod tests {
    use std::io::Write;
    use std::sync::{Arc, Mutex};

    use super::*;

    /// What a fmt layer wrote.
    #[derive(Clone, Default)]
    struct Captured(Arc<Mutex<Vec<u8>>>);

    impl Write for Captured {
        fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
            if let Ok(mut out) = self.0.lock() {
                out.extend_from_slice(buf);
            }
            Ok(buf.len())
        }

        fn flush(&mut self) -> std::io::Result<()> {
            Ok(())
        }
    }

    #[test]
    fn the_default_filter_leaves_out_the_quiet_lines_and_keeps_their_neighbours() {
        let captured = Captured::default();
        let writer = captured.clone();
        let layer = tracing_subscriber::fmt::layer()
            .with_ansi(false)
            .with_writer(move || writer.clone())
            .with_filter(default_filter());
        let subscriber = tracing_subscriber::registry().with(layer);
        tracing::subscriber::with_default(subscriber, || {
            for (target, message) in QUIET_BY_DEFAULT {
                match *target {
                    "zenoh::net::runtime::orchestrator" => {
                        tracing::warn!(target: "zenoh::net::runtime::orchestrator", "{message} (details)")
                    }
                    "zenoh_transport::unicast::establishment::open" => {
                        tracing::error!(target: "zenoh_transport::unicast::establishment::open", "{message} (details)")
                    }
                    "zenoh::api::admin" => {
                        tracing::error!(target: "zenoh::api::admin", "{message}")
                    }
                    other => panic!("a quiet line of {other} this test does not emit"),
                }
            }
            tracing::error!(target: "zenoh::api::admin", "Unable to subscribe to transport events: boom");
            tracing::info!(target: "zenoh::api::admin", "below the default level");
        });
        let out = String::from_utf8(captured.0.lock().map(|o| o.clone()).unwrap_or_default())
            .unwrap_or_default();
        assert_eq!(
            out.lines().count(),
            1,
            "only the neighbouring error is shown: {out}"
        );
        assert!(
            out.contains("Unable to subscribe to transport events: boom"),
            "{out}"
        );
    }
}
