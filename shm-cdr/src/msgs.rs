//! Standard ROS 2 messages, written with `#[derive(RosMessage)]` (feature `msgs`).
//!
//! Field for field as in the ROS 2 interface packages, so bytes and type hashes are
//! rosidl's. Types whose memory layout can equal their CDR layout are `#[repr(C)]`,
//! so sequences of them are copied in bulk. `…Ref<'a>` variants borrow strings and
//! byte payloads from the input when decoding.

/// `builtin_interfaces`
pub mod builtin_interfaces {
    use crate::RosMessage;

    /// builtin_interfaces/msg/Time
    #[derive(RosMessage, Debug, Clone, Copy, Default, PartialEq, Eq, Hash)]
    #[cfg_attr(feature = "arbitrary", derive(arbitrary::Arbitrary))]
    #[ros(type_name = "builtin_interfaces/msg/Time", crate = "crate")]
    #[repr(C)]
    pub struct Time {
        /// Seconds since the epoch.
        pub sec: i32,
        /// Nanoseconds within the second.
        pub nanosec: u32,
    }

    /// builtin_interfaces/msg/Duration
    #[derive(RosMessage, Debug, Clone, Copy, Default, PartialEq, Eq, Hash)]
    #[cfg_attr(feature = "arbitrary", derive(arbitrary::Arbitrary))]
    #[ros(type_name = "builtin_interfaces/msg/Duration", crate = "crate")]
    #[repr(C)]
    pub struct Duration {
        /// Seconds.
        pub sec: i32,
        /// Nanoseconds.
        pub nanosec: u32,
    }
}

/// `std_msgs`
pub mod std_msgs {
    use super::builtin_interfaces::Time;
    use crate::RosMessage;

    /// std_msgs/msg/Header
    #[derive(RosMessage, Debug, Clone, Default, PartialEq)]
    #[cfg_attr(feature = "arbitrary", derive(arbitrary::Arbitrary))]
    #[ros(type_name = "std_msgs/msg/Header", crate = "crate")]
    pub struct Header {
        /// Acquisition time.
        pub stamp: Time,
        /// Coordinate frame.
        pub frame_id: std::string::String,
    }

    /// std_msgs/msg/Header borrowing its frame id.
    #[derive(RosMessage, Debug, Clone, Default, PartialEq)]
    #[cfg_attr(feature = "arbitrary", derive(arbitrary::Arbitrary))]
    #[ros(type_name = "std_msgs/msg/Header", crate = "crate")]
    pub struct HeaderRef<'a> {
        /// Acquisition time.
        pub stamp: Time,
        /// Coordinate frame.
        pub frame_id: &'a str,
    }

    /// std_msgs/msg/String
    #[derive(RosMessage, Debug, Clone, Default, PartialEq)]
    #[cfg_attr(feature = "arbitrary", derive(arbitrary::Arbitrary))]
    #[ros(type_name = "std_msgs/msg/String", crate = "crate")]
    pub struct String {
        /// The text.
        pub data: std::string::String,
    }

    /// std_msgs/msg/Empty
    #[derive(RosMessage, Debug, Clone, Copy, Default, PartialEq, Eq)]
    #[cfg_attr(feature = "arbitrary", derive(arbitrary::Arbitrary))]
    #[ros(type_name = "std_msgs/msg/Empty", crate = "crate")]
    pub struct Empty;

    /// std_msgs/msg/Char (.msg `char`: `uint8` on the wire and in the hash)
    #[derive(RosMessage, Debug, Clone, Copy, Default, PartialEq, Eq)]
    #[cfg_attr(feature = "arbitrary", derive(arbitrary::Arbitrary))]
    #[ros(type_name = "std_msgs/msg/Char", crate = "crate")]
    pub struct Char {
        /// The character.
        #[ros(char)]
        pub data: u8,
    }

    /// std_msgs/msg/Byte
    #[derive(RosMessage, Debug, Clone, Copy, Default, PartialEq, Eq)]
    #[cfg_attr(feature = "arbitrary", derive(arbitrary::Arbitrary))]
    #[ros(type_name = "std_msgs/msg/Byte", crate = "crate")]
    pub struct Byte {
        /// The byte.
        #[ros(byte)]
        pub data: u8,
    }
}

/// `geometry_msgs`
pub mod geometry_msgs {
    use super::std_msgs::Header;
    use crate::RosMessage;

    /// geometry_msgs/msg/Point
    #[derive(RosMessage, Debug, Clone, Copy, Default, PartialEq)]
    #[cfg_attr(feature = "arbitrary", derive(arbitrary::Arbitrary))]
    #[ros(type_name = "geometry_msgs/msg/Point", crate = "crate")]
    #[repr(C)]
    pub struct Point {
        /// x
        pub x: f64,
        /// y
        pub y: f64,
        /// z
        pub z: f64,
    }

