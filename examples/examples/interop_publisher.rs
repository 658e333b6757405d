//! Interop, Rust → Python: publish standard and custom messages as rmw_zenoh
//! topics (the big ones through shared memory) to a peer, and write what was sent,
//! in normalized JSON, for `tests/interop/check.py` to compare with what rosbags
//! decodes on the other side.
//!
//! `interop_publisher <connect endpoint> <expected.json> [rounds]`

use std::time::Duration;

use serde_json::json;
use shm_cdr::RosMessage;
use shm_cdr_examples::interop::*;
use shm_runtime::ShmOptions;
use shm_runtime::{PublishOutcome, RosNode, RosPublisher, ShmConfig, ShmContext};
use zenoh::{Config, Wait};

fn record<T: RosMessage>(
    sent: &mut Vec<serde_json::Value>,
    publisher: &RosPublisher<T>,
    topic: &str,
    outcome: PublishOutcome,
    value: serde_json::Value,
) {
    sent.push(json!({
        "topic": topic,
        "type": T::TYPE_NAME,
        "key": publisher.key_expr(),
        "gid": format!("{:?}", publisher.gid().unwrap_or(shm_runtime::rmw::Gid([0; 16]))),
        "kind": format!("{:?}", outcome.kind),
        "seq": outcome.sequence_number,
        "value": value,
    }));
}

fn main() -> Result<(), Box<dyn std::error::Error + Send + Sync>> {
    let args: Vec<String> = std::env::args().collect();
    let (endpoint, expected) = match args.as_slice() {
        [_, endpoint, expected, ..] => (endpoint.clone(), expected.clone()),
        _ => {
            return Err(
                "usage: interop_publisher <connect endpoint> <expected.json> [rounds]".into(),
            )
        }
    };
    let rounds: u32 = args.get(3).map_or(Ok(2), |r| r.parse())?;

    let mut config = Config::default();
    config.insert_json5("mode", "\"peer\"")?;
    config.insert_json5("scouting/multicast/enabled", "false")?;
    config.insert_json5("connect/endpoints", &format!("[\"{endpoint}\"]"))?;
    let session = zenoh::open(config).wait()?;
    let shm = ShmContext::new(ShmConfig::enabled().pool_size_at_most(16 << 20))?;
    let node = RosNode::builder(&session, "interop_talker").wait()?;

    let clouds = node.declare_publisher("/points").shm(&shm).wait()?;
    let images = node.declare_publisher("/camera/image").shm(&shm).wait()?;
    let joints = node.declare_publisher("/joint_states").shm(&shm).wait()?;
    let headers = node.declare_publisher("/header").shm(&shm).wait()?;
    let batteries = node.declare_publisher("/battery").shm(&shm).wait()?;
    for matched in [
        clouds.wait_for_subscribers(Duration::from_secs(10)),
        images.wait_for_subscribers(Duration::from_secs(10)),
        joints.wait_for_subscribers(Duration::from_secs(10)),
        headers.wait_for_subscribers(Duration::from_secs(10)),
        batteries.wait_for_subscribers(Duration::from_secs(10)),
    ] {
        if !matched {
            return Err("the Python subscriber did not show up".into());
        }
    }

    let mut sent = Vec::new();
    for round in 0..rounds {
        let (cloud, image, joint_state, header, battery) = sample_messages(round);
        let o = clouds.publish(&cloud).wait()?;
        record(&mut sent, &clouds, "/points", o, point_cloud_json(&cloud));
        let o = images.publish(&image).wait()?;
        record(&mut sent, &images, "/camera/image", o, image_json(&image));
        let o = joints.publish(&joint_state).wait()?;
        record(
            &mut sent,
            &joints,
            "/joint_states",
            o,
            joint_state_json(&joint_state),
        );
        let o = headers.publish(&header).wait()?;
        record(&mut sent, &headers, "/header", o, header_json(&header));
        let o = batteries.publish(&battery).wait()?;
        record(&mut sent, &batteries, "/battery", o, battery_json(&battery));
    }
    std::fs::write(&expected, serde_json::to_string_pretty(&sent)?)?;
    // Keep the SHM buffers and the session alive until Python has read them.
    std::thread::sleep(Duration::from_secs(2));
    Ok(())
}
