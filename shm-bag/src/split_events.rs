//! `/events/write_split` and `/events/read_split`: a recording or a playback
//! announcing that it moved on to another file, as rosbag2's do.

use std::path::Path;

use shm_cdr::RosMessage;
use shm_runtime::rmw::{Durability, History, Qos, Reliability};
use shm_runtime::{RosNode, RosPublisher};
use zenoh::Wait;

use crate::interfaces::rosbag2_interfaces::msg::{ReadSplitEvent, WriteSplitEvent};
use crate::writer::FileSplit;
use crate::Error;

/// A split event message: the two files and the node.
pub(crate) trait SplitEvent: RosMessage + Send + Sync {
    /// The topic, relative to the node's namespace.
    const TOPIC: &'static str;

    fn new(closed_file: String, opened_file: String, node_name: String) -> Self;
}

impl SplitEvent for WriteSplitEvent {
    const TOPIC: &'static str = "events/write_split";

    fn new(closed_file: String, opened_file: String, node_name: String) -> Self {
        Self {
            closed_file,
            opened_file,
            node_name,
        }
    }
}

impl SplitEvent for ReadSplitEvent {
    const TOPIC: &'static str = "events/read_split";

    fn new(closed_file: String, opened_file: String, node_name: String) -> Self {
        Self {
            closed_file,
            opened_file,
            node_name,
        }
    }
}

/// The publisher of a node's split events.
pub(crate) struct SplitEvents<M: SplitEvent> {
    publisher: RosPublisher<M>,
    /// The node's fully qualified name.
    node_name: String,
}

impl<M: SplitEvent> SplitEvents<M> {
    /// Declare the publisher on `node`, with rosbag2's QoS (reliable,
    /// volatile, the last one kept).
    pub(crate) fn declare(node: &RosNode) -> Result<Self, Error> {
        let qos = Qos::with_history(
            Reliability::Reliable,
            Durability::Volatile,
            History::KeepLast(1),
        );
        let info = node.info();
        Ok(Self {
            publisher: node.declare_publisher_with_qos::<M>(M::TOPIC, qos).wait()?,
            node_name: match info.namespace.as_str() {
                "/" => format!("/{}", info.name),
                namespace => format!("{namespace}/{}", info.name),
            },
        })
    }

    /// Announce `split`, the files by their full paths.
    pub(crate) fn publish(&self, split: &FileSplit) {
        let event = M::new(
            full_path(&split.closed),
            full_path(&split.opened),
            self.node_name.clone(),
        );
        if let Err(e) = self.publisher.publish(&event).wait() {
            tracing::warn!("publishing {} failed: {e}", M::TOPIC);
        }
    }
}

fn full_path(path: &Path) -> String {
    std::path::absolute(path)
        .unwrap_or_else(|_| path.to_owned())
        .display()
        .to_string()
}