    /// geometry_msgs/msg/Vector3
    #[derive(RosMessage, Debug, Clone, Copy, Default, PartialEq)]
    #[cfg_attr(feature = "arbitrary", derive(arbitrary::Arbitrary))]
    #[ros(type_name = "geometry_msgs/msg/Vector3", crate = "crate")]
    #[repr(C)]
    pub struct Vector3 {
        /// x
        pub x: f64,
        /// y
        pub y: f64,
        /// z
        pub z: f64,
    }

    /// geometry_msgs/msg/Quaternion
    #[derive(RosMessage, Debug, Clone, Copy, PartialEq)]
    #[cfg_attr(feature = "arbitrary", derive(arbitrary::Arbitrary))]
    #[ros(type_name = "geometry_msgs/msg/Quaternion", crate = "crate")]
    #[repr(C)]
    pub struct Quaternion {
        /// x
        pub x: f64,
        /// y
        pub y: f64,
        /// z
        pub z: f64,
        /// w
        pub w: f64,
    }

    impl Default for Quaternion {
        /// The identity rotation (w = 1), as in the .msg default.
        fn default() -> Self {
            Self {
                x: 0.0,
                y: 0.0,
                z: 0.0,
                w: 1.0,
            }
        }
    }

    /// geometry_msgs/msg/Pose
    #[derive(RosMessage, Debug, Clone, Copy, Default, PartialEq)]
    #[cfg_attr(feature = "arbitrary", derive(arbitrary::Arbitrary))]
    #[ros(type_name = "geometry_msgs/msg/Pose", crate = "crate")]
    #[repr(C)]
    pub struct Pose {
        /// Position.
        pub position: Point,
        /// Orientation.
        pub orientation: Quaternion,
    }

    /// geometry_msgs/msg/PoseArray
    #[derive(RosMessage, Debug, Clone, Default, PartialEq)]
    #[cfg_attr(feature = "arbitrary", derive(arbitrary::Arbitrary))]
    #[ros(type_name = "geometry_msgs/msg/PoseArray", crate = "crate")]
    pub struct PoseArray {
        /// Header.
        pub header: Header,
        /// The poses.
        pub poses: Vec<Pose>,
    }

    /// geometry_msgs/msg/Twist
    #[derive(RosMessage, Debug, Clone, Copy, Default, PartialEq)]
    #[cfg_attr(feature = "arbitrary", derive(arbitrary::Arbitrary))]
    #[ros(type_name = "geometry_msgs/msg/Twist", crate = "crate")]
    #[repr(C)]
    pub struct Twist {
        /// Linear velocity.
        pub linear: Vector3,
        /// Angular velocity.
        pub angular: Vector3,
    }
}

/// `sensor_msgs`
pub mod sensor_msgs {
    use std::borrow::Cow;

    use super::geometry_msgs::{Quaternion, Vector3};
    use super::std_msgs::{Header, HeaderRef};
    use crate::RosMessage;

    /// sensor_msgs/msg/PointField
    #[derive(RosMessage, Debug, Clone, Default, PartialEq)]
    #[cfg_attr(feature = "arbitrary", derive(arbitrary::Arbitrary))]
    #[ros(type_name = "sensor_msgs/msg/PointField", crate = "crate")]
    pub struct PointField {
        /// Field name.
        pub name: String,
        /// Byte offset in a point.
        pub offset: u32,
        /// Data type (`PointField::FLOAT32`, ...).
        pub datatype: u8,
        /// Elements in the field.
        pub count: u32,
    }

    impl PointField {
        /// `INT8`
        pub const INT8: u8 = 1;
        /// `UINT8`
        pub const UINT8: u8 = 2;
        /// `INT16`
        pub const INT16: u8 = 3;
        /// `UINT16`
        pub const UINT16: u8 = 4;
        /// `INT32`
        pub const INT32: u8 = 5;
        /// `UINT32`
        pub const UINT32: u8 = 6;
        /// `FLOAT32`
        pub const FLOAT32: u8 = 7;
        /// `FLOAT64`
        pub const FLOAT64: u8 = 8;
    }

    /// sensor_msgs/msg/PointCloud2
    #[derive(RosMessage, Debug, Clone, Default, PartialEq)]
    #[cfg_attr(feature = "arbitrary", derive(arbitrary::Arbitrary))]
    #[ros(type_name = "sensor_msgs/msg/PointCloud2", crate = "crate")]
    pub struct PointCloud2 {
        /// Header.
        pub header: Header,
        /// Rows.
        pub height: u32,
        /// Points per row.
        pub width: u32,
        /// Layout of a point.
        pub fields: Vec<PointField>,
        /// Byte order of the data.
        pub is_bigendian: bool,
        /// Bytes per point.
        pub point_step: u32,
        /// Bytes per row.
        pub row_step: u32,
        /// The points.
        pub data: Vec<u8>,
        /// No invalid points.
        pub is_dense: bool,
    }

