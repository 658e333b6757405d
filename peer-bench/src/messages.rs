//! The messages compared, as shm-cdr types, with the sizes the comparison uses.

use shm_cdr::msgs::builtin_interfaces::Time;
use shm_cdr::msgs::geometry_msgs::PoseArray;
use shm_cdr::msgs::sensor_msgs::{
    Image, ImageRef, JointState, JointStateRef, PointCloud2, PointCloud2Ref,
};
use shm_cdr::msgs::std_msgs::{Header, HeaderRef};
use shm_cdr::{CdrDecode, CdrEncode, DecodeOwned, RosMessage};
use shm_cdr_tests::samples as shared;

use crate::mirror;

pub use shm_cdr_tests::msgs::{StringList, StringListCompact, StringListRef};

/// A struct whose CDR layout differs from its memory layout inside a sequence:
/// after the u32 count the first `stamp` starts at offset 4 and `value` needs
/// 4 bytes of padding, while in memory the element is 16 packed bytes.
#[derive(RosMessage, Debug, Clone, Copy, Default, PartialEq)]
#[ros(type_name = "bench_msgs/msg/StampedValue")]
pub struct StampedValue {
    /// When.
    pub stamp: Time,
    /// What.
    pub value: f64,
}

/// A sequence of [`StampedValue`]s (`{Time stamp; float64 value}[]`).
#[derive(RosMessage, Debug, Clone, Default, PartialEq)]
#[ros(type_name = "bench_msgs/msg/StampedValues")]
pub struct StampedValues {
    /// Header.
    pub header: Header,
    /// The samples.
    pub samples: Vec<StampedValue>,
}

/// One message type of the comparison: our type, its borrowing variant, and
/// the equivalent value for the peers.
pub trait Message: CdrEncode + DecodeOwned + RosMessage + Clone + 'static {
    /// The variant that borrows strings and byte arrays from the input.
    type Ref<'a>: CdrDecode<'a>;
    /// The type the Rust peers encode (serde derive plus hiroz-cdr's traits).
    type Mirror: mirror::PeerMessage;
    /// The same value as a peer type, built field by field (never by decoding
    /// our bytes, so a peer's decoder cannot hide a bug in its encoder).
    fn mirror(&self) -> Self::Mirror;
    /// The Fast-CDR shim's entry points for this message.
    #[cfg(fastcdr)]
    fn fast_cdr() -> &'static crate::fastcdr::Kind;
}

/// A named message value.
#[derive(Debug, Clone)]
pub struct Sample<M> {
    /// Name in tables and charts, e.g. `PointCloud2 1MiB`.
    pub name: &'static str,
    /// The value.
    pub msg: M,
}

macro_rules! message {
    ($ty:ty, $borrowed:ty, $mirror:ty, $fast:ident) => {
        impl Message for $ty {
            type Ref<'a> = $borrowed;
            type Mirror = $mirror;
            fn mirror(&self) -> $mirror {
                <$mirror>::from(self)
            }
            #[cfg(fastcdr)]
            fn fast_cdr() -> &'static crate::fastcdr::Kind {
                crate::fastcdr::$fast()
            }
        }
    };
}

message!(Header, HeaderRef<'a>, mirror::Header, header);
message!(
    PointCloud2,
    PointCloud2Ref<'a>,
    mirror::PointCloud2,
    point_cloud2
);
message!(Image, ImageRef<'a>, mirror::Image, image);
message!(
    JointState,
    JointStateRef<'a>,
    mirror::JointState,
    joint_state
);
// Nothing in a PoseArray can be borrowed except the frame id.
message!(PoseArray, PoseArray, mirror::PoseArray, pose_array);
message!(
    StringList,
    StringListRef<'a>,
    mirror::StringList,
    string_list
);
message!(
    StampedValues,
    StampedValues,
    mirror::StampedValues,
    stamped_values
);

/// The message values of the comparison.
pub mod samples {
    use super::*;

    fn header(frame_id: &str) -> Header {
        Header {
            stamp: Time {
                sec: 1_700_000_000,
                nanosec: 123_456_789,
            },
            frame_id: frame_id.into(),
        }
    }

    /// A small header: the fixed cost of a 1 kHz control loop message.
    pub fn header_small() -> Sample<Header> {
        Sample {
            name: "Header",
            msg: header("base_link"),
        }
    }

    /// XYZI point clouds of 1 MiB and 8 MiB of point data.
    pub fn point_clouds() -> [Sample<PointCloud2>; 2] {
        [
            Sample {
                name: "PointCloud2 1MiB",
                msg: shared::point_cloud(1 << 20),
            },
            Sample {
                name: "PointCloud2 8MiB",
                msg: shared::point_cloud(8 << 20),
            },
        ]
    }

    /// A 1920×1080 rgb8 image.
    pub fn image_1080p() -> Sample<Image> {
        let (width, height) = (1920u32, 1080u32);
        let step = width * 3;
        Sample {
            name: "Image 1080p rgb8",
            msg: Image {
                header: header("camera"),
                height,
                width,
                encoding: "rgb8".into(),
                is_bigendian: 0,
                step,
                data: (0..(step * height) as usize)
                    .map(|i| (i * 7 % 253) as u8)
                    .collect(),
            },
        }
    }

    /// A 40-joint robot arm.
    pub fn joint_state() -> Sample<JointState> {
        Sample {
            name: "JointState 40",
            msg: shared::joint_state(40),
        }
    }

    /// 10 000 poses.
    pub fn pose_array() -> Sample<PoseArray> {
        Sample {
            name: "PoseArray 10k",
            msg: shared::pose_array(10_000),
        }
    }

    /// 1 000 short strings.
    pub fn string_list() -> Sample<StringList> {
        Sample {
            name: "StringList 1000",
            msg: shared::string_list(1000),
        }
    }

    /// 1 000 `{Time stamp; float64 value}` elements. The frame id's length puts
    /// the sequence's first element at body offset 28, 4 mod 8: the phase where
    /// CDR layout and memory layout differ.
    pub fn stamped_values() -> Sample<StampedValues> {
        Sample {
            name: "StampedValues 1000",
            msg: StampedValues {
                header: header("timeseries"),
                samples: (0..1000)
                    .map(|i| StampedValue {
                        stamp: Time {
                            sec: 1_700_000_000 + i,
                            nanosec: (i as u32) * 1000,
                        },
                        value: f64::from(i) * 0.25,
                    })
                    .collect(),
            },
        }
    }
}
