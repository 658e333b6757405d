//! Shared by the interop programs (`interop_publisher`, `interop_subscriber`) and
//! `tests/interop/check.py`: the messages exchanged with Python and their
//! normalized JSON form, which both sides compute independently and compare.
//!
//! Normal form: structs are objects of their fields; `uint8[]` is
//! `{"len": n, "sha256": hex}`; other arrays are lists; `float32` is widened to
//! `float64` exactly.

use serde_json::{json, Value};
use sha2::{Digest, Sha256};
use shm_cdr::msgs::builtin_interfaces::Time;
use shm_cdr::msgs::sensor_msgs::{Image, JointState, PointCloud2, PointField};
use shm_cdr::msgs::std_msgs::Header;
use shm_cdr::{BoundedVec, RosMessage};

/// A custom nested message, known to Python through its .msg text
/// ([`BATTERY_MSG`]).
#[derive(RosMessage, Debug, Clone, PartialEq)]
#[ros(type_name = "interop_msgs/msg/Battery")]
pub struct Battery {
    /// Header.
    pub header: Header,
    /// Pack voltage.
    pub voltage: f32,
    /// Cell voltages.
    pub cells: BoundedVec<f32, 16>,
    /// Cell temperatures.
    pub temperatures: [f64; 3],
    /// Charging.
    pub charging: bool,
    /// Recent samples, nested.
    pub history: Vec<Time>,
}

/// The .msg definition of [`Battery`] for rosbags.
pub const BATTERY_MSG: &str = "std_msgs/Header header\nfloat32 voltage\nfloat32[<=16] cells\nfloat64[3] temperatures\nbool charging\nbuiltin_interfaces/Time[] history\n";

/// Normal form of a byte array.
pub fn bytes_json(data: &[u8]) -> Value {
    let digest = Sha256::digest(data);
    let hex: String = digest.iter().map(|b| format!("{b:02x}")).collect();
    json!({"len": data.len(), "sha256": hex})
}

fn f32s(values: &[f32]) -> Value {
    values.iter().map(|v| f64::from(*v)).collect()
}

/// Normal form of a Time.
pub fn time_json(t: &Time) -> Value {
    json!({"sec": t.sec, "nanosec": t.nanosec})
}

/// Normal form of a Header.
pub fn header_json(h: &Header) -> Value {
    json!({"stamp": time_json(&h.stamp), "frame_id": h.frame_id})
}

fn field_json(f: &PointField) -> Value {
    json!({"name": f.name, "offset": f.offset, "datatype": f.datatype, "count": f.count})
}

/// Normal form of a PointCloud2.
pub fn point_cloud_json(m: &PointCloud2) -> Value {
    json!({
        "header": header_json(&m.header), "height": m.height, "width": m.width,
        "fields": m.fields.iter().map(field_json).collect::<Vec<_>>(),
        "is_bigendian": m.is_bigendian, "point_step": m.point_step, "row_step": m.row_step,
        "data": bytes_json(&m.data), "is_dense": m.is_dense,
    })
}

/// Normal form of an Image.
pub fn image_json(m: &Image) -> Value {
    json!({
        "header": header_json(&m.header), "height": m.height, "width": m.width,
        "encoding": m.encoding, "is_bigendian": m.is_bigendian, "step": m.step,
        "data": bytes_json(&m.data),
    })
}

/// Normal form of a JointState.
pub fn joint_state_json(m: &JointState) -> Value {
    json!({
        "header": header_json(&m.header), "name": m.name,
        "position": m.position, "velocity": m.velocity, "effort": m.effort,
    })
}

/// Normal form of a Battery.
pub fn battery_json(m: &Battery) -> Value {
    json!({
        "header": header_json(&m.header), "voltage": f64::from(m.voltage), "cells": f32s(&m.cells),
        "temperatures": m.temperatures, "charging": m.charging,
        "history": m.history.iter().map(time_json).collect::<Vec<_>>(),
    })
}

/// The messages the Rust publisher sends, round `round`.
pub fn sample_messages(round: u32) -> (PointCloud2, Image, JointState, Header, Battery) {
    let header = |frame: &str| Header {
        stamp: Time {
            sec: 1_700_000_000 + round as i32,
            nanosec: 123_456_789,
        },
        frame_id: frame.into(),
    };
    let points = 65_536u32; // 1 MiB: above the SHM threshold
    let cloud = PointCloud2 {
        header: header("lidar"),
        height: 1,
        width: points,
        fields: crate::xyzi_fields(),
        is_bigendian: false,
        point_step: 16,
        row_step: points * 16,
        data: (0..points as usize * 16)
            .map(|i| (i * 7 + round as usize) as u8)
            .collect(),
        is_dense: true,
    };
    let image = Image {
        header: header("camera"),
        height: 480,
        width: 640,
        encoding: "rgb8".into(),
        is_bigendian: 0,
        step: 640 * 3,
        data: (0..640 * 480 * 3)
            .map(|i| (i % 251) as u8 ^ round as u8)
            .collect(),
    };
    let joints = JointState {
        header: header("base_link"),
        name: (0..6).map(|i| format!("joint_{i}")).collect(),
        position: (0..6)
            .map(|i| f64::from(i) * 0.25 + f64::from(round))
            .collect(),
        velocity: vec![0.5, -0.5, 1e-9, 0.0, -0.0, 1e300],
        effort: vec![],
    };
    let battery = Battery {
        header: header("battery"),
        voltage: 24.6,
        cells: vec![4.1, 4.1, 4.09, 4.11].into(),
        temperatures: [20.5, 21.0, -3.25],
        charging: round.is_multiple_of(2),
        history: (0..3).map(|i| Time { sec: i, nanosec: 7 }).collect(),
    };
    (cloud, image, joints, header("tf"), battery)
}
