//! A subscriber whose process cannot map a publisher's shared memory (here:
//! its memory-lock limit is used up, as with a second camera in a container)
//! would get nothing for those messages from Zenoh, not even an error. The
//! publisher checks every subscribing session before its pool's messages go
//! to it (see `Reach`): a session that cannot map the pool gets every message
//! from the heap, and its process's log names the cause.
//!
//! The limit is lowered for this whole process, so each such test has a
//! binary of its own (`two_pools.rs`, `open_files.rs`): no other test's
//! sessions may unmap (and free) locked memory meanwhile. As
//! root (`CAP_IPC_LOCK`) nothing fails and every message goes through shared
//! memory; `.ci/unprivileged` runs them as an ordinary user, where the
//! limit bites.

mod common;

use std::time::Duration;

use common::blobs::{limited, publish_all, receive_all, LimitGuard, PUBLISHED};
use common::loopback_sessions;
use shm_cdr::msgs::std_msgs::UInt8MultiArray;
use shm_runtime::ShmOptions;
use shm_runtime::{
    shm_receive_failures, MemlockBudget, PayloadKind, Reach, ReceiveFailureCause, SessionExt,
    ShmConfig, ShmContext,
};
use zenoh::Wait;

const TIMEOUT: Duration = Duration::from_secs(10);

#[test]
fn a_session_that_cannot_map_the_pool_gets_every_message_from_the_heap() {
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
