//! Which of a session's transports carry shared memory, followed through
//! Zenoh's transport and link events.
//!
//! Two Zenoh sessions share memory over a transport only when both have it
//! on, can open each other's segments (same host, same user) and speak the
//! same shared-memory protocol; they settle it once, when the transport
//! opens, and Zenoh copies every shared-memory buffer into a transport that
//! did not. Zenoh 1.10 changed that protocol (its version 2, with new
//! handshake fields), so a session on 1.10 never shares memory with one on
//! 1.8 (every rmw_zenoh_cpp release's) or 1.9 ([`ZenohLine`](crate::ZenohLine)).
//! For a subscriber that does not answer the pool's probe (rmw_zenoh_cpp's),
//! the transport to its session is what tells how it gets our messages.

use std::collections::HashMap;
use std::sync::{Arc, Mutex, MutexGuard, Weak};

use zenoh::config::WhatAmI;
use zenoh::sample::SampleKind;
use zenoh::session::ZenohId;
use zenoh::{Session, Wait};

use crate::transport::changes::Changes;

/// What one transport negotiated.
#[derive(Debug, Clone, Default)]
struct TransportState {
    whatami: Option<WhatAmI>,
    shm: bool,
    /// The remote ends of its links, as `proto/address`.
    remotes: Vec<String>,
}

/// How messages travel to a session.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum LinkReach {
    /// The transport to it (or to the router in between) carries shared memory.
    SharedMemory,
    /// It carries none: Zenoh copies each shared-memory message into it.
    Bytes,
    /// No transport is open yet.
    Unknown,
}

/// The transports, and a count of their changes.
#[derive(Default)]
struct Table {
    transports: Mutex<HashMap<ZenohId, TransportState>>,
    changes: Changes,
}

/// The transports of one session.
pub(crate) struct Links {
    session: ZenohId,
    transports: Arc<Table>,
    /// None in Zenoh's low-latency mode: listing its transports panics
    /// outside Zenoh's own threads (zenoh-transport 1.9,
    /// `TransportUnicastLowlatency::get_links`), so they are not followed and
    /// every session's link stays unknown.
    _events: Option<(
        zenoh::session::TransportEventsListener<()>,
        zenoh::session::LinkEventsListener<()>,
    )>,
}

type Registry = HashMap<ZenohId, Weak<Links>>;
static LINKS: Mutex<Option<Registry>> = Mutex::new(None);

fn lock<T>(mutex: &Mutex<T>) -> MutexGuard<'_, T> {
    // Each entry is written whole.
    mutex.lock().unwrap_or_else(|e| e.into_inner())
}

impl Links {
    /// The table of `session`: the one its publishers share, or a new one.
    pub(crate) fn of(session: &Session) -> zenoh::Result<Arc<Self>> {
        let mut registry = lock(&LINKS);
        let registry = registry.get_or_insert_with(HashMap::new);
        if let Some(links) = registry.get(&session.zid()).and_then(Weak::upgrade) {
            return Ok(links);
        }
        registry.retain(|_, l| l.strong_count() > 0);
        let transports = Arc::new(Table::default());
        let lowlatency = session
            .config()
            .get_typed::<bool>("transport/unicast/lowlatency")
            .unwrap_or(false);
        if lowlatency {
            let links = Arc::new(Self {
                session: session.zid(),
                transports,
                _events: None,
            });
            registry.insert(session.zid(), Arc::downgrade(&links));
            return Ok(links);
        }
        let on_transport = Arc::downgrade(&transports);
        let on_link = Arc::downgrade(&transports);
        // Callbacks with history: every open transport and link is replayed
        // before `wait` returns.
        let transport_events = session
            .info()
            .transport_events_listener()
            .history(true)
            .callback(move |event| {
                let Some(table) = on_transport.upgrade() else {
                    return;
                };
                let transport = event.transport();
                {
                    let mut transports = lock(&table.transports);
                    match event.kind() {
                        SampleKind::Put => {
                            let state = transports.entry(*transport.zid()).or_default();
                            state.whatami = Some(transport.whatami());
                            state.shm = transport.is_shm();
                        }
                        SampleKind::Delete => {
                            transports.remove(transport.zid());
                        }
                    }
                }
                table.changes.note();
            })
            .wait()?;
        let link_events = session
            .info()
            .link_events_listener()
            .history(true)
            .callback(move |event| {
                let Some(table) = on_link.upgrade() else {
                    return;
                };
                let link = event.link();
                let remote = link.dst().to_string();
                {
                    let mut transports = lock(&table.transports);
                    match event.kind() {
                        SampleKind::Put => {
                            let state = transports.entry(*link.zid()).or_default();
                            if !state.remotes.contains(&remote) {
                                state.remotes.push(remote);
                            }
                        }
                        SampleKind::Delete => {
                            if let Some(state) = transports.get_mut(link.zid()) {
                                state.remotes.retain(|r| *r != remote);
                            }
                        }
                    }
                }
                table.changes.note();
            })
            .wait()?;
        let links = Arc::new(Self {
            session: session.zid(),
            transports,
            _events: Some((transport_events, link_events)),
        });
        registry.insert(session.zid(), Arc::downgrade(&links));
        Ok(links)
    }

