//! A hand-written message with `#[derive(RosMessage)]`, published on a raw key
//! expression and as an rmw_zenoh_cpp-compatible ROS 2 topic.
//!
//! `cargo run -p shm-cdr-examples --example custom_message`

use std::time::Duration;

use shm_cdr::msgs::builtin_interfaces::Time;
use shm_cdr::{BoundedVec, RosMessage};
use shm_cdr_examples::loopback_pair;
use shm_runtime::{RosNode, SessionExt};
use zenoh::Wait;

/// A robot's battery report: no .msg file, no ROS installation.
#[derive(RosMessage, Debug, Clone, PartialEq)]
#[ros(type_name = "robot_msgs/msg/Battery")]
struct Battery {
    stamp: Time,
    voltage: f32,
    cells: BoundedVec<f32, 16>,
    charging: bool,
    label: String,
}

fn main() -> zenoh::Result<()> {
    // Warnings (a pool that fell back to the heap, a message missed) reach
    // stderr only through a logger: `RUST_LOG=info` shows more.
    shm_runtime::init_logging();
    let (a, b) = loopback_pair(7449)?;
    let msg = Battery {
        stamp: Time {
            sec: 1_700_000_000,
            nanosec: 42,
        },
        voltage: 24.6,
        cells: vec![4.1, 4.1, 4.09, 4.1, 4.11, 4.09].into(),
        charging: false,
        label: "pack-A".into(),
    };
    println!("type {} ({})", Battery::TYPE_NAME, Battery::type_hash());

    // Raw key expression of your choice.
    let publisher = a.declare_ros_publisher::<Battery>("robot/battery").wait()?;
    let subscriber = b
        .declare_ros_subscriber::<Battery>("robot/battery")
        .wait()?;
    publisher.wait_for_subscribers(Duration::from_secs(5));
    publisher.publish(&msg).wait()?;
    let received: Battery = subscriber.recv_message()?;
    assert_eq!(received, msg);
    println!("raw key   {}  -> {received:?}", publisher.key_expr());

    // rmw_zenoh style: a node, a ROS topic, liveliness token, GID and attachment.
    let node = RosNode::builder(&a, "battery_monitor")
        .namespace("/robot")
        .wait()?;
    let ros_publisher = node.declare_publisher::<Battery>("/battery_state").wait()?;
    let ros_subscriber = b
        .declare_ros_subscriber::<Battery>(ros_publisher.key_expr())
        .wait()?;
    ros_publisher.wait_for_subscribers(Duration::from_secs(5));
    let outcome = ros_publisher.publish(&msg).wait()?;
    let sample = ros_subscriber.recv()?;
    let attachment = sample.attachment().ok_or("no attachment")??;
    println!("ros key   {}", sample.key_expr());
    println!(
        "token     {}",
        ros_publisher.liveliness_token().unwrap_or_default()
    );
    println!(
        "attach    seq {} ts {} gid {:?} ({:?}, {} bytes)",
        attachment.sequence_number,
        attachment.source_timestamp,
        attachment.gid,
        outcome.kind,
        outcome.size
    );
    assert_eq!(sample.decode::<Battery>()?, msg);
    Ok(())
}
