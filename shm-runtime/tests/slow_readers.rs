//! Readers that stall: memory stays bounded by each subscriber's history or
//! budget, what is dropped is counted, and a callback that blocks for longer
//! than Zenoh's `wait_before_close` (5 s) stalls neither the publisher, nor
//! the other subscribers of its session, nor the connection.

mod common;

use std::sync::mpsc;
use std::time::Duration;

use common::loopback_sessions;
use shm_cdr::msgs::std_msgs::UInt8MultiArray;
use shm_runtime::{Executor, History, SessionExt};
use zenoh::Wait;

const TIMEOUT: Duration = Duration::from_secs(10);

fn blob(i: usize, len: usize) -> UInt8MultiArray {
    UInt8MultiArray {
        data: vec![i as u8; len],
        ..Default::default()
    }
}

#[test]
fn a_keep_all_subscriber_that_never_reads_holds_its_budget_and_counts_the_rest() {
    let (a, b, _) = loopback_sessions();
    let publisher = a
        .declare_ros_publisher::<UInt8MultiArray>("slow/keep_all")
        .wait()
        .unwrap();
    let budget = 4 << 20;
    let idle = b
        .declare_ros_subscriber::<UInt8MultiArray>("slow/keep_all")
        .max_queued_bytes(budget)
        .wait()
        .unwrap();
    let reader = b
        .declare_ros_subscriber::<UInt8MultiArray>("slow/keep_all")
        .wait()
        .unwrap();
    assert!(publisher.wait_for_subscribers(TIMEOUT));
    let (sent, size) = (40, 256 << 10);
    for i in 0..sent {
        publisher.publish(&blob(i, size)).wait().unwrap();
        // The reading subscriber tells when each has arrived.
        assert!(reader.recv_timeout(TIMEOUT).unwrap().is_some());
    }
    let queued = idle.queued();
    assert!(
        queued * size <= budget,
        "{queued} samples of {size} bytes held"
    );
    assert!(queued >= budget / size - 1, "only {queued} held");
    assert_eq!(
        queued as u64 + idle.lost(),
        sent as u64,
        "every sample held or counted"
    );

    // Released samples give their budget back: reading makes room again.
    while idle.try_recv().unwrap().is_some() {}
    publisher.publish(&blob(0, size)).wait().unwrap();
    assert!(idle.recv_timeout(TIMEOUT).unwrap().is_some());
}

#[test]
fn a_node_subscriber_that_never_reads_keeps_what_its_qos_says() {
    let (a, b, _) = loopback_sessions();
    let talker = common::node(&a, "talker");
    let publisher = talker
        .declare_publisher::<UInt8MultiArray>("/slow/images")
        .wait()
        .unwrap();
    let listener = common::node(&b, "listener");
    let idle = listener
        .declare_subscriber::<UInt8MultiArray>("/slow/images")
        .wait()
        .unwrap();
    let reader = listener
        .declare_subscriber::<UInt8MultiArray>("/slow/images")
        .history(History::KeepAll)
        .wait()
        .unwrap();
    assert!(publisher.wait_for_subscribers(TIMEOUT));
    for i in 0..50 {
        publisher.publish(&blob(i, 64 << 10)).wait().unwrap();
        assert!(reader.recv_timeout(TIMEOUT).unwrap().is_some());
    }
    // ROS 2's default profile: keep last 10.
    assert_eq!(idle.queued(), 10);
    assert_eq!(idle.lost(), 40);
    let newest = idle.try_recv().unwrap().unwrap();
    let message: UInt8MultiArray = newest.decode().unwrap();
    assert_eq!(
        message.data[0], 40,
        "the oldest were dropped, the newest kept"
    );
}

