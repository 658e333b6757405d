//! The same messages as the Rust peers want them: serde derives for `cdr` and
//! `cdr-encoding`, and `hiroz-cdr`'s `CdrSerialize` / `CdrDeserialize` /
//! `CdrSerializedSize` written as hiroz-codegen emits them. That means a bulk
//! `write_pod_slice` / `read_pod_slice` for sequences of "plain" element types
//! (primitives, and structs hiroz deems plain, made `repr(C)` + `Pod`) and an
//! element loop for everything else.
//!
//! Every peer gets its best path: `serde_bytes` for `uint8[]` fields (one
//! `write_all` instead of a serde call per byte), and hiroz's bulk path wherever
//! its code generator would use it.

use std::fmt::Debug;

use byteorder::ByteOrder;
use hiroz_cdr::{
    CdrBuffer, CdrDeserialize, CdrPlain, CdrReader, CdrSerialize, CdrSerializedSize, CdrWriter,
};
use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};

use crate::messages as ours;

/// What every Rust peer needs from a message type.
pub trait PeerMessage:
    Serialize
    + DeserializeOwned
    + CdrSerialize
    + CdrDeserialize
    + CdrSerializedSize
    + PartialEq
    + Debug
    + Clone
{
}

impl<T> PeerMessage for T where
    T: Serialize
        + DeserializeOwned
        + CdrSerialize
        + CdrDeserialize
        + CdrSerializedSize
        + PartialEq
        + Debug
        + Clone
{
}

/// Implements hiroz-cdr's three traits for a struct from its field list, the
/// way hiroz-codegen does. `one` fields go through the field type's own impl
/// (primitives, strings, nested messages, and sequences of non-plain elements
/// element by element); `bulk` fields are sequences of plain elements, written
/// as a u32 count and one `write_pod_slice`.
macro_rules! hiroz_message {
    ($name:ident { $($field:ident: $mode:ident),* $(,)? }) => {
        impl CdrSerialize for $name {
            fn cdr_serialize<BO: ByteOrder, B: CdrBuffer>(&self, w: &mut CdrWriter<'_, BO, B>) {
                $(hiroz_message!(@write $mode, w, self.$field);)*
            }
        }
        impl CdrDeserialize for $name {
            fn cdr_deserialize<'de, BO: ByteOrder>(
                r: &mut CdrReader<'de, BO>,
            ) -> hiroz_cdr::Result<Self> {
                Ok(Self { $($field: hiroz_message!(@read $mode, r),)* })
            }
        }
        impl CdrSerializedSize for $name {
            fn cdr_serialized_size(&self, mut pos: usize) -> usize {
                $(pos = hiroz_message!(@size $mode, pos, self.$field);)*
                pos
            }
        }
    };
    (@write one, $w:ident, $value:expr) => {
        CdrSerialize::cdr_serialize(&$value, $w)
    };
    (@write bulk, $w:ident, $value:expr) => {{
        $w.write_sequence_length($value.len());
        if !$value.is_empty() {
            $w.write_pod_slice(&$value);
        }
    }};
    (@read one, $r:ident) => {
        CdrDeserialize::cdr_deserialize($r)?
    };
    (@read bulk, $r:ident) => {{
        let count = $r.read_sequence_length()?;
        if count > 0 {
            $r.read_pod_slice(count)?
        } else {
            Vec::new()
        }
    }};
    (@size one, $pos:ident, $value:expr) => {
        CdrSerializedSize::cdr_serialized_size(&$value, $pos)
    };
    (@size bulk, $pos:ident, $value:expr) => {{
        // hiroz-codegen's O(1) size: u32 count, then Rust's alignment and size.
        let mut pos = $pos + (4 - $pos % 4) % 4 + 4;
        if let Some(first) = $value.first() {
            let align = std::mem::align_of_val(first);
            pos += (align - pos % align) % align + $value.len() * std::mem::size_of_val(first);
        }
        pos
    }};
}

/// builtin_interfaces/msg/Time
#[derive(
    Serialize,
    Deserialize,
    Debug,
    Clone,
    Copy,
    Default,
    PartialEq,
    bytemuck::Pod,
    bytemuck::Zeroable,
)]
#[repr(C)]
pub struct Time {
    pub sec: i32,
    pub nanosec: u32,
}
hiroz_message!(Time {
    sec: one,
    nanosec: one
});
// SAFETY: `Time` is `Pod` (two 4-byte integers, no padding, every bit pattern
// valid), which is all `CdrPlain` needs for memory safety; its CDR layout equals
// its memory layout on little-endian hosts.
unsafe impl CdrPlain for Time {}

/// std_msgs/msg/Header
#[derive(Serialize, Deserialize, Debug, Clone, Default, PartialEq)]
pub struct Header {
    pub stamp: Time,
    pub frame_id: String,
}
hiroz_message!(Header {
    stamp: one,
    frame_id: one
});

