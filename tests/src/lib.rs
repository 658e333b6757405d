//! Message definitions shared by the golden tests, property tests, fuzz corpus
//! replay and benchmarks. They mirror the ROS 2 interfaces field for field, so their
//! bytes and type hashes can be compared with rosidl / rosbags output.

pub mod msgs {
    //! Hand-written ROS 2 standard messages.
    use shm_cdr::RosMessage;
    use std::borrow::Cow;

    /// builtin_interfaces/msg/Time
    #[derive(RosMessage, Debug, Clone, Copy, Default, PartialEq, arbitrary::Arbitrary)]
    #[ros(type_name = "builtin_interfaces/msg/Time")]
    #[repr(C)] // field order in memory = CDR order: sequences copy in bulk
    pub struct Time {
        pub sec: i32,
        pub nanosec: u32,
    }

    /// std_msgs/msg/Header
    #[derive(RosMessage, Debug, Clone, Default, PartialEq)]
    #[ros(type_name = "std_msgs/msg/Header")]
    pub struct Header {
        pub stamp: Time,
        pub frame_id: String,
    }

    /// std_msgs/msg/Header, borrowing its frame id from the input.
    #[derive(RosMessage, Debug, Clone, Default, PartialEq)]
    #[ros(type_name = "std_msgs/msg/Header")]
    pub struct HeaderRef<'a> {
        pub stamp: Time,
        pub frame_id: &'a str,
    }

    /// std_msgs/msg/String
    #[derive(RosMessage, Debug, Clone, Default, PartialEq)]
    #[ros(type_name = "std_msgs/msg/String")]
    pub struct StringMsg {
        pub data: String,
    }

    /// std_msgs/msg/Char (.msg `char` is uint8 on the wire and in the hash)
    #[derive(RosMessage, Debug, Clone, Default, PartialEq)]
    #[ros(type_name = "std_msgs/msg/Char")]
    pub struct Char {
        #[ros(char)]
        pub data: u8,
    }

    /// std_msgs/msg/Byte
    #[derive(RosMessage, Debug, Clone, Default, PartialEq)]
    #[ros(type_name = "std_msgs/msg/Byte")]
    pub struct Byte {
        #[ros(byte)]
        pub data: u8,
    }

    /// std_msgs/msg/Empty
    #[derive(RosMessage, Debug, Clone, Default, PartialEq)]
    #[ros(type_name = "std_msgs/msg/Empty")]
    pub struct Empty;

    /// sensor_msgs/msg/Image
    #[derive(RosMessage, Debug, Clone, Default, PartialEq)]
    #[ros(type_name = "sensor_msgs/msg/Image")]
    pub struct Image {
        pub header: Header,
        pub height: u32,
        pub width: u32,
        pub encoding: String,
        pub is_bigendian: u8,
        pub step: u32,
        pub data: Vec<u8>,
    }

    /// sensor_msgs/msg/Image, borrowing strings and pixels from the input.
    #[derive(RosMessage, Debug, Clone, Default, PartialEq)]
    #[ros(type_name = "sensor_msgs/msg/Image")]
    pub struct ImageRef<'a> {
        pub header: HeaderRef<'a>,
        pub height: u32,
        pub width: u32,
        pub encoding: Cow<'a, str>,
        pub is_bigendian: u8,
        pub step: u32,
        pub data: &'a [u8],
    }

    /// sensor_msgs/msg/PointField
    #[derive(RosMessage, Debug, Clone, Default, PartialEq)]
    #[ros(type_name = "sensor_msgs/msg/PointField")]
    pub struct PointField {
        pub name: String,
        pub offset: u32,
        pub datatype: u8,
        pub count: u32,
    }

    /// sensor_msgs/msg/PointCloud2
    #[derive(RosMessage, Debug, Clone, Default, PartialEq)]
    #[ros(type_name = "sensor_msgs/msg/PointCloud2")]
    pub struct PointCloud2 {
        pub header: Header,
        pub height: u32,
        pub width: u32,
        pub fields: Vec<PointField>,
        pub is_bigendian: bool,
        pub point_step: u32,
        pub row_step: u32,
        pub data: Vec<u8>,
        pub is_dense: bool,
    }

    /// sensor_msgs/msg/PointCloud2, borrowing its point data from the input.
    #[derive(RosMessage, Debug, Clone, Default, PartialEq)]
    #[ros(type_name = "sensor_msgs/msg/PointCloud2")]
    pub struct PointCloud2Ref<'a> {
        pub header: HeaderRef<'a>,
        pub height: u32,
        pub width: u32,
        pub fields: Vec<PointField>,
        pub is_bigendian: bool,
        pub point_step: u32,
        pub row_step: u32,
        pub data: &'a [u8],
        pub is_dense: bool,
    }

    /// sensor_msgs/msg/JointState, borrowing joint names from the input.
    #[derive(RosMessage, Debug, Clone, Default, PartialEq)]
    #[ros(type_name = "sensor_msgs/msg/JointState")]
    pub struct JointStateRef<'a> {
        pub header: HeaderRef<'a>,
        pub name: Vec<&'a str>,
        pub position: Vec<f64>,
        pub velocity: Vec<f64>,
        pub effort: Vec<f64>,
    }

    /// sensor_msgs/msg/JointState
    #[derive(RosMessage, Debug, Clone, Default, PartialEq)]
    #[ros(type_name = "sensor_msgs/msg/JointState")]
    pub struct JointState {
        pub header: Header,
        pub name: Vec<String>,
        pub position: Vec<f64>,
        pub velocity: Vec<f64>,
        pub effort: Vec<f64>,
    }

    /// geometry_msgs/msg/Point
    #[derive(RosMessage, Debug, Clone, Copy, Default, PartialEq, arbitrary::Arbitrary)]
    #[ros(type_name = "geometry_msgs/msg/Point")]
    #[repr(C)] // field order in memory = CDR order: sequences copy in bulk
    pub struct Point {
        pub x: f64,
        pub y: f64,
        pub z: f64,
    }

    /// geometry_msgs/msg/Quaternion
    #[derive(RosMessage, Debug, Clone, Copy, Default, PartialEq, arbitrary::Arbitrary)]
    #[ros(type_name = "geometry_msgs/msg/Quaternion")]
    #[repr(C)] // field order in memory = CDR order: sequences copy in bulk
    pub struct Quaternion {
        pub x: f64,
        pub y: f64,
        pub z: f64,
        pub w: f64,
    }

    /// geometry_msgs/msg/Pose
    #[derive(RosMessage, Debug, Clone, Copy, Default, PartialEq, arbitrary::Arbitrary)]
    #[ros(type_name = "geometry_msgs/msg/Pose")]
    #[repr(C)] // field order in memory = CDR order: sequences copy in bulk
    pub struct Pose {
        pub position: Point,
        pub orientation: Quaternion,
    }

    /// geometry_msgs/msg/PoseArray
    #[derive(RosMessage, Debug, Clone, Default, PartialEq)]
    #[ros(type_name = "geometry_msgs/msg/PoseArray")]
    pub struct PoseArray {
        pub header: Header,
        pub poses: Vec<Pose>,
    }
}

