//! `/rosout` for an independent reader (`tests/ros2/rosout.py`: Python
//! eclipse-zenoh, rclpy's deserialization of `rcl_interfaces/msg/Log`).
//!
//! `interop_rosout <listen endpoint>`: a node `/demo/talker` with its log on
//! `/rosout`; prints `ready`, and on each line of stdin logs an info, a
//! warning and an error (the same three every time), then prints `logged`.

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
        .wait()?;
    tracing_subscriber::registry()
        .with(node.rosout_layer()?)
        .init();
    println!("ready");
    for line in std::io::stdin().lock().lines() {
        line?;
        tracing::info!(speed = 1.5, "moving");
        tracing::warn!("careful: ünïcode");
        tracing::error!(code = 7, "failed");
        println!("logged");
    }
    Ok(())
}