/// sensor_msgs/msg/PointField
#[derive(Serialize, Deserialize, Debug, Clone, Default, PartialEq)]
pub struct PointField {
    pub name: String,
    pub offset: u32,
    pub datatype: u8,
    pub count: u32,
}
hiroz_message!(PointField {
    name: one,
    offset: one,
    datatype: one,
    count: one
});

/// sensor_msgs/msg/PointCloud2
#[derive(Serialize, Deserialize, Debug, Clone, Default, PartialEq)]
pub struct PointCloud2 {
    pub header: Header,
    pub height: u32,
    pub width: u32,
    pub fields: Vec<PointField>,
    pub is_bigendian: bool,
    pub point_step: u32,
    pub row_step: u32,
    #[serde(with = "serde_bytes")]
    pub data: Vec<u8>,
    pub is_dense: bool,
}
hiroz_message!(PointCloud2 {
    header: one,
    height: one,
    width: one,
    fields: one,
    is_bigendian: one,
    point_step: one,
    row_step: one,
    data: bulk,
    is_dense: one,
});

/// sensor_msgs/msg/Image
#[derive(Serialize, Deserialize, Debug, Clone, Default, PartialEq)]
pub struct Image {
    pub header: Header,
    pub height: u32,
    pub width: u32,
    pub encoding: String,
    pub is_bigendian: u8,
    pub step: u32,
    #[serde(with = "serde_bytes")]
    pub data: Vec<u8>,
}
hiroz_message!(Image {
    header: one,
    height: one,
    width: one,
    encoding: one,
    is_bigendian: one,
    step: one,
    data: bulk,
});

/// sensor_msgs/msg/JointState
#[derive(Serialize, Deserialize, Debug, Clone, Default, PartialEq)]
pub struct JointState {
    pub header: Header,
    pub name: Vec<String>,
    pub position: Vec<f64>,
    pub velocity: Vec<f64>,
    pub effort: Vec<f64>,
}
hiroz_message!(JointState {
    header: one,
    name: one,
    position: bulk,
    velocity: bulk,
    effort: bulk,
});

/// geometry_msgs/msg/Point
#[derive(
    Serialize,
    Deserialize,
    Debug,
    Clone,
    Copy,
    Default,
    PartialEq,
    bytemuck::Pod,
    bytemuck::Zeroable,
)]
#[repr(C)]
pub struct Point {
    pub x: f64,
    pub y: f64,
    pub z: f64,
}
hiroz_message!(Point {
    x: one,
    y: one,
    z: one
});
// SAFETY: `Pod` (three f64, no padding); CDR layout equals memory layout.
unsafe impl CdrPlain for Point {}

/// geometry_msgs/msg/Quaternion
#[derive(
    Serialize,
    Deserialize,
    Debug,
    Clone,
    Copy,
    Default,
    PartialEq,
    bytemuck::Pod,
    bytemuck::Zeroable,
)]
#[repr(C)]
pub struct Quaternion {
    pub x: f64,
    pub y: f64,
    pub z: f64,
    pub w: f64,
}
hiroz_message!(Quaternion {
    x: one,
    y: one,
    z: one,
    w: one
});
// SAFETY: `Pod` (four f64, no padding); CDR layout equals memory layout.
unsafe impl CdrPlain for Quaternion {}

/// geometry_msgs/msg/Pose
#[derive(
    Serialize,
    Deserialize,
    Debug,
    Clone,
    Copy,
    Default,
    PartialEq,
    bytemuck::Pod,
    bytemuck::Zeroable,
)]
#[repr(C)]
pub struct Pose {
    pub position: Point,
    pub orientation: Quaternion,
}
hiroz_message!(Pose {
    position: one,
    orientation: one
});
// SAFETY: `Pod` (seven f64, no padding); CDR layout equals memory layout.
unsafe impl CdrPlain for Pose {}

/// geometry_msgs/msg/PoseArray
#[derive(Serialize, Deserialize, Debug, Clone, Default, PartialEq)]
pub struct PoseArray {
    pub header: Header,
    pub poses: Vec<Pose>,
}
hiroz_message!(PoseArray {
    header: one,
    poses: bulk
});

/// bench_msgs/msg/StringList
#[derive(Serialize, Deserialize, Debug, Clone, Default, PartialEq)]
pub struct StringList {
    pub header: Header,
    pub names: Vec<String>,
}
hiroz_message!(StringList {
    header: one,
    names: one
});

