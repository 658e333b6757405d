//! A subscriber's process at its open-files limit cannot open a publisher's
//! segment; the publisher's probe finds that out and the session gets every
//! message from the heap. The limit binds root as well, so this runs
//! everywhere. It lowers the limit of this whole process to the descriptors
//! in use, so it runs alone in its binary: no other test's sessions may
//! close (and free) descriptors meanwhile.

mod common;

use std::time::Duration;

use common::blobs::{publish_all, receive_all, PUBLISHED};
use common::loopback_sessions;
use shm_cdr::msgs::std_msgs::UInt8MultiArray;
use shm_runtime::ShmOptions;
use shm_runtime::{
    shm_receive_failures, PayloadKind, Reach, ReceiveFailureCause, SessionExt, ShmConfig,
    ShmContext,
};
use zenoh::Wait;

const TIMEOUT: Duration = Duration::from_secs(10);

#[test]
fn a_session_at_its_open_files_limit_gets_every_message_from_the_heap() {
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