    /// How messages travel from the table's own Zenoh session to `session`:
    /// over the transport to it, or else over those to the routers in between
    /// (all of them must carry shared memory, as any may route).
    pub(crate) fn reach(&self, session: ZenohId) -> LinkReach {
        if session == self.session {
            // Delivered within the process: the buffer itself.
            return LinkReach::SharedMemory;
        }
        if self._events.is_none() {
            return LinkReach::Unknown;
        }
        let table = lock(&self.transports.transports);
        let shm = |state: &TransportState| match state.shm {
            true => LinkReach::SharedMemory,
            false => LinkReach::Bytes,
        };
        if let Some(state) = table.get(&session).filter(|s| s.whatami.is_some()) {
            return shm(state);
        }
        let mut routers = table
            .values()
            .filter(|s| s.whatami == Some(WhatAmI::Router))
            .peekable();
        if routers.peek().is_none() {
            return LinkReach::Unknown;
        }
        match routers.all(|s| s.shm) {
            true => LinkReach::SharedMemory,
            false => LinkReach::Bytes,
        }
    }

    /// How many times the transports or their links changed: what
    /// [`reach`](Self::reach), [`is_linked`](Self::is_linked) and
    /// [`is_local`](Self::is_local) answer holds while it stays the same.
    pub(crate) fn changes(&self) -> u64 {
        self.transports.changes.seen()
    }

    /// Whether `session` is this table's own, or one a transport of ours was
    /// opened with: its id came from the transport's handshake (and its
    /// authentication, where configured), not from anything it declared.
    pub(crate) fn is_linked(&self, session: ZenohId) -> bool {
        session == self.session
            || lock(&self.transports.transports)
                .get(&session)
                .is_some_and(|state| state.whatami.is_some())
    }

    /// Whether the transport to `session` runs over this host's loopback or
    /// a Unix socket: then only a differing Zenoh, shared memory off over
    /// there, or another user keeps it from carrying shared memory.
    pub(crate) fn is_local(&self, session: ZenohId) -> bool {
        lock(&self.transports.transports)
            .get(&session)
            .is_some_and(|state| state.remotes.iter().any(|remote| is_loopback(remote)))
    }
}

/// Whether a locator (`tcp/127.0.0.1:7447`, `unixsock-stream//tmp/s`, …)
/// names this host.
fn is_loopback(locator: &str) -> bool {
    let Some((proto, address)) = locator.split_once('/') else {
        return false;
    };
    if proto.starts_with("unix") {
        return true;
    }
    let host = address.split('#').next().unwrap_or(address);
    let host = host.rsplit_once(':').map_or(host, |(host, _)| host);
    let host = host.trim_start_matches('[').trim_end_matches(']');
    host == "localhost"
        || host
            .parse::<std::net::IpAddr>()
            .is_ok_and(|ip| ip.is_loopback())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn loopback_locators_are_told_apart() {
        assert!(is_loopback("tcp/127.0.0.1:7447"));
        assert!(is_loopback("tcp/[::1]:7447"));
        assert!(is_loopback("tcp/localhost:7447"));
        assert!(is_loopback("unixsock-stream//tmp/zenoh.sock"));
        assert!(!is_loopback("tcp/192.168.1.20:7447"));
        assert!(!is_loopback("tcp/[fe80::1]:7447"));
        assert!(!is_loopback("nonsense"));
    }
}
