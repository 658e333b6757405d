//! Waiting for a match (a subscriber for a publisher, a server for a client) on
//! Zenoh's matching listener: it wakes when the match happens.

use std::time::{Duration, Instant};

use zenoh::handlers::DefaultHandler;
use zenoh::matching::{MatchingListener, MatchingListenerBuilder, MatchingStatus};
use zenoh::Wait;

/// Statuses that may wait to be read: a wait reads them as they come, and
/// looks at the match itself when it ends.
const STATUS_QUEUE: usize = 16;

/// A matching listener whose statuses arrive in a channel of its own. A
/// status Zenoh delivers while the listener is being dropped is dropped
/// without a word: Zenoh's own channel would log an ERROR for it.
pub(crate) struct Listener {
    statuses: flume::Receiver<MatchingStatus>,
    _listener: MatchingListener<()>,
}

/// Declare the listener `builder` (a publisher's or a querier's) makes.
pub(crate) fn listen(
    builder: MatchingListenerBuilder<'_, DefaultHandler>,
) -> zenoh::Result<Listener> {
    let (sender, statuses) = flume::bounded(STATUS_QUEUE);
    let listener = builder
        .callback(move |status| {
            let _ = sender.try_send(status);
        })
        .wait()?;
    Ok(Listener {
        statuses,
        _listener: listener,
    })
}

/// Wait until `matched()` or `timeout` passes; returns whether it matched.
/// `listener` is declared before the first look, so a match between the two is
/// not missed.
pub(crate) fn wait(
    listener: zenoh::Result<Listener>,
    matched: impl Fn() -> bool,
    timeout: Duration,
) -> bool {
    let deadline = Instant::now() + timeout;
    let Ok(listener) = listener else {
        return false;
    };
    if matched() {
        return true;
    }
    loop {
        let left = deadline.saturating_duration_since(Instant::now());
        match listener.statuses.recv_timeout(left) {
            Ok(status) if status.matching() => return true,
            Ok(_) => {}
            Err(_) => return matched(),
        }
    }
}

/// Resolves once `matched()` (at once if it is now); cancellation-safe.
pub(crate) async fn matched(
    listener: zenoh::Result<Listener>,
    matched: impl Fn() -> bool,
) -> zenoh::Result<()> {
    let listener = listener?;
    if matched() {
        return Ok(());
    }
    loop {
        if listener.statuses.recv_async().await?.matching() {
            return Ok(());
        }
    }
}
