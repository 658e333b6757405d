//! What the recording tests share: two sessions as two processes would have
//! them, and waiting for a condition with a bound.

use std::time::{Duration, Instant};

use shm_bag::{RecordOptions, Selection};
use shm_runtime::testing;
use zenoh::{Session, Wait};

/// How long any one thing may take before a test fails.
pub const TIMEOUT: Duration = Duration::from_secs(30);

/// Two peer sessions on a local port, as two processes would be.
pub fn sessions() -> (Session, Session) {
    let port = testing::free_port().unwrap();
    let a = peer(port, true);
    (a, peer(port, false))
}

/// A peer session listening on `port`, or connecting to it.
pub fn peer(port: u16, listen: bool) -> Session {
    zenoh::open(testing::peer_config(port, listen).unwrap())
        .wait()
        .unwrap()
}

/// Wait until `condition` holds; fail naming `what` after [`TIMEOUT`].
pub fn wait_until(what: &str, mut condition: impl FnMut() -> bool) {
    let deadline = Instant::now() + TIMEOUT;
    while !condition() {
        assert!(Instant::now() < deadline, "timed out waiting for {what}");
        std::thread::sleep(Duration::from_millis(10));
    }
}

/// A fresh directory for a recording named `name`, and options recording
/// `topics` into it on domain 0.
pub fn recording(name: &str, topics: Vec<String>) -> (std::path::PathBuf, RecordOptions) {
    let dir = std::env::temp_dir().join(format!("{name}_{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let selection = Selection {
        topics,
        ..Selection::default()
    };
    let mut options = RecordOptions::new(dir.join("bag"), selection);
    options.domain_id = Some(0);
    (dir, options)
}