    /// sensor_msgs/msg/PointCloud2 borrowing its strings and point data.
    #[derive(RosMessage, Debug, Clone, Default, PartialEq)]
    #[cfg_attr(feature = "arbitrary", derive(arbitrary::Arbitrary))]
    #[ros(type_name = "sensor_msgs/msg/PointCloud2", crate = "crate")]
    pub struct PointCloud2Ref<'a> {
        /// Header.
        pub header: HeaderRef<'a>,
        /// Rows.
        pub height: u32,
        /// Points per row.
        pub width: u32,
        /// Layout of a point.
        pub fields: Vec<PointField>,
        /// Byte order of the data.
        pub is_bigendian: bool,
        /// Bytes per point.
        pub point_step: u32,
        /// Bytes per row.
        pub row_step: u32,
        /// The points, borrowed from the input.
        pub data: &'a [u8],
        /// No invalid points.
        pub is_dense: bool,
    }

    /// sensor_msgs/msg/Image
    #[derive(RosMessage, Debug, Clone, Default, PartialEq)]
    #[cfg_attr(feature = "arbitrary", derive(arbitrary::Arbitrary))]
    #[ros(type_name = "sensor_msgs/msg/Image", crate = "crate")]
    pub struct Image {
        /// Header.
        pub header: Header,
        /// Rows.
        pub height: u32,
        /// Columns.
        pub width: u32,
        /// Pixel encoding, e.g. `rgb8`.
        pub encoding: String,
        /// Byte order of the data.
        pub is_bigendian: u8,
        /// Bytes per row.
        pub step: u32,
        /// The pixels.
        pub data: Vec<u8>,
    }

    /// sensor_msgs/msg/Image borrowing its strings and pixels.
    #[derive(RosMessage, Debug, Clone, Default, PartialEq)]
    #[cfg_attr(feature = "arbitrary", derive(arbitrary::Arbitrary))]
    #[ros(type_name = "sensor_msgs/msg/Image", crate = "crate")]
    pub struct ImageRef<'a> {
        /// Header.
        pub header: HeaderRef<'a>,
        /// Rows.
        pub height: u32,
        /// Columns.
        pub width: u32,
        /// Pixel encoding.
        pub encoding: Cow<'a, str>,
        /// Byte order of the data.
        pub is_bigendian: u8,
        /// Bytes per row.
        pub step: u32,
        /// The pixels, borrowed from the input.
        pub data: &'a [u8],
    }

    /// sensor_msgs/msg/LaserScan
    #[derive(RosMessage, Debug, Clone, Default, PartialEq)]
    #[cfg_attr(feature = "arbitrary", derive(arbitrary::Arbitrary))]
    #[ros(type_name = "sensor_msgs/msg/LaserScan", crate = "crate")]
    pub struct LaserScan {
        /// Header.
        pub header: Header,
        /// Start angle (rad).
        pub angle_min: f32,
        /// End angle (rad).
        pub angle_max: f32,
        /// Angular step (rad).
        pub angle_increment: f32,
        /// Time between measurements (s).
        pub time_increment: f32,
        /// Time between scans (s).
        pub scan_time: f32,
        /// Minimum range (m).
        pub range_min: f32,
        /// Maximum range (m).
        pub range_max: f32,
        /// Ranges (m).
        pub ranges: Vec<f32>,
        /// Intensities.
        pub intensities: Vec<f32>,
    }

    /// sensor_msgs/msg/Imu
    #[derive(RosMessage, Debug, Clone, Default, PartialEq)]
    #[cfg_attr(feature = "arbitrary", derive(arbitrary::Arbitrary))]
    #[ros(type_name = "sensor_msgs/msg/Imu", crate = "crate")]
    pub struct Imu {
        /// Header.
        pub header: Header,
        /// Orientation.
        pub orientation: Quaternion,
        /// Its covariance (row-major 3×3).
        pub orientation_covariance: [f64; 9],
        /// Angular velocity (rad/s).
        pub angular_velocity: Vector3,
        /// Its covariance.
        pub angular_velocity_covariance: [f64; 9],
        /// Linear acceleration (m/s²).
        pub linear_acceleration: Vector3,
        /// Its covariance.
        pub linear_acceleration_covariance: [f64; 9],
    }

    /// sensor_msgs/msg/JointState
    #[derive(RosMessage, Debug, Clone, Default, PartialEq)]
    #[cfg_attr(feature = "arbitrary", derive(arbitrary::Arbitrary))]
    #[ros(type_name = "sensor_msgs/msg/JointState", crate = "crate")]
    pub struct JointState {
        /// Header.
        pub header: Header,
        /// Joint names.
        pub name: Vec<String>,
        /// Positions.
        pub position: Vec<f64>,
        /// Velocities.
        pub velocity: Vec<f64>,
        /// Efforts.
        pub effort: Vec<f64>,
    }

    /// sensor_msgs/msg/JointState borrowing its names.
    #[derive(RosMessage, Debug, Clone, Default, PartialEq)]
    #[cfg_attr(feature = "arbitrary", derive(arbitrary::Arbitrary))]
    #[ros(type_name = "sensor_msgs/msg/JointState", crate = "crate")]
    pub struct JointStateRef<'a> {
        /// Header.
        pub header: HeaderRef<'a>,
        /// Joint names, borrowed from the input.
        pub name: Vec<&'a str>,
        /// Positions.
        pub position: Vec<f64>,
        /// Velocities.
        pub velocity: Vec<f64>,
        /// Efforts.
        pub effort: Vec<f64>,
    }

    /// sensor_msgs/msg/NavSatStatus
    #[derive(RosMessage, Debug, Clone, Copy, Default, PartialEq, Eq)]
    #[cfg_attr(feature = "arbitrary", derive(arbitrary::Arbitrary))]
    #[ros(type_name = "sensor_msgs/msg/NavSatStatus", crate = "crate")]
    pub struct NavSatStatus {
        /// Fix status (`STATUS_NO_FIX`, ...).
        pub status: i8,
        /// Satellite services used (`SERVICE_GPS`, ...).
        pub service: u16,
    }

    impl NavSatStatus {
        /// `STATUS_NO_FIX`
        pub const STATUS_NO_FIX: i8 = -1;
        /// `STATUS_FIX`
        pub const STATUS_FIX: i8 = 0;
        /// `STATUS_SBAS_FIX`
        pub const STATUS_SBAS_FIX: i8 = 1;
        /// `STATUS_GBAS_FIX`
        pub const STATUS_GBAS_FIX: i8 = 2;
        /// `SERVICE_GPS`
        pub const SERVICE_GPS: u16 = 1;
        /// `SERVICE_GLONASS`
        pub const SERVICE_GLONASS: u16 = 2;
        /// `SERVICE_COMPASS`
        pub const SERVICE_COMPASS: u16 = 4;
        /// `SERVICE_GALILEO`
        pub const SERVICE_GALILEO: u16 = 8;
    }

    /// sensor_msgs/msg/NavSatFix
    #[derive(RosMessage, Debug, Clone, Default, PartialEq)]
    #[cfg_attr(feature = "arbitrary", derive(arbitrary::Arbitrary))]
    #[ros(type_name = "sensor_msgs/msg/NavSatFix", crate = "crate")]
    pub struct NavSatFix {
        /// Header.
        pub header: Header,
        /// Fix status.
        pub status: NavSatStatus,
        /// Latitude (degrees).
        pub latitude: f64,
        /// Longitude (degrees).
        pub longitude: f64,
        /// Altitude (m).
        pub altitude: f64,
        /// Position covariance (m², row-major ENU).
        pub position_covariance: [f64; 9],
        /// How the covariance is known.
        pub position_covariance_type: u8,
    }

    /// sensor_msgs/msg/RegionOfInterest
    #[derive(RosMessage, Debug, Clone, Copy, Default, PartialEq, Eq)]
    #[cfg_attr(feature = "arbitrary", derive(arbitrary::Arbitrary))]
    #[ros(type_name = "sensor_msgs/msg/RegionOfInterest", crate = "crate")]
    pub struct RegionOfInterest {
        /// Left edge.
        pub x_offset: u32,
        /// Top edge.
        pub y_offset: u32,
        /// Height.
        pub height: u32,
        /// Width.
        pub width: u32,
        /// Whether to rectify.
        pub do_rectify: bool,
    }

    /// sensor_msgs/msg/CameraInfo
    #[derive(RosMessage, Debug, Clone, Default, PartialEq)]
    #[cfg_attr(feature = "arbitrary", derive(arbitrary::Arbitrary))]
    #[ros(type_name = "sensor_msgs/msg/CameraInfo", crate = "crate")]
    pub struct CameraInfo {
        /// Header.
        pub header: Header,
        /// Image height.
        pub height: u32,
        /// Image width.
        pub width: u32,
        /// Distortion model name.
        pub distortion_model: String,
        /// Distortion parameters.
        pub d: Vec<f64>,
        /// Intrinsic matrix (3×3).
        pub k: [f64; 9],
        /// Rectification matrix (3×3).
        pub r: [f64; 9],
        /// Projection matrix (3×4).
        pub p: [f64; 12],
        /// Horizontal binning.
        pub binning_x: u32,
        /// Vertical binning.
        pub binning_y: u32,
        /// Region of interest.
        pub roi: RegionOfInterest,
    }
}
