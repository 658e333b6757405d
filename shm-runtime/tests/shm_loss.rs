//! A subscriber whose process cannot map a publisher's shared memory (here:
//! its memory-lock limit is used up, as with a second camera in a container)
//! would get nothing for those messages from Zenoh, not even an error. The
//! publisher checks every subscribing session before its pool's messages go
//! to it (see `Reach`): a session that cannot map the pool gets every message
//! from the heap, and its process's log names the cause.
//!
//! The limit is lowered inside this process, so these tests take turns. As
//! root (`CAP_IPC_LOCK`) nothing fails and every message goes through shared
//! memory; `.ci/unprivileged` runs them as an ordinary user, where the
//! limit bites.

mod common;

use std::time::Duration;

use common::{loopback_sessions, shm_serial};
use shm_cdr::msgs::std_msgs::UInt8MultiArray;
use shm_runtime::{
    shm_receive_failures, MemlockBudget, PayloadKind, Reach, ReceiveFailureCause, RosPublisher,
    RosSubscriber, SessionExt, ShmConfig, ShmContext, ZENOH_METADATA_SEGMENT,
};
use zenoh::Wait;

const PUBLISHED: usize = 40;
const TIMEOUT: Duration = Duration::from_secs(10);

/// Restores the soft memory-lock limit when dropped, whatever the test did.
struct LimitGuard(u64, u64);

