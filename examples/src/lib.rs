//! Runnable examples: `cargo run -p shm-cdr-examples --example <name>`.
//!
//! [`loopback_pair`] opens two Zenoh peer sessions in this process, connected over
//! TCP on 127.0.0.1 with multicast scouting off: no router and no network needed.

pub mod interop;

use shm_cdr::msgs::sensor_msgs::PointField;
use zenoh::{Config, Session, Wait};

/// Two peer sessions: the first listens on `tcp/127.0.0.1:<port>`, the second
/// connects to it.
pub fn loopback_pair(port: u16) -> zenoh::Result<(Session, Session)> {
    let config = |key: &str| -> zenoh::Result<Config> {
        let mut c = Config::default();
        c.insert_json5("mode", "\"peer\"")?;
        c.insert_json5("scouting/multicast/enabled", "false")?;
        c.insert_json5(key, &format!("[\"tcp/127.0.0.1:{port}\"]"))?;
        Ok(c)
    };
    let publisher_side = zenoh::open(config("listen/endpoints")?).wait()?;
    let subscriber_side = zenoh::open(config("connect/endpoints")?).wait()?;
    Ok((publisher_side, subscriber_side))
}

/// The layout of a 16-byte point: `x`, `y`, `z`, `intensity` as `float32`.
pub fn xyzi_fields() -> Vec<PointField> {
    ["x", "y", "z", "intensity"]
        .iter()
        .enumerate()
        .map(|(i, name)| PointField {
            name: (*name).into(),
            offset: 4 * i as u32,
            datatype: PointField::FLOAT32,
            count: 1,
        })
        .collect()
}