pub mod samples {
    //! Deterministic sample messages of realistic sizes, for benchmarks and tests.
    use crate::msgs::*;

    fn header(frame_id: &str) -> Header {
        Header {
            stamp: Time {
                sec: 1_700_000_000,
                nanosec: 123_456_789,
            },
            frame_id: frame_id.into(),
        }
    }

    /// An XYZ+intensity cloud (16-byte points) of about `bytes` bytes of point data.
    pub fn point_cloud(bytes: usize) -> PointCloud2 {
        let point_step = 16;
        let width = (bytes / point_step) as u32;
        let field = |name: &str, offset| PointField {
            name: name.into(),
            offset,
            datatype: 7, // FLOAT32
            count: 1,
        };
        PointCloud2 {
            header: header("lidar"),
            height: 1,
            width,
            fields: vec![
                field("x", 0),
                field("y", 4),
                field("z", 8),
                field("intensity", 12),
            ],
            is_bigendian: false,
            point_step: point_step as u32,
            row_step: width * point_step as u32,
            data: (0..width as usize * point_step)
                .map(|i| (i * 31 % 251) as u8)
                .collect(),
            is_dense: true,
        }
    }

    /// A robot arm's joint state with `joints` joints.
    pub fn joint_state(joints: usize) -> JointState {
        JointState {
            header: header("base_link"),
            name: (0..joints).map(|i| format!("arm_joint_{i}")).collect(),
            position: (0..joints).map(|i| i as f64 * 0.1).collect(),
            velocity: (0..joints).map(|i| i as f64 * -0.01).collect(),
            effort: (0..joints).map(|i| i as f64 * 2.5).collect(),
        }
    }

