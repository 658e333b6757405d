//! Parameters for an independent client (`tests/ros2/parameters.py`: Python
//! eclipse-zenoh and rclpy's serialization), which asks this node and an
//! rclpy node declared the same way the same questions and compares the
//! answers.
//!
//! `interop_parameters <listen endpoint>`: node `/demo/param_node` with the
//! parameters below and a validation callback that refuses a speed of 7.5;
//! prints `ready` and serves until stdin closes.

use std::io::BufRead;

use shm_cdr_examples::peer_session;
use shm_runtime::parameters::{ParameterDescriptor, ParameterValue};
use shm_runtime::RosNode;
use zenoh::Wait;

fn main() -> Result<(), Box<dyn std::error::Error + Send + Sync>> {
    let endpoint = std::env::args()
        .nth(1)
        .ok_or("usage: interop_parameters <listen endpoint>")?;
    let session = peer_session(&endpoint, true)?;
    let node = RosNode::builder(&session, "param_node")
        .namespace("/demo")
        .domain_id(0)
        .wait()?;
    node.declare_parameter_with(
        "speed",
        1.5,
        ParameterDescriptor::new("m/s").floating_point_range(0.0, 10.0, 0.5),
    )?;
    node.declare_parameter_with(
        "count",
        4i64,
        ParameterDescriptor::new("").integer_range(0, 10, 2),
    )?;
    node.declare_parameter_with("frame", "map", ParameterDescriptor::default().read_only())?;
    node.declare_parameter_with("any", 1i64, ParameterDescriptor::default().dynamic_typing())?;
    node.declare_parameter("name.first", "ada")?;
    node.declare_parameter("name.last", "lovelace")?;
    node.declare_parameter("nested.deep.flag", true)?;
    node.declare_parameter("ids", vec![1i64, 2, 3])?;
    node.on_set_parameters(|set| {
        match set
            .iter()
            .any(|(name, value)| name == "speed" && *value == ParameterValue::Double(7.5))
        {
            true => Err("7.5 is not allowed".to_owned()),
            false => Ok(()),
        }
    })?;
    println!("ready");
    for line in std::io::stdin().lock().lines() {
        line?;
    }
    Ok(())
}
