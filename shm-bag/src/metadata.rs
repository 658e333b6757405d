//! `metadata.yaml`, the file rosbag2 keeps beside a recording's MCAP files
//! (bag format version 9): what `ros2 bag info` prints and what `rosbags`
//! and rosbag2's player read first.

use std::collections::BTreeMap;
use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::qos::QosProfile;
use crate::Error;

/// The file's name in a bag directory.
pub const FILE_NAME: &str = "metadata.yaml";

/// The bag format version written.
pub const VERSION: u32 = 9;

/// The whole file: one key, `rosbag2_bagfile_information`.
#[derive(Debug, Clone, Serialize, Deserialize)]
struct File {
    rosbag2_bagfile_information: BagMetadata,
}

/// What a recording holds, as rosbag2 describes it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BagMetadata {
    /// The bag format version (9).
    pub version: u32,
    /// `mcap`.
    pub storage_identifier: String,
    /// From the first message's receive time to the last's.
    pub duration: Nanoseconds,
    /// The first message's receive time.
    pub starting_time: NanosecondsSinceEpoch,
    /// Messages in all files.
    pub message_count: u64,
    /// Each topic with its message count.
    pub topics_with_message_count: Vec<TopicWithMessageCount>,
    /// Empty: MCAP compresses its chunks itself.
    #[serde(default)]
    pub compression_format: String,
    /// Empty: MCAP compresses its chunks itself.
    #[serde(default)]
    pub compression_mode: String,
    /// The MCAP files, relative to the bag directory, in order.
    pub relative_file_paths: Vec<String>,
    /// Each file's span and count.
    #[serde(default)]
    pub files: Vec<FileInformation>,
    /// Free-form key/value pairs.
    #[serde(default)]
    pub custom_data: Option<BTreeMap<String, String>>,
    /// The ROS distribution the recording was made for.
    #[serde(default)]
    pub ros_distro: String,
}

/// A duration in nanoseconds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct Nanoseconds {
    /// Nanoseconds.
    pub nanoseconds: u64,
}

/// A time in nanoseconds since the Unix epoch.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct NanosecondsSinceEpoch {
    /// Nanoseconds since the Unix epoch.
    pub nanoseconds_since_epoch: u64,
}

/// One topic and how many of its messages a recording holds.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TopicWithMessageCount {
    /// The topic.
    pub topic_metadata: TopicMetadata,
    /// Its messages in all files.
    pub message_count: u64,
}

/// One recorded topic.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TopicMetadata {
    /// Its name.
    pub name: String,
    /// Its type, `pkg/msg/Name`.
    #[serde(rename = "type")]
    pub type_name: String,
    /// `cdr`.
    pub serialization_format: String,
    /// The QoS of the publishers recorded.
    #[serde(default)]
    pub offered_qos_profiles: Vec<QosProfile>,
    /// The type's RIHS01 hash.
    #[serde(default)]
    pub type_description_hash: String,
}

/// One MCAP file of a recording.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FileInformation {
    /// Relative to the bag directory.
    pub path: String,
    /// Its first message's receive time.
    pub starting_time: NanosecondsSinceEpoch,
    /// From its first message to its last.
    pub duration: Nanoseconds,
    /// Its messages.
    pub message_count: u64,
}

impl BagMetadata {
    /// The text of `metadata.yaml`.
    pub fn to_yaml(&self) -> String {
        serde_yaml::to_string(&File {
            rosbag2_bagfile_information: self.clone(),
        })
        .unwrap_or_default()
    }

    /// The metadata alone, as rosbag2 keeps it in each MCAP file's `rosbag2`
    /// metadata record (`serialized_metadata`): without the file's
    /// `rosbag2_bagfile_information` key.
    pub fn to_serialized_metadata(&self) -> String {
        serde_yaml::to_string(self).unwrap_or_default()
    }

    /// Read `metadata.yaml` text.
    pub fn from_yaml(text: &str) -> Result<Self, Error> {
        shm_cdr::text_limits::check_yaml(text).map_err(|e| format!("{FILE_NAME}: {e}"))?;
        let file: File = serde_yaml::from_str(text)
            .map_err(|e| format!("{FILE_NAME} is not a rosbag2 metadata file: {e}"))?;
        Ok(file.rosbag2_bagfile_information)
    }

    /// Read the `metadata.yaml` of the bag directory `dir`.
    pub fn read(dir: &Path) -> Result<Self, Error> {
        let path = dir.join(FILE_NAME);
        let text = shm_cdr::text_limits::read_text_file(&path)
            .map_err(|e| format!("cannot read {}: {e}", path.display()))?;
        Self::from_yaml(&text)
    }
}
