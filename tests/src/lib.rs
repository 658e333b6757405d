//! Message definitions shared by the golden tests, property tests, fuzz corpus
//! replay and benchmarks. They mirror the ROS 2 interfaces field for field, so their
//! bytes and type hashes can be compared with rosidl / rosbags output.

pub mod msgs {
    //! Hand-written ROS 2 standard messages.
    use shm_cdr::RosMessage;
    use std::borrow::Cow;

    /// builtin_interfaces/msg/Time
    #[derive(RosMessage, Debug, Clone, Copy, Default, PartialEq)]
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
    #[derive(RosMessage, Debug, Clone, Copy, Default, PartialEq)]
    #[ros(type_name = "geometry_msgs/msg/Point")]
    #[repr(C)] // field order in memory = CDR order: sequences copy in bulk
    pub struct Point {
        pub x: f64,
        pub y: f64,
        pub z: f64,
    }

    /// geometry_msgs/msg/Quaternion
    #[derive(RosMessage, Debug, Clone, Copy, Default, PartialEq)]
    #[ros(type_name = "geometry_msgs/msg/Quaternion")]
    #[repr(C)] // field order in memory = CDR order: sequences copy in bulk
    pub struct Quaternion {
        pub x: f64,
        pub y: f64,
        pub z: f64,
        pub w: f64,
    }

    /// geometry_msgs/msg/Pose
    #[derive(RosMessage, Debug, Clone, Copy, Default, PartialEq)]
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
            fields: vec![field("x", 0), field("y", 4), field("z", 8), field("intensity", 12)],
            is_bigendian: false,
            point_step: point_step as u32,
            row_step: width * point_step as u32,
            data: (0..width as usize * point_step).map(|i| (i * 31 % 251) as u8).collect(),
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
