//! Record ROS 2 topics of rmw_zenoh systems into MCAP as rosbag2 writes it,
//! and play recordings back (MCAP, and rosbag2's sqlite3 storage).
//!
//! A recording is a directory with `metadata.yaml` and MCAP files (profile
//! `ros2`; a `ros2msg` schema with the full definition per type; a `cdr`
//! channel per topic with its QoS profiles and type hash), so rosbag2,
//! Foxglove, the `mcap` tools and `rosbags` read it. Types come from the
//! standard set built in, or from the publishing node's type-description
//! service: a topic of a type this crate was never built with is recorded
//! too. Messages are written from the sample Zenoh delivers (in shared
//! memory, where the publisher put it), with bounded memory and a count of
//! everything that could not be kept.
//!
//! - [`Recorder`]: discover, subscribe, write.
//! - [`Player`]: publish a recording with its timing and QoS.
//! - [`Bag`]: a recording on disk, in MCAP or rosbag2's sqlite3 storage
//!   ([`Storage`]), read in log-time order.
//! - [`convert`]: bags of any storage into one MCAP bag.
//! - [`BagWriter`] and [`BagMetadata`]: the files themselves.

mod bag;
mod chunk;
mod control;
mod convert;
mod player;
mod recorder;
mod reindex;
mod split_events;
mod storage;
mod writer;

pub mod metadata;
pub mod qos;

/// Type resolution lives in the runtime ([`shm_runtime::types`]), shared
/// with `shm-ros2`; these are its paths as this crate first published them.
pub use shm_runtime::types::{self, definition, local};

/// rosbag2's player control services (`rosbag2_interfaces/srv/Pause`, …)
/// and split events, from the standard set
/// ([`shm_cdr::msgs::rosbag2_interfaces`]): the [`Player`] answers them as
/// `ros2 bag play` does, and the [`Recorder`] as `ros2 bag record`.
pub mod interfaces {
    pub use shm_cdr::msgs::rosbag2_interfaces;
}

pub use bag::Bag;
pub use control::PlayerControl;
pub use convert::{convert, ConvertOptions, Converted};
pub use metadata::BagMetadata;
pub use player::{ClockTrigger, PlayOptions, PlayStats, Player};
pub use recorder::{
    service_of_event_topic, ChannelStats, RecordOptions, RecordStats, Recorder, RecorderControl,
    Selection, TypeDefinition, MAX_DEFINITION, MAX_NODE_DEFINITIONS,
};
pub use reindex::{reindex, FileReport, Reindexed};
pub use storage::{BagMessage, RecordedTopic, Storage};
pub use writer::{BagWriter, Compression, FileSplit, TopicId, WriteOptions};

/// A failure to report: the message says what happened and what to do.
pub type Error = Box<dyn std::error::Error + Send + Sync>;
