//! Standard messages whose big payload is a [`ShmBytes`]: the application writes
//! the points or pixels straight into shared memory, and publishing splices them
//! in without a copy. Same ROS types (and type hashes) as
//! `shm_cdr::msgs::sensor_msgs::{PointCloud2, Image}`, so subscribers decode them
//! as those (or their borrowing `…Ref` forms).

use shm_cdr::msgs::sensor_msgs::PointField;
use shm_cdr::msgs::std_msgs::Header;
use shm_cdr::RosMessage;

use crate::ShmBytes;

/// sensor_msgs/msg/PointCloud2 with its point data in shared memory.
#[derive(RosMessage, Debug, Clone, Default, PartialEq)]
#[ros(type_name = "sensor_msgs/msg/PointCloud2")]
pub struct PointCloud2Shm {
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
    pub data: ShmBytes,
    /// No invalid points.
    pub is_dense: bool,
}

/// sensor_msgs/msg/Image with its pixels in shared memory.
#[derive(RosMessage, Debug, Clone, Default, PartialEq)]
#[ros(type_name = "sensor_msgs/msg/Image")]
pub struct ImageShm {
    /// Header.
    pub header: Header,
    /// Rows.
    pub height: u32,
    /// Columns.
    pub width: u32,
    /// Pixel encoding.
    pub encoding: String,
    /// Byte order of the data.
    pub is_bigendian: u8,
    /// Bytes per row.
    pub step: u32,
    /// The pixels.
    pub data: ShmBytes,
}
