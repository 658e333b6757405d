//! The ROS 2 node on top of the transport core: rmw_zenoh_cpp's names, tokens
//! and attachments, nodes, services, actions and the graph.

pub mod action;
pub mod graph;
pub mod lifecycle;
pub mod log_levels;
pub mod names;
pub(crate) mod node;
pub mod parameters;
pub(crate) mod rosout;
pub mod service;
pub mod time;
pub(crate) mod topic_types;
pub(crate) mod type_description;
#[cfg(feature = "type_resolution")]
pub mod types;
