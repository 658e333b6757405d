//! A node configured the way a launch file configures one: values from a ROS 2
//! parameter file and from `-p`, declared with descriptions and ranges,
//! logged to the console and `/rosout`, and changes from `ros2 param set` (or
//! any parameter client) checked, applied and logged.
//!
//! ```text
//! cargo run -p shm-cdr-examples --example param_node -- 0 \
//!     --ros-args --params-file examples/config/driver.yaml -p max_speed:=1.2
//! ```
//!
//! The first argument is how many seconds to serve the parameters after
//! start-up (0: print them and exit). A value out of range, or of the wrong
//! type, is an error that names the parameter. The session is configured as
//! rmw_zenoh_cpp configures a node's (a router on `tcp/localhost:7447`:
//! `shm-ros2 router`; `ZENOH_SESSION_CONFIG_URI`, `ZENOH_CONFIG_OVERRIDE`),
//! so `shm-ros2 param list /robot/driver` (or `ros2 param`) reaches it there.

use std::time::Duration;

use shm_runtime::parameters::{ParameterDescriptor, ParameterValue};
use shm_runtime::RosNode;
use tracing::Level;
use tracing_subscriber::filter::Targets;
use tracing_subscriber::prelude::*;
use zenoh::Wait;

fn main() -> std::process::ExitCode {
    match run() {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("param_node: {e}");
            std::process::ExitCode::FAILURE
        }
    }
}

fn run() -> Result<(), Box<dyn std::error::Error + Send + Sync>> {
    let args: Vec<String> = std::env::args().collect();
    let seconds: u64 = match args.get(1).filter(|a| *a != "--ros-args") {
        Some(s) => s.parse().map_err(|e| format!("seconds {s:?}: {e}"))?,
        None => 0,
    };
    let session = zenoh::open(shm_runtime::rmw::config::session_config()?).wait()?;
    let node = RosNode::builder(&session, "driver")
        .namespace("/robot")
        .ros_args(&args)
        .wait()?;
    // The console shows this program's info and Zenoh's warnings; /rosout
    // gets the program's log (never Zenoh's).
    let console = Targets::new()
        .with_default(Level::INFO)
        .with_target("zenoh", Level::WARN);
    tracing_subscriber::registry()
        .with(tracing_subscriber::fmt::layer().with_filter(console))
        .with(node.rosout_layer()?)
        .init();

    let frame = node.declare_parameter_with(
        "frame_id",
        "odom",
        ParameterDescriptor::new("frame the velocities are in").read_only(),
    )?;
    let max_speed = node.declare_parameter_with(
        "max_speed",
        0.5,
        ParameterDescriptor::new("m/s").floating_point_range(0.0, 2.0, 0.0),
    )?;
    let radius = node.declare_parameter("wheels.radius", 0.1)?;
    let separation = node.declare_parameter("wheels.separation", 0.5)?;
    tracing::info!(%frame, %max_speed, %radius, %separation, "configured");
    println!("frame_id={frame} max_speed={max_speed} wheels.radius={radius} wheels.separation={separation}");

    node.on_parameters_set(|changes| {
        for (name, value) in changes {
            tracing::info!(name, %value, "parameter changed");
        }
    })?;
    if seconds > 0 {
        std::thread::sleep(Duration::from_secs(seconds));
        if let Some(ParameterValue::Double(speed)) = node.parameter("max_speed") {
            println!("max_speed is now {speed}");
        }
    }
    Ok(())
}
