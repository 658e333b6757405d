//! `/rosout` for an independent reader (`tests/ros2/rosout.py`: Python
//! eclipse-zenoh, rclpy's deserialization of `rcl_interfaces/msg/Log`).
//!
//! `interop_rosout <listen endpoint> [--ros-args …]`: a node `/demo/talker`
//! with its log on `/rosout` and the logger-level services; prints `ready`,
//! and on each line of stdin logs a debug message, an info, a warning and an
//! error (the same four every time), then prints `logged`. Which of them
//! reach `/rosout` is up to the node's logger level (`INFO` by default;
//! `--log-level` and `~/set_logger_levels` change it).

use std::io::BufRead;

use shm_cdr_examples::peer_session;
use shm_runtime::RosNode;
use tracing_subscriber::prelude::*;
use zenoh::Wait;

fn main() -> Result<(), Box<dyn std::error::Error + Send + Sync>> {
    let endpoint = std::env::args()
        .nth(1)
        .ok_or("usage: interop_rosout <listen endpoint>")?;
    let session = peer_session(&endpoint, true)?;
    let node = RosNode::builder(&session, "talker")
        .namespace("/demo")
        .domain_id(0)
        .logger_service(true)
        .ros_args(std::env::args())
        .wait()?;
    tracing_subscriber::registry()
        .with(node.rosout_layer()?)
        .init();
    println!("ready");
    for line in std::io::stdin().lock().lines() {
        line?;
        tracing::debug!("details");
        tracing::info!(speed = 1.5, "moving");
        tracing::warn!("careful: ünïcode");
        tracing::error!(code = 7, "failed");
        println!("logged");
    }
    Ok(())
}
