//! Your own message type, published by one process and read by another
//! through shared memory, both meeting at a router as ROS 2 nodes on
//! rmw_zenoh_cpp do. The README's quick start is this file.
//!
//! ```sh
//! cargo run --release -p shm-cdr-examples --example quickstart -- router
//! cargo run --release -p shm-cdr-examples --example quickstart -- talk
//! cargo run --release -p shm-cdr-examples --example quickstart -- listen
//! ```
use std::time::Duration;

use shm_cdr::RosMessage;
use shm_runtime::rmw::config;
use shm_runtime::{RosNode, ShmConfig, ShmContext};
use zenoh::Wait;

/// Your message: a plain struct of ROS field types.
#[derive(RosMessage, Debug)]
#[ros(type_name = "my_robot/msg/Scan")]
struct Scan {
    seq: u32,
    frame_id: String,
    ranges: Vec<f32>,
}

const USAGE: &str = "usage: quickstart router | talk [count] | listen [count]";

fn main() -> Result<(), Box<dyn std::error::Error + Send + Sync>> {
    shm_runtime::init_logging(); // the runtime's warnings, on stderr
    let role = std::env::args().nth(1).unwrap_or_default();
    let count = match std::env::args().nth(2).map(|n| n.parse::<u32>()) {
        None => u32::MAX,
        Some(Ok(n)) => n,
        Some(Err(_)) => usage(),
    };

    // Configured as rmw_zenoh_cpp configures ROS 2's processes: a router on
    // tcp/localhost:7447 where nodes and the ROS tools meet, changed by
    // ZENOH_ROUTER_CONFIG_URI, ZENOH_SESSION_CONFIG_URI and ZENOH_CONFIG_OVERRIDE.
    let session_config = match role.as_str() {
        "router" => {
            // What `ros2 run rmw_zenoh_cpp rmw_zenohd` runs.
            let _router = zenoh::open(config::router_config()?).wait()?;
            println!("router running; stop it with Ctrl-C");
            loop {
                std::thread::park();
            }
        }
        "talk" | "listen" => config::session_config()?,
        _ => usage(),
    };
    let session = zenoh::open(session_config).wait()?;

    // A shared-memory pool that fits the memory-lock limit (`ulimit -l`).
    let shm = ShmContext::new(ShmConfig::enabled().with_env()?)?;
    let node = RosNode::builder(&session, &role).shm(&shm).wait()?;

    if role == "talk" {
        let publisher = node.declare_publisher::<Scan>("scan").wait()?;
        for seq in 0..count {
            let scan = Scan {
                seq,
                frame_id: "laser".into(),
                ranges: vec![1.5; 1080],
            };
            let sent = publisher.publish(&scan).wait()?;
            println!("sent     #{seq}: {} bytes as {:?}", sent.size, sent.kind);
            std::thread::sleep(Duration::from_millis(500));
        }
    } else {
        let subscriber = node.declare_subscriber::<Scan>("scan").wait()?;
        for _ in 0..count {
            let sample = subscriber.recv()?;
            let scan: Scan = sample.decode()?;
            println!(
                "received #{}: {} ranges from {:?}, in shared memory: {}",
                scan.seq,
                scan.ranges.len(),
                scan.frame_id,
                sample.is_shm()
            );
        }
    }
    Ok(())
}

fn usage() -> ! {
    eprintln!("{USAGE}");
    std::process::exit(2)
}
