//! What the recording tests share: two sessions as two processes would have
//! them, and waiting for a condition with a bound.

use std::time::{Duration, Instant};

use shm_runtime::testing;
use zenoh::{Session, Wait};

/// How long any one thing may take before a test fails.
pub const TIMEOUT: Duration = Duration::from_secs(30);

/// Two peer sessions on a local port, as two processes would be.
pub fn sessions() -> (Session, Session) {
    let port = testing::free_port().unwrap();
    let open = |listen| {
        zenoh::open(testing::peer_config(port, listen).unwrap())
            .wait()
            .unwrap()
    };
    let a = open(true);
    (a, open(false))
}

/// Wait until `condition` holds; fail naming `what` after [`TIMEOUT`].
pub fn wait_until(what: &str, mut condition: impl FnMut() -> bool) {
    let deadline = Instant::now() + TIMEOUT;
    while !condition() {
        assert!(Instant::now() < deadline, "timed out waiting for {what}");
        std::thread::sleep(Duration::from_millis(10));
    }
}
