//! Print the ROS graph the way `ros2 node list`, `ros2 topic list -t`,
//! `ros2 service list -t`, `ros2 action list -t` and `ros2 topic info -v`
//! would, from rmw_zenoh_cpp's liveliness tokens.
//!
//! `ros_graph <connect endpoint>` (e.g. `tcp/127.0.0.1:7447`, a router or a
//! peer) lists what is there; `ros_graph` alone first starts a small demo (a
//! talker with a latched topic, a service and an action; a listener with a
//! subscriber and two clients) on two loopback sessions and lists that.

use std::time::Duration;

use shm_cdr::msgs::std_msgs;
use shm_cdr::msgs::std_srvs::srv::{Trigger, Trigger_Response};
use shm_cdr_examples::loopback_pair;
use shm_runtime::graph::Graph;
use shm_runtime::rmw::{EntityKind, Qos};
use shm_runtime::RosNode;
use zenoh::{Config, Wait};

fn main() -> Result<(), Box<dyn std::error::Error + Send + Sync>> {
    // Warnings (a pool that fell back to the heap, a message missed) reach
    // stderr only through a logger: `RUST_LOG=info` shows more.
    shm_runtime::init_logging();
    let args: Vec<String> = std::env::args().collect();
    match args.get(1) {
        Some(endpoint) => {
            let mut config = Config::default();
            config.insert_json5("mode", "\"peer\"")?;
            config.insert_json5("scouting/multicast/enabled", "false")?;
            config.insert_json5("connect/endpoints", &format!("[\"{endpoint}\"]"))?;
            let session = zenoh::open(config).wait()?;
            let node = RosNode::builder(&session, "ros_graph").wait()?;
            std::thread::sleep(Duration::from_millis(500));
            print(&node.graph(Duration::from_secs(3))?);
        }
        None => {
            let (a, b) = loopback_pair(7453)?;
            let talker = RosNode::builder(&a, "talker").namespace("/demo").wait()?;
            let _chatter = talker
                .declare_publisher::<std_msgs::String>("chatter")
                .wait()?;
            let _description = talker
                .declare_publisher_with_qos::<std_msgs::String>(
                    "robot_description",
                    Qos::transient_local(1),
                )
                .wait()?;
            let _reset = talker
                .declare_service::<Trigger>("~/reset")
                .handler(|_| Trigger_Response::default())
                .wait()?;
            let _navigate = talker
                .declare_action_server::<shm_cdr::msgs::test_msgs::action::Fibonacci>("fibonacci")
                .wait()?;
            let listener = RosNode::builder(&b, "listener").wait()?;
            let _sub = listener
                .declare_subscriber_with_qos::<std_msgs::String>(
                    "/demo/chatter",
                    Qos::sensor_data(),
                )
                .wait()?;
            let client = listener
                .declare_client::<Trigger>("/demo/talker/reset")
                .wait()?;
            client.wait_for_service(Duration::from_secs(5));
            let fibonacci = listener
                .declare_action_client::<shm_cdr::msgs::test_msgs::action::Fibonacci>(
                    "/demo/fibonacci",
                )
                .wait()?;
            fibonacci.wait_for_server(Duration::from_secs(5));
            print(&listener.graph(Duration::from_secs(3))?);
        }
    }
    Ok(())
}

/// A name the `ros2` CLI hides unless asked: one with a part starting with
/// `_` (an action's `_action/…` services and topics).
fn hidden(name: &str) -> bool {
    name.split('/').any(|part| part.starts_with('_'))
}

fn print(graph: &Graph) {
    println!("$ ros2 node list");
    for node in graph.nodes() {
        println!("{node}");
    }
    println!("\n$ ros2 topic list -t");
    for (topic, types) in graph.topics().into_iter().filter(|(t, _)| !hidden(t)) {
        println!("{topic} [{}]", Vec::from_iter(types).join(", "));
    }
    println!("\n$ ros2 service list -t");
    for (service, types) in graph.services().into_iter().filter(|(s, _)| !hidden(s)) {
        println!("{service} [{}]", Vec::from_iter(types).join(", "));
    }
    println!("\n$ ros2 action list -t");
    for (action, types) in graph.actions() {
        println!("{action} [{}]", Vec::from_iter(types).join(", "));
    }
    for (topic, types) in graph.topics().into_iter().filter(|(t, _)| !hidden(t)) {
        println!("\n$ ros2 topic info -v {topic}");
        println!("Type: {}", Vec::from_iter(types).join(", "));
        for (label, kind) in [
            ("Publisher", EntityKind::Publisher),
            ("Subscription", EntityKind::Subscriber),
        ] {
            let endpoints = graph.endpoints(kind, &topic);
            println!("{label} count: {}", endpoints.len());
            for e in endpoints {
                let Some(endpoint) = &e.endpoint else {
                    continue;
                };
                println!(
                    "  Node name: {}\n  Node namespace: {}\n  Endpoint type: {}\n  GID: {:?}\n  QoS: {:?} / {:?} / {:?}",
                    e.node_name,
                    e.namespace,
                    label.to_uppercase(),
                    e.gid,
                    endpoint.qos.reliability,
                    endpoint.qos.durability,
                    endpoint.qos.history,
                );
            }
        }
    }
    for unreadable in graph.unreadable() {
        println!("\n(unreadable) {unreadable}");
    }
}
