//! Record ROS 2 topics of rmw_zenoh systems into MCAP as rosbag2 writes it,
//! and play recordings back.
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
//! - [`BagWriter`] and [`BagMetadata`]: the files themselves.

mod player;
mod recorder;
mod writer;

pub mod definition;
pub mod local;
pub mod metadata;
pub mod qos;
pub mod types;

pub use metadata::BagMetadata;
pub use player::{Bag, ClockTrigger, PlayOptions, PlayStats, Player, RecordedTopic};
pub use recorder::{RecordOptions, RecordStats, Recorder, Selection};
pub use writer::{BagWriter, Compression, TopicId, WriteOptions};

/// A failure to report: the message says what happened and what to do.
pub type Error = Box<dyn std::error::Error + Send + Sync>;
