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
    /// The QoS of the publishers recorded. (rosbag2 wrote them as one YAML
    /// text up to bag format version 8, as a list since 9; both are read.)
    #[serde(default, deserialize_with = "qos_profiles")]
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

/// Offered QoS profiles as a list (version 9) or as the YAML text of one
/// (versions up to 8; empty when none).
fn qos_profiles<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Vec<QosProfile>, D::Error> {
    #[derive(Deserialize)]
    #[serde(untagged)]
    enum Form {
        List(Vec<QosProfile>),
        Text(String),
    }
    match Form::deserialize(d)? {
        Form::List(list) => Ok(list),
        Form::Text(text) => crate::qos::from_yaml(&text).map_err(serde::de::Error::custom),
    }
}

impl BagMetadata {
    /// The text of `metadata.yaml`.
    pub fn to_yaml(&self) -> String {
        yaml_serde::to_string(&File {
            rosbag2_bagfile_information: self.clone(),
        })
        .unwrap_or_default()
    }

    /// The metadata alone, as rosbag2 keeps it in each MCAP file's `rosbag2`
    /// metadata record (`serialized_metadata`): without the file's
    /// `rosbag2_bagfile_information` key.
    pub fn to_serialized_metadata(&self) -> String {
        yaml_serde::to_string(self).unwrap_or_default()
    }

    /// Read `metadata.yaml` text.
    pub fn from_yaml(text: &str) -> Result<Self, Error> {
        shm_cdr::text_limits::check_yaml(text).map_err(|e| format!("{FILE_NAME}: {e}"))?;
        let file: File = yaml_serde::from_str(text)
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

#[cfg(test)]
mod tests {
    use super::*;

    /// A `metadata.yaml` as rosbag2 wrote it up to format version 8 (as
    /// rosbags' writer does today): offered QoS profiles as one YAML text.
    const VERSION_8: &str = r#"rosbag2_bagfile_information:
  version: 8
  storage_identifier: mcap
  duration:
    nanoseconds: 1000
  starting_time:
    nanoseconds_since_epoch: 1700000000000000000
  message_count: 2
  topics_with_message_count:
  - topic_metadata:
      name: /chatter
      type: std_msgs/msg/String
      serialization_format: cdr
      offered_qos_profiles: "- history: 1\n  depth: 7\n  reliability: 1\n  durability: 1\n  deadline:\n    sec: 0\n    nsec: 0\n  lifespan:\n    sec: 0\n    nsec: 0\n  liveliness: 1\n  liveliness_lease_duration:\n    sec: 0\n    nsec: 0\n  avoid_ros_namespace_conventions: false"
      type_description_hash: RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18
    message_count: 2
  - topic_metadata:
      name: /quiet
      type: std_msgs/msg/Empty
      serialization_format: cdr
      offered_qos_profiles: ''
    message_count: 0
  compression_format: ''
  compression_mode: ''
  relative_file_paths:
  - bag_0.mcap
  files:
  - path: bag_0.mcap
    starting_time:
      nanoseconds_since_epoch: 1700000000000000000
    duration:
      nanoseconds: 1000
    message_count: 2
  custom_data: {}
  ros_distro: humble
"#;

    /// `metadata.yaml` as rosbag2 wrote it in format version `version` (4:
    /// Foxy, 5: Galactic and Humble, 6 and 7 on the way to Iron's 8), each
    /// with only the fields that version has: files since 5, custom data
    /// since 6, the type hash since 7.
    fn older(version: u32) -> String {
        let mut topic = String::from(
            "  - topic_metadata:\n      name: /chatter\n      type: std_msgs/msg/String\n      \
             serialization_format: cdr\n      offered_qos_profiles: \"- history: 3\\n  depth: 0\\n  \
             reliability: 1\\n  durability: 2\\n  deadline:\\n    sec: 2147483647\\n    nsec: \
             4294967295\\n  lifespan:\\n    sec: 2147483647\\n    nsec: 4294967295\\n  liveliness: \
             1\\n  liveliness_lease_duration:\\n    sec: 2147483647\\n    nsec: 4294967295\\n  \
             avoid_ros_namespace_conventions: false\"\n",
        );
        if version >= 7 {
            topic += "      type_description_hash: ''\n";
        }
        topic += "    message_count: 10\n";
        let mut text = format!(
            "rosbag2_bagfile_information:\n  version: {version}\n  storage_identifier: sqlite3\n  \
             relative_file_paths:\n    - bag_0.db3\n  duration:\n    nanoseconds: 9000000000\n  \
             starting_time:\n    nanoseconds_since_epoch: 1596117933614436264\n  message_count: 10\n  \
             topics_with_message_count:\n{topic}  compression_format: \"\"\n  compression_mode: \"\"\n"
        );
        if version >= 5 {
            text += "  files:\n    - path: bag_0.db3\n      starting_time:\n        \
                     nanoseconds_since_epoch: 1596117933614436264\n      duration:\n        \
                     nanoseconds: 9000000000\n      message_count: 10\n";
        }
        if version >= 6 {
            text += "  custom_data: ~\n";
        }
        text
    }

    #[test]
    fn every_older_format_version_is_read() {
        for version in 4..=7 {
            let metadata = BagMetadata::from_yaml(&older(version))
                .unwrap_or_else(|e| panic!("version {version}: {e}"));
            assert_eq!(metadata.version, version);
            assert_eq!(metadata.storage_identifier, "sqlite3");
            assert_eq!(metadata.message_count, 10);
            assert_eq!(metadata.files.len(), usize::from(version >= 5));
            let topic = &metadata.topics_with_message_count[0].topic_metadata;
            assert_eq!(topic.name, "/chatter");
            // Foxy's QoS: rmw's numbers (history 3 is "unknown"), and its
            // infinite durations in 32 bits.
            let qos = topic.offered_qos_profiles[0].to_qos();
            assert_eq!(qos.reliability, shm_runtime::rmw::Reliability::Reliable);
            assert_eq!(qos.durability, shm_runtime::rmw::Durability::Volatile);
            assert_eq!(
                (qos.deadline, qos.lifespan, qos.liveliness_lease),
                (None, None, None)
            );
        }
    }

    #[test]
    fn qos_written_as_text_up_to_version_8_is_read() {
        let metadata = BagMetadata::from_yaml(VERSION_8).unwrap();
        assert_eq!(metadata.version, 8);
        let topics = &metadata.topics_with_message_count;
        assert_eq!(topics[0].topic_metadata.offered_qos_profiles.len(), 1);
        let qos = topics[0].topic_metadata.offered_qos_profiles[0].to_qos();
        assert_eq!(qos, shm_runtime::rmw::Qos::transient_local(7));
        assert!(topics[1].topic_metadata.offered_qos_profiles.is_empty());
        // Written back as version 9 writes it: a list.
        let again = BagMetadata::from_yaml(&metadata.to_yaml()).unwrap();
        assert_eq!(again, metadata);
        // Text that is no QoS list is refused with the reason.
        let bad = VERSION_8.replace("\"- history: 1", "\"history: [");
        assert!(BagMetadata::from_yaml(&bad).is_err());
    }
}
