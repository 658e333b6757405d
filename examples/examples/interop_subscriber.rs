//! Interop, Python → Rust: receive messages that rosbags and pycdr2 serialized (in
//! both byte orders) and published on `interop/<kind>/<writer>`, decode them with
//! our types and print each as one line of normalized JSON for
//! `tests/interop/check.py` to compare with what it sent.
//!
//! `interop_subscriber <connect endpoint> <count>`

use std::io::Write;
use std::time::Duration;

use serde_json::json;
use shm_cdr::msgs::sensor_msgs::{Image, JointState, PointCloud2};
use shm_cdr::msgs::std_msgs::Header;
use shm_cdr_examples::interop::*;
use shm_runtime::SessionExt;
use zenoh::{Config, Wait};

fn main() -> Result<(), Box<dyn std::error::Error + Send + Sync>> {
    let args: Vec<String> = std::env::args().collect();
    let [_, endpoint, count] = args.as_slice() else {
        return Err("usage: interop_subscriber <connect endpoint> <count>".into());
    };
    let count: usize = count.parse()?;
    let mut config = Config::default();
    config.insert_json5("mode", "\"peer\"")?;
    config.insert_json5("scouting/multicast/enabled", "false")?;
    config.insert_json5("connect/endpoints", &format!("[\"{endpoint}\"]"))?;
    let session = zenoh::open(config).wait()?;
    let subscriber = session
        .declare_ros_subscriber::<Header>("interop/**")
        .wait()?;
    println!("ready");
    std::io::stdout().flush()?;

    for _ in 0..count {
        let sample = subscriber
            .recv_timeout(Duration::from_secs(20))?
            .ok_or("timed out waiting for Python")?;
        let key = sample.key_expr().to_owned();
        let kind = key.split('/').nth(1).unwrap_or_default();
        let value = match kind {
            "cloud" => sample.decode::<PointCloud2>().map(|m| point_cloud_json(&m)),
            "image" => sample.decode::<Image>().map(|m| image_json(&m)),
            "joints" => sample.decode::<JointState>().map(|m| joint_state_json(&m)),
            "header" => sample.decode::<Header>().map(|m| header_json(&m)),
            "battery" => sample.decode::<Battery>().map(|m| battery_json(&m)),
            other => return Err(format!("unexpected key {other}").into()),
        };
        let line = match value {
            Ok(value) => json!({"key": key, "value": value}),
            Err(e) => json!({"key": key, "error": e.to_string()}),
        };
        println!("{line}");
        std::io::stdout().flush()?;
    }
    Ok(())
}