/// A callback blocked for 6 s (Zenoh closes a connection it cannot write to
/// for 5 s): the publisher goes on, another subscriber of the same session
/// gets every message meanwhile, the blocked one's queue keeps its depth and
/// counts the rest, and the connection is still up afterwards.
#[test]
fn a_callback_blocked_past_zenohs_close_timeout_stalls_nothing_else() {
    let (a, b, _) = loopback_sessions();
    let publisher = a
        .declare_ros_publisher::<UInt8MultiArray>("slow/callback")
        .wait()
        .unwrap();
    let (entered, entered_rx) = mpsc::channel::<()>();
    let (release, released) = mpsc::channel::<()>();
    let (seen, seen_rx) = mpsc::channel::<u8>();
    let executor = Executor::new(1).unwrap();
    let blocked = b
        .declare_ros_subscriber::<UInt8MultiArray>("slow/callback")
        .history(History::KeepLast(5.try_into().unwrap()))
        .callback(move |sample| {
            let message: UInt8MultiArray = sample.decode().unwrap();
            if message.data[0] == 0 {
                entered.send(()).unwrap();
                released.recv_timeout(Duration::from_secs(30)).unwrap();
            }
            seen.send(message.data[0]).unwrap();
        })
        .executor(&executor)
        .wait()
        .unwrap();
    let (other_tx, other) = mpsc::channel::<u8>();
    let _other = b
        .declare_ros_subscriber::<UInt8MultiArray>("slow/callback")
        .callback(move |sample| {
            let message: UInt8MultiArray = sample.decode().unwrap();
            other_tx.send(message.data[0]).unwrap();
        })
        .wait()
        .unwrap();
    assert!(publisher.wait_for_subscribers(TIMEOUT));

    publisher.publish(&blob(0, 1024)).wait().unwrap();
    entered_rx.recv_timeout(TIMEOUT).unwrap();
    assert_eq!(other.recv_timeout(TIMEOUT).unwrap(), 0);
    // 6 s of messages while the first callback is blocked.
    let sent = 120;
    for i in 1..sent {
        publisher.publish(&blob(i, 64 << 10)).wait().unwrap();
        assert_eq!(
            other.recv_timeout(TIMEOUT).unwrap(),
            i as u8,
            "the other subscriber stalled"
        );
        std::thread::sleep(Duration::from_millis(50));
    }
    release.send(()).unwrap();

    // The blocked callback sees message 0, then the newest 5; the rest are
    // counted as lost, none as missed (the connection never closed).
    let mut got = vec![seen_rx.recv_timeout(TIMEOUT).unwrap()];
    while let Ok(i) = seen_rx.recv_timeout(Duration::from_millis(500)) {
        got.push(i);
    }
    assert_eq!(got, [0, 115, 116, 117, 118, 119]);
    assert_eq!(blocked.lost(), 114);
    assert_eq!(blocked.missed(), 0);

    // Still connected: both get the next one.
    publisher.publish(&blob(7, 1024)).wait().unwrap();
    assert_eq!(seen_rx.recv_timeout(TIMEOUT).unwrap(), 7);
    assert_eq!(other.recv_timeout(TIMEOUT).unwrap(), 7);
}

/// A panicking callback loses the sample it panicked on, not its thread.
#[test]
fn a_panicking_callback_goes_on_with_the_next_sample() {
    let (a, b, _) = loopback_sessions();
    let publisher = a
        .declare_ros_publisher::<UInt8MultiArray>("slow/panic")
        .wait()
        .unwrap();
    let (seen, seen_rx) = mpsc::channel::<u8>();
    let executor = Executor::new(1).unwrap();
    let _subscriber = b
        .declare_ros_subscriber::<UInt8MultiArray>("slow/panic")
        .callback(move |sample| {
            let message: UInt8MultiArray = sample.decode().unwrap();
            assert_ne!(message.data[0], 1, "a callback that panics on 1");
            seen.send(message.data[0]).unwrap();
        })
        .executor(&executor)
        .wait()
        .unwrap();
    assert!(publisher.wait_for_subscribers(TIMEOUT));
    for i in 0..3 {
        publisher.publish(&blob(i, 16)).wait().unwrap();
    }
    assert_eq!(seen_rx.recv_timeout(TIMEOUT).unwrap(), 0);
    assert_eq!(seen_rx.recv_timeout(TIMEOUT).unwrap(), 2);
}

/// A service handler blocked for 6 s holds up neither Zenoh's thread nor
/// another server of the same session.
#[test]
fn a_blocked_service_handler_does_not_stall_another_server() {
    use shm_cdr::msgs::std_srvs::srv::{Trigger, Trigger_Request, Trigger_Response};

    let (a, b, _) = loopback_sessions();
    let server_node = common::node(&a, "servers");
    let (release, released) = mpsc::channel::<()>();
    let released = std::sync::Mutex::new(released);
    let _slow = server_node
        .declare_service::<Trigger>("/slow")
        .handler(move |_| {
            let _ = released
                .lock()
                .unwrap()
                .recv_timeout(Duration::from_secs(30));
            Trigger_Response {
                success: true,
                message: "late".into(),
            }
        })
        .wait()
        .unwrap();
    let _fast = server_node
        .declare_service::<Trigger>("/fast")
        .handler(|_| Trigger_Response {
            success: true,
            message: "at once".into(),
        })
        .wait()
        .unwrap();
    let client_node = common::node(&b, "clients");
    let slow = client_node
        .declare_client::<Trigger>("/slow")
        .wait()
        .unwrap();
    let fast = client_node
        .declare_client::<Trigger>("/fast")
        .wait()
        .unwrap();
    assert!(slow.wait_for_service(TIMEOUT) && fast.wait_for_service(TIMEOUT));

    let pending = std::thread::spawn(move || {
        slow.call(&Trigger_Request)
            .timeout(Duration::from_secs(30))
            .wait()
    });
    std::thread::sleep(Duration::from_millis(200));
    // 6 s of calls to the other server while the first handler is blocked.
    for _ in 0..60 {
        let response = fast.call(&Trigger_Request).wait().unwrap();
        assert_eq!(response.message, "at once");
        std::thread::sleep(Duration::from_millis(100));
    }
    release.send(()).unwrap();
    assert_eq!(pending.join().unwrap().unwrap().message, "late");
}