/// bench_msgs/msg/StampedValue
#[derive(
    Serialize,
    Deserialize,
    Debug,
    Clone,
    Copy,
    Default,
    PartialEq,
    bytemuck::Pod,
    bytemuck::Zeroable,
)]
#[repr(C)]
pub struct StampedValue {
    pub stamp: Time,
    pub value: f64,
}
hiroz_message!(StampedValue {
    stamp: one,
    value: one
});
// SAFETY: `Pod` (Time's 8 bytes then an f64 at offset 8: no padding, every bit
// pattern valid), which is all memory safety needs. The CDR half of hiroz's
// contract does NOT hold: after a u32 count the CDR element starts at offset 4
// with 4 bytes of padding before `value`. This impl exists to show what the bulk
// path does with such a type (see `StampedValuesBulk`).
unsafe impl CdrPlain for StampedValue {}

/// bench_msgs/msg/StampedValues, element by element (hiroz-codegen's current
/// plainness rule sees mixed alignments in `StampedValue` and loops).
#[derive(Serialize, Deserialize, Debug, Clone, Default, PartialEq)]
pub struct StampedValues {
    pub header: Header,
    pub samples: Vec<StampedValue>,
}
hiroz_message!(StampedValues {
    header: one,
    samples: one
});

/// bench_msgs/msg/StampedValues through hiroz-cdr's bulk path, as a code
/// generator that only compares direct primitive fields' alignments emits it.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct StampedValuesBulk {
    pub header: Header,
    pub samples: Vec<StampedValue>,
}
hiroz_message!(StampedValuesBulk {
    header: one,
    samples: bulk
});

// ---- from our types, field by field --------------------------------------------

impl From<&shm_cdr::msgs::builtin_interfaces::Time> for Time {
    fn from(t: &shm_cdr::msgs::builtin_interfaces::Time) -> Self {
        Time {
            sec: t.sec,
            nanosec: t.nanosec,
        }
    }
}

impl From<&shm_cdr::msgs::std_msgs::Header> for Header {
    fn from(h: &shm_cdr::msgs::std_msgs::Header) -> Self {
        Header {
            stamp: (&h.stamp).into(),
            frame_id: h.frame_id.clone(),
        }
    }
}

impl From<&shm_cdr::msgs::sensor_msgs::PointCloud2> for PointCloud2 {
    fn from(m: &shm_cdr::msgs::sensor_msgs::PointCloud2) -> Self {
        PointCloud2 {
            header: (&m.header).into(),
            height: m.height,
            width: m.width,
            fields: m
                .fields
                .iter()
                .map(|f| PointField {
                    name: f.name.clone(),
                    offset: f.offset,
                    datatype: f.datatype,
                    count: f.count,
                })
                .collect(),
            is_bigendian: m.is_bigendian,
            point_step: m.point_step,
            row_step: m.row_step,
            data: m.data.clone(),
            is_dense: m.is_dense,
        }
    }
}

impl From<&shm_cdr::msgs::sensor_msgs::Image> for Image {
    fn from(m: &shm_cdr::msgs::sensor_msgs::Image) -> Self {
        Image {
            header: (&m.header).into(),
            height: m.height,
            width: m.width,
            encoding: m.encoding.clone(),
            is_bigendian: m.is_bigendian,
            step: m.step,
            data: m.data.clone(),
        }
    }
}

impl From<&shm_cdr::msgs::sensor_msgs::JointState> for JointState {
    fn from(m: &shm_cdr::msgs::sensor_msgs::JointState) -> Self {
        JointState {
            header: (&m.header).into(),
            name: m.name.clone(),
            position: m.position.clone(),
            velocity: m.velocity.clone(),
            effort: m.effort.clone(),
        }
    }
}

impl From<&shm_cdr::msgs::geometry_msgs::PoseArray> for PoseArray {
    fn from(m: &shm_cdr::msgs::geometry_msgs::PoseArray) -> Self {
        PoseArray {
            header: (&m.header).into(),
            poses: m
                .poses
                .iter()
                .map(|p| Pose {
                    position: Point {
                        x: p.position.x,
                        y: p.position.y,
                        z: p.position.z,
                    },
                    orientation: Quaternion {
                        x: p.orientation.x,
                        y: p.orientation.y,
                        z: p.orientation.z,
                        w: p.orientation.w,
                    },
                })
                .collect(),
        }
    }
}

impl From<&ours::StringList> for StringList {
    fn from(m: &ours::StringList) -> Self {
        StringList {
            header: (&m.header).into(),
            names: m.names.clone(),
        }
    }
}

impl From<&ours::StampedValues> for StampedValues {
    fn from(m: &ours::StampedValues) -> Self {
        StampedValues {
            header: (&m.header).into(),
            samples: m
                .samples
                .iter()
                .map(|s| StampedValue {
                    stamp: (&s.stamp).into(),
                    value: s.value,
                })
                .collect(),
        }
    }
}

impl From<&StampedValues> for StampedValuesBulk {
    fn from(m: &StampedValues) -> Self {
        StampedValuesBulk {
            header: m.header.clone(),
            samples: m.samples.clone(),
        }
    }
}
