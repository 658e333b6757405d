//! Waiting for a match (a subscriber for a publisher, a server for a client) on
//! Zenoh's matching listener: it wakes when the match happens.

use std::time::{Duration, Instant};

use zenoh::handlers::FifoChannelHandler;
use zenoh::matching::{MatchingListener, MatchingStatus};

/// A matching listener as Zenoh's publishers and queriers hand it out.
pub(crate) type Listener = MatchingListener<FifoChannelHandler<MatchingStatus>>;

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
        match listener.recv_timeout(left) {
            Ok(Some(status)) if status.matching() => return true,
            Ok(Some(_)) => {}
            Ok(None) | Err(_) => return matched(),
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
        if listener.recv_async().await?.matching() {
            return Ok(());
        }
    }
}
