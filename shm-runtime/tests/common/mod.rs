//! Session helpers shared by the integration tests.

use std::sync::{Arc, Condvar, Mutex};

use zenoh::shm::ShmClientStorage;
use zenoh::Config;

/// A client storage of its own for the sessions of one test, so that the
/// shared-memory segments they mapped are unmapped once they have all closed.
/// With Zenoh's process-wide storage (the default) every segment a session
/// ever mapped stays mapped, and locked in RAM, until the process exits: the
/// pools of a few earlier tests would use up an ordinary user's 8 MiB
/// memory-lock limit. Sessions that exchange shared memory with each other
/// share one, which maps each pool once.
#[allow(dead_code)] // not every test binary uses it
pub fn shm_clients() -> Arc<ShmClientStorage> {
    Arc::new(
        ShmClientStorage::builder()
            .with_default_client_set()
            .build(),
    )
}

/// Open a session with a client storage of its own (see [`shm_clients`]).
#[allow(dead_code)] // not every test binary uses it
pub fn open(config: Config) -> zenoh::session::OpenBuilder<Config> {
    zenoh::open(config).with_shm_clients(shm_clients())
}

/// Open a session with the client storage `clients` (see [`shm_clients`]).
#[allow(dead_code)] // not every test binary uses it
pub fn open_with(
    config: Config,
    clients: &Arc<ShmClientStorage>,
) -> zenoh::session::OpenBuilder<Config> {
    zenoh::open(config).with_shm_clients(clients.clone())
}

/// Held by each test that uses shared memory, for its whole length (take it
/// first, so that it is released last). The tests of a binary run as threads
/// of one process, which has one memory-lock limit (`ulimit -l`); one at a
/// time, each has all of it. (A plain `MutexGuard` held across `.await` is
/// what clippy warns about; this one is meant to be.)
#[allow(dead_code)] // not every test binary uses it
pub struct ShmSerial(());

#[allow(dead_code)] // not every test binary uses it
static SHM_IN_USE: (Mutex<bool>, Condvar) = (Mutex::new(false), Condvar::new());

/// Wait until no other test of this binary uses shared memory.
#[allow(dead_code)] // not every test binary uses it
pub fn shm_serial() -> ShmSerial {
    let (lock, freed) = &SHM_IN_USE;
    let mut in_use = lock.lock().unwrap_or_else(|e| e.into_inner());
    while *in_use {
        in_use = freed.wait(in_use).unwrap_or_else(|e| e.into_inner());
    }
    *in_use = true;
    ShmSerial(())
}

impl Drop for ShmSerial {
    fn drop(&mut self) {
        let (lock, freed) = &SHM_IN_USE;
        *lock.lock().unwrap_or_else(|e| e.into_inner()) = false;
        freed.notify_one();
    }
}

/// [`shm_runtime::testing::free_port`], for tests.
pub fn free_port() -> u16 {
    shm_runtime::testing::free_port().expect("no free TCP port on loopback")
}

/// [`shm_runtime::testing::peer_config`], for tests.
pub fn peer_config(port: u16, listen: bool) -> Config {
    shm_runtime::testing::peer_config(port, listen).expect("a peer configuration")
}

/// `config` with Zenoh's implicit SHM copy of large non-SHM payloads turned
/// off, so that what arrives as shared memory is exactly what we put there.
///
/// The copy also allocates with an *unsafe* garbage collection that reclaims
/// chunks whose watchdog expired even while a reader holds them: on 2 busy cores
/// a reader stalled past 100 ms saw its sample overwritten (CI caught one in the
/// load test). The README recommends turning it off next to shm-runtime.
#[allow(dead_code)] // not every test binary uses it
pub fn without_implicit_shm_copy(mut config: Config) -> Config {
    config
        .insert_json5(
            "transport/shared_memory/transport_optimization/enabled",
            "false",
        )
        .unwrap();
    config
}

/// Two peer sessions on TCP loopback, the first listening on the returned port,
/// both with Zenoh's implicit SHM copy off.
#[allow(dead_code)] // not every test binary uses it
pub fn loopback_sessions() -> (zenoh::Session, zenoh::Session, u16) {
    use zenoh::Wait;
    let port = free_port();
    let clients = shm_clients();
    let open = |listen| {
        open_with(
            without_implicit_shm_copy(peer_config(port, listen)),
            &clients,
        )
        .wait()
        .unwrap()
    };
    (open(true), open(false), port)
}

