//! Your own message type, published by one process and read by another
//! through shared memory. The README's quick start is this file.
//!
//! ```sh
//! cargo run --release -p shm-cdr-examples --example quickstart -- talk
//! cargo run --release -p shm-cdr-examples --example quickstart -- listen
//! ```
use std::time::Duration;

use shm_cdr::RosMessage;
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

fn main() -> Result<(), Box<dyn std::error::Error + Send + Sync>> {
    shm_runtime::init_logging(); // the runtime's warnings, on stderr
    let role = std::env::args().nth(1).unwrap_or_default();
    let count = match std::env::args().nth(2) {
        Some(n) => n.parse()?,
        None => u32::MAX,
    };

    // The talker listens on a local port, the listener connects to it.
    let mut config = zenoh::Config::default();
    let side = match role.as_str() {
        "talk" => "listen/endpoints",
        "listen" => "connect/endpoints",
        _ => return Err("usage: quickstart talk|listen [count]".into()),
    };
    config.insert_json5(side, r#"["tcp/127.0.0.1:7448"]"#)?;
    // Large heap payloads stay where they are: no copy into a pool of Zenoh's.
    config.insert_json5(
        "transport/shared_memory/transport_optimization/enabled",
        "false",
    )?;
    let session = zenoh::open(config).wait()?;

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
