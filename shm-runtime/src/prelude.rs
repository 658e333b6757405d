//! Everything a ROS 2 program on shm-runtime starts with, `zenoh::Wait` (for
//! `.wait()`) and the loan traits included: `use shm_runtime::prelude::*;`.
//!
//! ```no_run
//! use shm_runtime::prelude::*;
//! use shm_runtime::msgs::sensor_msgs::ImageShm;
//!
//! let session = zenoh::open(zenoh::Config::default()).wait()?;
//! let shm = ShmContext::new(ShmConfig::enabled())?;
//! let node = RosNode::builder(&session, "camera").shm(&shm).wait()?;
//! let images = node.declare_publisher::<ImageShm>("image").wait()?;
//! # Ok::<(), Box<dyn std::error::Error + Send + Sync>>(())
//! ```

pub use shm_cdr::prelude::*;
pub use zenoh::Wait;

pub use crate::{
    init_logging, History, PayloadKind, PoolSize, RosNode, RosSample, SessionExt, ShmBytes,
    ShmConfig, ShmContext, ShmOptions,
};