    /// A pose array of `n` poses.
    pub fn pose_array(n: usize) -> PoseArray {
        PoseArray {
            header: header("map"),
            poses: (0..n)
                .map(|i| Pose {
                    position: Point {
                        x: i as f64,
                        y: i as f64 * 2.0,
                        z: 0.5,
                    },
                    orientation: Quaternion {
                        x: 0.0,
                        y: 0.0,
                        z: (i as f64).sin(),
                        w: (i as f64).cos(),
                    },
                })
                .collect(),
        }
    }
}

pub mod fuzzing {
    //! The bodies of the cargo-fuzz targets in `fuzz/`, kept here so that
    //! `cargo test` replays the committed corpus through exactly the same code.
    use arbitrary::Arbitrary;
    use shm_cdr::testing::check_roundtrip;
    use shm_cdr::{from_bytes, BoundedString, BoundedVec, BoundedWString, RosMessage, WString};

    use crate::msgs::*;

    /// Decode `data` as `T`; if that succeeds, the value must satisfy every
    /// invariant of `check_roundtrip`.
    fn decode_as<T>(data: &[u8])
    where
        T: shm_cdr::DecodeOwned + shm_cdr::CdrEncode + std::fmt::Debug,
    {
        let Ok(value) = from_bytes::<T>(data) else {
            return;
        };
        if let Err(why) = check_roundtrip(&value) {
            panic!("decoded {value:?}: {why}");
        }
    }

    /// Decode `data` as a borrowing `T`; if that succeeds, it must re-encode to
    /// exactly `encoded_size` bytes.
    fn decode_borrowed_as<'a, T>(data: &'a [u8])
    where
        T: shm_cdr::CdrDecode<'a> + shm_cdr::CdrEncode,
    {
        let Ok(value) = from_bytes::<T>(data) else {
            return;
        };
        let bytes = shm_cdr::to_vec(&value).expect("a decoded value re-encodes");
        assert_eq!(bytes.len(), shm_cdr::encoded_size(&value));
    }

    /// Target `decode`: arbitrary bytes into several message types, owned and
    /// borrowed. Must never panic, hang or over-allocate.
    pub fn decode(data: &[u8]) {
        decode_as::<Image>(data);
        decode_borrowed_as::<ImageRef>(data);
        decode_as::<PointCloud2>(data);
        decode_borrowed_as::<PointCloud2Ref>(data);
        decode_as::<JointState>(data);
        decode_borrowed_as::<JointStateRef>(data);
        decode_as::<PoseArray>(data);
        decode_as::<Everything>(data);
        decode_as::<Empty>(data);
    }

    /// Time + value; `#[repr(C)]` so sequences of it take the bulk path at phase 0.
    #[derive(RosMessage, Arbitrary, Debug, Clone, PartialEq)]
    #[ros(type_name = "fuzz_msgs/msg/Stamped")]
    #[repr(C)]
    pub struct Stamped {
        pub stamp: Time,
        pub value: f64,
    }

    /// Every kind of field, with mixed alignment.
    #[derive(RosMessage, Arbitrary, Debug, Clone, PartialEq)]
    #[ros(type_name = "fuzz_msgs/msg/Everything")]
    pub struct Everything {
        pub flag: bool,
        pub lead: u8,
        pub stamped: Vec<Stamped>,
        pub small: i16,
        pub text: String,
        pub texts: Vec<String>,
        pub bounded: BoundedString<6>,
        pub bounded_seq: BoundedVec<Stamped, 3>,
        pub wide: WString,
        pub wide_bounded: BoundedWString<3>,
        pub floats: Vec<f64>,
        pub bools: Vec<bool>,
        pub fixed: [Stamped; 2],
        pub odd: [u16; 3],
        pub poses: Vec<Pose>,
        pub bytes: Vec<u8>,
        pub tail: u8,
    }

    /// Target `roundtrip`: an arbitrary message must satisfy every invariant of
    /// `shm_cdr::testing::check_roundtrip` (exact size, garbage-proof padding, one
    /// byte short fails, decode(encode(x)) == x, both byte orders).
    pub fn roundtrip(data: &[u8]) {
        let mut u = arbitrary::Unstructured::new(data);
        if let Ok(msg) = Everything::arbitrary(&mut u) {
            if let Err(why) = check_roundtrip(&msg) {
                panic!("{why}");
            }
        }
    }
}
