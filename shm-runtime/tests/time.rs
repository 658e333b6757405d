//! A node's clock and timers on simulated time: a `/clock` publisher drives
//! them, counted rather than timed. The timer fires once per simulated
//! period, not while `/clock` stands still, and starts over after a jump back;
//! the clock switches between system and simulated time at run time.

mod common;

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use common::loopback_sessions;
use shm_cdr::msgs::rosgraph_msgs::msg::Clock as ClockMsg;
use shm_runtime::rmw::{Durability, History, Qos, Reliability};
use shm_runtime::time::RosTime;
use shm_runtime::RosNode;
use zenoh::Wait;

const TIMEOUT: Duration = Duration::from_secs(10);

fn at_ms(ms: i64) -> ClockMsg {
    ClockMsg {
        clock: RosTime::from_nanos(ms * 1_000_000).to_msg(),
    }
}

/// Wait (bounded) until `condition`; whether it held.
fn eventually(condition: impl Fn() -> bool) -> bool {
    let deadline = Instant::now() + TIMEOUT;
    while !condition() {
        if Instant::now() > deadline {
            return false;
        }
        std::thread::sleep(Duration::from_millis(2));
    }
    true
}

#[test]
fn a_ros_time_timer_fires_at_the_simulated_rate() {
    let (a, b, _) = loopback_sessions();
    let simulator = common::node(&a, "simulator");
    let clock_qos = Qos::with_history(
        Reliability::BestEffort,
        Durability::Volatile,
        History::KeepLast(1),
    );
    let publisher = simulator
        .declare_publisher_with_qos::<ClockMsg>("/clock", clock_qos)
        .wait()
        .unwrap();
    let node = RosNode::builder(&b, "controller")
        .domain_id(0)
        .use_sim_time(true)
        .wait()
        .unwrap();
    assert!(node.clock().is_simulated());
    assert_eq!(
        node.clock().now(),
        RosTime::default(),
        "zero before the first /clock"
    );
    assert!(publisher.wait_for_subscribers(TIMEOUT));

    let fired = Arc::new(AtomicU64::new(0));
    let count = fired.clone();
    let timer = node
        .create_timer(Duration::from_secs(1), move || {
            count.fetch_add(1, Ordering::SeqCst);
        })
        .unwrap();

    // 5 simulated seconds in steps of 100 ms: one tick per simulated second.
    for step in 1..=50 {
        publisher.publish(&at_ms(step * 100)).wait().unwrap();
        assert!(eventually(
            || node.clock().now() == RosTime::from_nanos(step * 100_000_000)
        ));
        // Each deadline crossed fires the timer before time goes on.
        let due = (step / 10) as u64;
        assert!(
            eventually(|| fired.load(Ordering::SeqCst) >= due),
            "step {step}"
        );
        assert_eq!(
            fired.load(Ordering::SeqCst),
            due,
            "step {step}: fired too often"
        );
    }
    // /clock stands still: so does the timer.
    std::thread::sleep(Duration::from_millis(1500));
    assert_eq!(fired.load(Ordering::SeqCst), 5);

    // A jump of 10 simulated seconds fires once; a jump back starts over.
    publisher.publish(&at_ms(15_000)).wait().unwrap();
    assert!(eventually(|| fired.load(Ordering::SeqCst) == 6));
    publisher.publish(&at_ms(1_000)).wait().unwrap();
    assert!(eventually(
        || node.clock().now() == RosTime::from_nanos(1_000_000_000)
    ));
    publisher.publish(&at_ms(1_500)).wait().unwrap();
    assert!(eventually(
        || node.clock().now() == RosTime::from_nanos(1_500_000_000)
    ));
    assert_eq!(fired.load(Ordering::SeqCst), 6);
    publisher.publish(&at_ms(2_000)).wait().unwrap();
    assert!(eventually(|| fired.load(Ordering::SeqCst) == 7));
    assert_eq!(timer.fired(), 7);

    // Canceled: never again, whatever the clock does. (Left running, it
    // would fire once on the switch to system time, a jump forward.)
    timer.cancel();
    assert!(timer.is_canceled());

    // Back to system time at run time, and to simulated time again.
    node.set_use_sim_time(false).unwrap();
    assert!(!node.clock().is_simulated());
    assert!(node.clock().now().to_msg().sec > 1_700_000_000);
    node.set_use_sim_time(true).unwrap();
    // The new /clock subscription is known to the publisher after a moment.
    assert!(eventually(|| {
        publisher.publish(&at_ms(100_000)).wait().unwrap();
        node.clock().now() == RosTime::from_nanos(100_000_000_000)
    }));
    std::thread::sleep(Duration::from_millis(100));
    assert_eq!(timer.fired(), 7);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_async_sleep_on_simulated_time_wakes_when_clock_gets_there() {
    let (a, b, _) = loopback_sessions();
    let simulator = common::node(&a, "simulator");
    let publisher = simulator
        .declare_publisher_with_qos::<ClockMsg>(
            "/clock",
            Qos::with_history(
                Reliability::BestEffort,
                Durability::Volatile,
                History::KeepLast(1),
            ),
        )
        .wait()
        .unwrap();
    let node = RosNode::builder(&b, "sleeper")
        .domain_id(0)
        .use_sim_time(true)
        .wait()
        .unwrap();
    assert!(publisher.wait_for_subscribers(TIMEOUT));
    let clock = node.clock().clone();
    let sleeper = tokio::spawn(async move {
        clock
            .sleep_until_async(RosTime::from_nanos(3_000_000_000))
            .await;
        clock.now()
    });
    for ms in [1_000, 2_000, 2_999] {
        publisher.publish(&at_ms(ms)).wait().unwrap();
        tokio::time::sleep(Duration::from_millis(50)).await;
        assert!(!sleeper.is_finished(), "woke at {ms} ms");
    }
    publisher.publish(&at_ms(3_000)).wait().unwrap();
    let woke = tokio::time::timeout(TIMEOUT, sleeper)
        .await
        .unwrap()
        .unwrap();
    assert_eq!(woke, RosTime::from_nanos(3_000_000_000));
}

#[test]
fn a_wall_timer_fires_on_system_time_whatever_the_node_follows() {
    let (_, b, _) = loopback_sessions();
    let node = RosNode::builder(&b, "walls")
        .domain_id(0)
        .use_sim_time(true)
        .wait()
        .unwrap();
    let timer = node
        .create_wall_timer(Duration::from_millis(20), || {})
        .unwrap();
    // Simulated time stands at zero; the wall timer goes on.
    assert!(eventually(|| timer.fired() >= 3));
    drop(timer);
}