/// One more peer session connected to the listener of [`loopback_sessions`]
/// on `port`.
#[allow(dead_code)] // not every test binary uses it
pub fn connect_to(port: u16) -> zenoh::Session {
    use zenoh::Wait;
    open_with(
        without_implicit_shm_copy(peer_config(port, false)),
        &shm_clients(),
    )
    .wait()
    .unwrap()
}

/// A node in domain 0 (whatever `ROS_DOMAIN_ID` says).
#[allow(dead_code)] // not every test binary uses it
pub fn node(session: &zenoh::Session, name: &str) -> shm_runtime::RosNode {
    use zenoh::Wait;
    shm_runtime::RosNode::builder(session, name)
        .domain_id(0)
        .wait()
        .unwrap()
}

/// `config` with Zenoh's lowlatency transport on (it needs QoS off), and its
/// implicit SHM copy off: what goes outside shared memory is exactly ours.
#[allow(dead_code)] // not every test binary uses it
pub fn lowlatency(config: Config) -> Config {
    let mut config = without_implicit_shm_copy(config);
    config
        .insert_json5("transport/unicast/qos/enabled", "false")
        .unwrap();
    config
        .insert_json5("transport/unicast/lowlatency", "true")
        .unwrap();
    config
}

/// Whether a plain Zenoh publisher matched a subscriber within `timeout`.
#[allow(dead_code)] // not every test binary uses it
pub fn raw_publisher_matched(
    publisher: &zenoh::pubsub::Publisher<'_>,
    timeout: std::time::Duration,
) -> bool {
    use zenoh::Wait;
    let deadline = std::time::Instant::now() + timeout;
    while !publisher
        .matching_status()
        .wait()
        .is_ok_and(|s| s.matching())
    {
        if std::time::Instant::now() >= deadline {
            return false;
        }
        std::thread::sleep(std::time::Duration::from_millis(5));
    }
    true
}

/// Numbered 64 KiB messages, published and received in order (the
/// shared-memory loss tests).
#[allow(dead_code)] // not every test binary uses it
pub mod blobs {
    use std::time::Duration;

    use shm_cdr::msgs::std_msgs::UInt8MultiArray;
    use shm_runtime::{PayloadKind, RosPublisher, RosSubscriber};
    use zenoh::Wait;

    /// How many each test publishes.
    pub const PUBLISHED: usize = 40;
    const TIMEOUT: Duration = Duration::from_secs(10);

    pub fn message(i: usize) -> UInt8MultiArray {
        UInt8MultiArray {
            data: vec![i as u8; 64 * 1024],
            ..Default::default()
        }
    }

    /// Publish [`PUBLISHED`] messages; the kinds they went as.
    pub fn publish_all(publisher: &RosPublisher<UInt8MultiArray>) -> Vec<PayloadKind> {
        (0..PUBLISHED)
            .map(|i| publisher.publish(&message(i)).wait().unwrap().kind)
            .collect()
    }

    /// Receive until [`PUBLISHED`] messages arrived or [`TIMEOUT`] passed; each
    /// must be the one published in its place.
    pub fn receive_all(subscriber: &RosSubscriber<UInt8MultiArray>) -> usize {
        let mut received = 0;
        while received < PUBLISHED {
            let Ok(Some(sample)) = subscriber.recv_timeout(TIMEOUT) else {
                break;
            };
            let got: UInt8MultiArray = sample.decode().unwrap();
            assert_eq!(got.data[0] as usize, received, "out of order or corrupt");
            received += 1;
        }
        received
    }

    /// Restores the soft memory-lock limit when dropped, whatever the test did.
    pub struct LimitGuard(u64, u64);

    impl LimitGuard {
        /// Lower the soft limit to `soft` (never above where it is).
        pub fn lower_to(soft: u64) -> Self {
            let (old, hard) = rlimit::getrlimit(rlimit::Resource::MEMLOCK).unwrap();
            rlimit::setrlimit(rlimit::Resource::MEMLOCK, soft.min(old), hard).unwrap();
            Self(old, hard)
        }
    }

    impl Drop for LimitGuard {
        fn drop(&mut self) {
            let _ = rlimit::setrlimit(rlimit::Resource::MEMLOCK, self.0, self.1);
        }
    }

    /// Whether the memory-lock limit applies to this process.
    pub fn limited() -> bool {
        let budget = shm_runtime::MemlockBudget::read();
        !budget.exempt && budget.limit.is_some()
    }
}
