//! Of two publishers' pools, a subscriber's memory-lock limit holds one: the
//! second publisher's probe finds the session cannot map its pool, and its
//! messages reach it from the heap; nothing is lost. (Across processes, with
//! 4 MiB pools under an 8 MiB limit, `.ci/unprivileged` runs the same case
//! with `examples/shm_reach.rs`.) The limit is lowered for this whole process,
//! so this test has its binary to itself. As root the limit does not apply
//! and both pools are mapped.

mod common;

use std::time::Duration;

use common::blobs::{limited, publish_all, receive_all, LimitGuard, PUBLISHED};
use common::loopback_sessions;
use shm_cdr::msgs::std_msgs::UInt8MultiArray;
use shm_runtime::ShmOptions;
use shm_runtime::{
    MemlockBudget, Reach, SessionExt, ShmConfig, ShmContext, ZENOH_METADATA_SEGMENT,
};
use zenoh::Wait;

const TIMEOUT: Duration = Duration::from_secs(10);

#[test]
fn of_two_pools_the_one_that_does_not_fit_goes_from_the_heap_and_nothing_is_lost() {
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
