//! The transport core: typed publishers and subscribers on any key expression,
//! their payloads, the shared-memory pool and loans. Nothing here knows ROS
//! names or the graph; the [`ros`](crate::ros) tree builds on it.

pub(crate) mod changes;
pub(crate) mod config;
pub(crate) mod encoded;
pub(crate) mod executor;
pub(crate) mod gaps;
pub(crate) mod inline_limit;
pub(crate) mod limits;
pub(crate) mod links;
pub(crate) mod loan;
pub(crate) mod matching;
pub(crate) mod memlock;
pub(crate) mod payload;
pub(crate) mod pool;
pub(crate) mod publisher;
pub(crate) mod queue;
pub(crate) mod reach;
pub(crate) mod reach_table;
pub(crate) mod receive_failures;
pub(crate) mod sample;
pub(crate) mod shm_bytes;
pub(crate) mod shm_options;
pub(crate) mod subscriber;
pub(crate) mod type_check;
pub(crate) mod type_registration;
pub(crate) mod zenoh_line;
