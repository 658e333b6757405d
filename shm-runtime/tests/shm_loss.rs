//! A subscriber whose process cannot map the publisher's shared memory (here:
//! its memory-lock limit is used up, as with a second camera in a container)
//! gets nothing for those messages from Zenoh, not even an error. Every one of
//! them must still be counted, with its cause: received + counted = published.
//!
//! The limit is lowered inside this process, so this binary holds this test
//! alone. As root (`CAP_IPC_LOCK`) nothing fails and the sum holds with no
//! failure; `.ci/unprivileged` runs it as an ordinary user, where every
//! shared-memory message fails to map until the publisher's pool is full and
//! it goes on from the heap.

mod common;

use std::time::{Duration, Instant};

use common::{loopback_sessions, shm_serial};
use shm_cdr::msgs::std_msgs::UInt8MultiArray;
use shm_runtime::{
    shm_receive_failures, MemlockBudget, PayloadKind, ReceiveFailureCause, SessionExt, ShmConfig,
    ShmContext,
};
use zenoh::Wait;

const PUBLISHED: usize = 40;
const TIMEOUT: Duration = Duration::from_secs(10);

#[test]
fn every_message_the_subscriber_cannot_map_is_counted_with_its_cause() {
    let _shm = shm_serial();
    shm_runtime::init_logging();
    let (a, b, _) = loopback_sessions();
    let shm = ShmContext::new(ShmConfig::enabled().threshold(1024)).unwrap();
    let publisher = a
        .declare_ros_publisher::<UInt8MultiArray>("loss/blobs")
        .shm(&shm)
        .wait()
        .unwrap();
    let subscriber = b
        .declare_ros_subscriber::<UInt8MultiArray>("loss/blobs")
        .wait()
        .unwrap();
    assert!(publisher.wait_for_subscribers(TIMEOUT));

    // From here on nothing more can be locked: the subscriber's session has
    // not mapped the pool yet, and now it cannot.
    let budget = MemlockBudget::read();
    let limited = budget.available().is_some();
    let (soft, hard) = rlimit::getrlimit(rlimit::Resource::MEMLOCK).unwrap();
    rlimit::setrlimit(rlimit::Resource::MEMLOCK, budget.locked.min(soft), hard).unwrap();

    let before = shm_receive_failures();
    let mut through_shm = 0;
    for i in 0..PUBLISHED {
        let message = UInt8MultiArray {
            data: vec![i as u8; 64 * 1024],
            ..Default::default()
        };
        let outcome = publisher.publish(&message).wait().unwrap();
        through_shm += usize::from(outcome.kind == PayloadKind::Shm);
        std::thread::sleep(Duration::from_millis(5));
    }
    let failed = || shm_receive_failures().total() - before.total();
    let mut received = 0;
    let deadline = Instant::now() + TIMEOUT;
    while received + (failed() as usize) < PUBLISHED && Instant::now() < deadline {
        if let Ok(Some(_)) = subscriber.recv_timeout(Duration::from_millis(100)) {
            received += 1;
        }
    }
    rlimit::setrlimit(rlimit::Resource::MEMLOCK, soft, hard).unwrap();

    let failures = shm_receive_failures();
    println!(
        "{budget}: {through_shm} of {PUBLISHED} sent through shared memory, {received} received, {} counted as lost",
        failed()
    );
    assert_eq!(
        received + failed() as usize,
        PUBLISHED,
        "a message was lost silently"
    );
    assert_eq!(
        failures.count(ReceiveFailureCause::MemoryLock)
            - before.count(ReceiveFailureCause::MemoryLock),
        failed(),
        "every loss here is the memory-lock limit's"
    );
    if limited && shm.pool_size().is_some() {
        assert!(
            failed() > 0,
            "the limit was used up, yet every message mapped"
        );
    }
}