impl LimitGuard {
    /// Lower the soft limit to `soft` (never above where it is).
    fn lower_to(soft: u64) -> Self {
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

fn message(i: usize) -> UInt8MultiArray {
    UInt8MultiArray {
        data: vec![i as u8; 64 * 1024],
        ..Default::default()
    }
}

/// Publish [`PUBLISHED`] messages; the kinds they went as.
fn publish_all(publisher: &RosPublisher<UInt8MultiArray>) -> Vec<PayloadKind> {
    (0..PUBLISHED)
        .map(|i| publisher.publish(&message(i)).wait().unwrap().kind)
        .collect()
}

/// Receive until [`PUBLISHED`] messages arrived or [`TIMEOUT`] passed; each
/// must be the one published in its place.
fn receive_all(subscriber: &RosSubscriber<UInt8MultiArray>) -> usize {
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

/// Whether the memory-lock limit applies to this process.
fn limited() -> bool {
    let budget = MemlockBudget::read();
    !budget.exempt && budget.limit.is_some()
}

#[test]
fn a_session_that_cannot_map_the_pool_gets_every_message_from_the_heap() {
    let _shm = shm_serial();
    shm_runtime::init_logging();
    let (a, b, _) = loopback_sessions();
    let shm = ShmContext::new(ShmConfig::enabled().threshold(1024)).unwrap();
    let Some(pool_size) = shm.pool_size() else {
        eprintln!(
            "no pool under this limit ({}): nothing to map",
            shm.memlock()
        );
        return;
    };
    let publisher = a
        .declare_ros_publisher::<UInt8MultiArray>("loss/blobs")
        .shm(&shm)
        .wait()
        .unwrap();
    // From here on nothing more can be locked, so the subscriber's session
    // cannot map the pool.
    let before = shm_receive_failures();
    let limit = LimitGuard::lower_to(MemlockBudget::read().locked);
    let subscriber = b
        .declare_ros_subscriber::<UInt8MultiArray>("loss/blobs")
        .wait()
        .unwrap();
    assert!(publisher.wait_for_subscribers(TIMEOUT));

    let receivers = publisher.receivers();
    assert_eq!(receivers.len(), 1, "{receivers:?}");
    assert_eq!(receivers[0].session, b.zid());
    let (reach, kind) = match limited() {
        true => (Reach::CannotMap, PayloadKind::ReceiverCannotMap),
        false => (Reach::SharedMemory, PayloadKind::Shm),
    };
    assert_eq!(receivers[0].reach, reach);
    let kinds = publish_all(&publisher);
    assert!(kinds.iter().all(|k| *k == kind), "{kinds:?}");
    let received = receive_all(&subscriber);
    drop(limit);

    println!(
        "pool of {pool_size} bytes, receiver {reach:?}: {received} of {PUBLISHED} received, {} missed",
        subscriber.missed()
    );
    assert_eq!(received, PUBLISHED, "a message was lost");
    assert_eq!(subscriber.missed(), 0);
    assert_eq!(
        shm.stats().cannot_map as usize,
        match limited() {
            true => PUBLISHED,
            false => 0,
        }
    );
    if limited() {
        // The failed probe is in the subscriber process's log, with its cause.
        let failures = shm_receive_failures();
        assert!(
            failures.count(ReceiveFailureCause::MemoryLock)
                > before.count(ReceiveFailureCause::MemoryLock)
        );
    }
}

#[test]
fn of_two_pools_the_one_that_does_not_fit_goes_from_the_heap_and_nothing_is_lost() {
    let _shm = shm_serial();
    shm_runtime::init_logging();
    const POOL: usize = 1 << 20;
    let (a, b, port) = loopback_sessions();
    let c = common::connect_to(port);
    let pools = [ShmConfig::enabled(), ShmConfig::enabled()]
        .map(|config| ShmContext::new(config.pool_size(POOL).threshold(1024)));
    let [Ok(first), Ok(second)] = pools else {
        eprintln!("two pools of 1 MiB do not fit this limit: nothing to show");
        return;
    };
    let publishers =
        [(&a, &first, "loss/left"), (&c, &second, "loss/right")].map(|(session, pool, key)| {
            session
                .declare_ros_publisher::<UInt8MultiArray>(key)
                .shm(pool)
                .wait()
                .unwrap()
        });
    // Room for one pool (and the metadata segment, if this process has not
    // mapped it as a reader yet): the first subscriber's session maps it.
    let room = MemlockBudget::read().locked + ZENOH_METADATA_SEGMENT + POOL as u64 + 512 * 1024;
    let limit = LimitGuard::lower_to(room);
    let left = b
        .declare_ros_subscriber::<UInt8MultiArray>("loss/left")
        .wait()
        .unwrap();
    assert!(publishers[0].wait_for_subscribers(TIMEOUT));
    // Then no room for the second.
    let _tighter = LimitGuard::lower_to(MemlockBudget::read().locked);
    let right = b
        .declare_ros_subscriber::<UInt8MultiArray>("loss/right")
        .wait()
        .unwrap();
    assert!(publishers[1].wait_for_subscribers(TIMEOUT));
    let mut reaches = Vec::new();
    for (publisher, subscriber) in publishers.iter().zip([&left, &right]) {
        let receivers = publisher.receivers();
        assert_eq!(receivers.len(), 1, "{receivers:?}");
        reaches.push(receivers[0].reach);
        publish_all(publisher);
        assert_eq!(receive_all(subscriber), PUBLISHED, "a message was lost");
        assert_eq!(subscriber.missed(), 0);
    }
    drop(_tighter);
    drop(limit);
    println!("reaches under {room} bytes of memory-lock limit: {reaches:?}");
    if limited() {
        assert_eq!(reaches, [Reach::SharedMemory, Reach::CannotMap]);
    } else {
        assert_eq!(reaches, [Reach::SharedMemory; 2]);
    }
}

#[test]
fn a_session_at_its_open_files_limit_gets_every_message_from_the_heap() {
    let _shm = shm_serial();
    shm_runtime::init_logging();
    let (a, b, _) = loopback_sessions();
    let shm = ShmContext::new(ShmConfig::enabled().threshold(1024)).unwrap();
    if shm.pool_size().is_none() {
        eprintln!(
            "no pool under this limit ({}): nothing to map",
            shm.memlock()
        );
        return;
    }
    let publisher = a
        .declare_ros_publisher::<UInt8MultiArray>("loss/files")
        .shm(&shm)
        .wait()
        .unwrap();
    let before = shm_receive_failures();
    // Every file descriptor the limit allows is in use: the subscriber's
    // session cannot open the pool's segment (the open-files limit applies
    // to root as well).
    let (soft, hard) = rlimit::getrlimit(rlimit::Resource::NOFILE).unwrap();
    // (The listing counts its own descriptor, closed when it ends.)
    let open = std::fs::read_dir("/proc/self/fd").unwrap().count() as u64 - 1;
    rlimit::setrlimit(rlimit::Resource::NOFILE, open.min(soft), hard).unwrap();
    let subscriber = b
        .declare_ros_subscriber::<UInt8MultiArray>("loss/files")
        .wait()
        .unwrap();
    let matched = publisher.wait_for_subscribers(TIMEOUT);
    let receivers = publisher.receivers();
    let kinds = publish_all(&publisher);
    let received = receive_all(&subscriber);
    rlimit::setrlimit(rlimit::Resource::NOFILE, soft, hard).unwrap();

    assert!(matched);
    assert_eq!(receivers.len(), 1, "{receivers:?}");
    assert_eq!(receivers[0].reach, Reach::CannotMap);
    assert!(
        kinds.iter().all(|k| *k == PayloadKind::ReceiverCannotMap),
        "{kinds:?}"
    );
    assert_eq!(received, PUBLISHED, "a message was lost");
    let failures = shm_receive_failures();
    assert!(
        failures.count(ReceiveFailureCause::OpenFiles)
            > before.count(ReceiveFailureCause::OpenFiles),
        "{failures:?}"
    );
}
