//! `/rosout`: `tracing` events of the application reach the topic as
//! `rcl_interfaces/msg/Log`, under the node's logger name, with level,
//! message and fields, file, module and line, on rclcpp's QoS; those the
//! node's logger level admits.

mod common;

use std::time::Duration;

use common::loopback_sessions;
use shm_cdr::msgs::rcl_interfaces::msg::Log;
use shm_runtime::log_levels::{self, LogLevel};
use shm_runtime::rmw::Qos;
use shm_runtime::RosNode;
use tracing_subscriber::prelude::*;
use zenoh::Wait;

const TIMEOUT: Duration = Duration::from_secs(10);

#[test]
fn tracing_events_reach_rosout_as_rcl_log_messages() {
    let (a, b, _) = loopback_sessions();
    let talker = RosNode::builder(&a, "talker")
        .namespace("/demo")
        .domain_id(0)
        .wait()
        .unwrap();
    let layer = talker.rosout_layer().unwrap();
    assert_eq!(layer.logger_name(), "demo.talker");
    let listener = common::node(&b, "console");
    // A volatile subscriber: what is checked here is what the layer
    // publishes, not transient-local delivery (`durability.rs`), whose
    // zenoh-ext history queries can hold or drop a live message that races
    // them while the sessions start.
    let rosout = listener
        .declare_subscriber_with_qos::<Log>("/rosout", Qos::default())
        .wait()
        .unwrap();
    assert!(rosout.wait_for_publishers(TIMEOUT));
    // Log once the talker's session routes to the listener: what is
    // published before that goes nowhere.
    let route = a
        .declare_publisher(rosout.key_expr().to_owned())
        .wait()
        .unwrap();
    let deadline = std::time::Instant::now() + TIMEOUT;
    while !route.matching_status().wait().unwrap().matching() {
        assert!(std::time::Instant::now() < deadline, "no route to /rosout");
        std::thread::sleep(Duration::from_millis(5));
    }

    let line = line!() + 4;
    // Kept to the end: the layer holds the /rosout publisher.
    let dispatch = tracing::Dispatch::new(tracing_subscriber::registry().with(layer));
    tracing::dispatcher::with_default(&dispatch, || {
        tracing::info!(speed = 1.5, "moving");
        tracing::warn!("careful");
        tracing::error!(target: "zenoh::transport", "not published: Zenoh's own");
        tracing::debug!("not published: below the default level, INFO");
        // A level for the node's logger's parent applies to it.
        log_levels::set_logger_level("demo", LogLevel::Debug).unwrap();
        tracing::debug!(id = "x7", "details");
        log_levels::set_logger_level("demo.talker", LogLevel::Warn).unwrap();
        tracing::info!("not published: below the node's own level");
    });

    let mut logs = Vec::new();
    while logs.len() < 3 {
        let sample = rosout
            .recv_timeout(TIMEOUT)
            .unwrap()
            .expect("a /rosout message");
        logs.push(sample.decode::<Log>().unwrap());
    }
    assert!(rosout
        .recv_timeout(Duration::from_millis(300))
        .unwrap()
        .is_none());
    let levels: Vec<u8> = logs.iter().map(|l| l.level).collect();
    assert_eq!(levels, [Log::INFO, Log::WARN, Log::DEBUG]);
    assert_eq!(logs[0].msg, "moving speed=1.5");
    assert_eq!(logs[2].msg, "details id=\"x7\"");
    for log in &logs {
        assert_eq!(log.name, "demo.talker");
        assert!(log.file.ends_with("rosout.rs"), "{}", log.file);
        assert_eq!(log.function, "rosout");
        assert!(log.stamp.sec > 1_700_000_000);
    }
    assert_eq!(logs[0].line, line);

    // On the graph as rclcpp's: a transient-local publisher keeping 1000.
    let graph = listener.graph(TIMEOUT).unwrap();
    let publishers = graph.publishers("/rosout");
    let ours = publishers
        .iter()
        .find(|p| p.node_fqn() == "/demo/talker")
        .expect("the /rosout publisher on the graph");
    assert_eq!(
        ours.endpoint.as_ref().unwrap().qos,
        Qos::transient_local(1000).lifespan(Duration::from_secs(10))
    );
    drop(dispatch);
}
