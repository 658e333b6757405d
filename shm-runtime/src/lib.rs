//! Publish and receive ROS 2 messages through Zenoh shared memory, inside your own
//! `zenoh::Session`.
//!
//! A publisher asks [`shm_cdr::encoded_size`] for the exact size, allocates a
//! shared-memory buffer of exactly that size (at or above the threshold; heap
//! below it) and encodes straight into it; a [`ShmBytes`] field the application
//! already wrote into shared memory is spliced in without a copy. Subscribers decode
//! borrowing from the received buffers. A subscriber counts what never reached
//! it ([`RosSubscriber::missed`]); with [`PublisherBuilder::recovery`] and
//! [`SubscriberBuilder::recovery`] it gets those messages back from the
//! publisher's cache, in order.
//!
//! On a [`RosNode`] the same runs with rmw_zenoh_cpp's conventions, so the
//! program is a ROS 2 participant: topics with QoS (latched topics included),
//! [`service`]s (servers and clients), [`action`]s (servers and clients, with
//! rcl_action's goal state machine), and the ROS [`graph`].
//!
//! ```no_run
//! use shm_runtime::{SessionExt, ShmConfig, ShmContext, ShmOptions};
//! use zenoh::Wait;
//! # #[derive(shm_cdr::RosMessage)] #[ros(type_name = "my_pkg/msg/Blob")] struct Blob { data: Vec<u8> }
//!
//! let session = zenoh::open(zenoh::Config::default()).wait()?;
//! let shm = ShmContext::new(ShmConfig::enabled())?;
//! let publisher = session.declare_ros_publisher::<Blob>("blobs").shm(&shm).wait()?;
//! let outcome = publisher.publish(&Blob { data: vec![7; 1 << 20] }).wait()?;
//! println!("{outcome:?}"); // kind: Shm, size: 1048584
//! # Ok::<(), Box<dyn std::error::Error + Send + Sync>>(())
//! ```
#![warn(missing_docs)]
// docs.rs builds with `--cfg docsrs`: every item behind a cargo feature is
// marked with the feature it needs.
#![cfg_attr(docsrs, feature(doc_cfg))]

mod logging;
pub mod msgs;
pub mod prelude;
pub mod rmw;
mod ros;
pub mod testing;
mod transport;

#[cfg(feature = "type_resolution")]
pub use ros::types;
pub use ros::{action, graph, lifecycle, log_levels, names, parameters, service, time};

pub use logging::{init_logging, DEFAULT_LOG_FILTER, QUIET_BY_DEFAULT};
pub use ros::node::{RosNode, RosNodeBuilder};
pub use ros::rosout::{LogSite, RosoutLayer};
pub use ros::topic_types::TypeConflict;
pub use transport::config::{ConfigError, PoolSize, ShmConfig};
pub use transport::encoded::{EncodedPayload, PayloadKind};
pub use transport::executor::Executor;
pub use transport::inline_limit::Unfragmentable;
pub use transport::limits::{KeyExprTooLong, MAX_KEY_EXPR_LEN};
pub use transport::loan::{BufferLoan, Loan, LoanPublish, LoanedPayload};
pub use transport::memlock::{MemlockBudget, ZENOH_METADATA_SEGMENT};
pub use transport::pool::{CdrBackend, ShmContext, ShmStats};
pub use transport::publisher::{
    PublishBuilder, PublishError, PublishOutcome, PublisherBuilder, RosPublisher, Serialized,
};
pub use transport::queue::DEFAULT_MAX_QUEUED_BYTES;
pub use transport::reach::PROBE_TIMEOUT;
pub use transport::reach_table::{Reach, Receiver};
pub use transport::receive_failures::{
    receive_failure_layer, shm_receive_failures, ReceiveFailureCause, ReceiveFailureLayer,
    ShmReceiveFailures,
};
pub use transport::sample::RosSample;
pub use transport::shm_bytes::ShmBytes;
pub use transport::shm_options::ShmOptions;
pub use transport::subscriber::{
    CallbackSubscriber, CallbackSubscriberBuilder, History, MessageStream, RecvError,
    RosSubscriber, SampleStream, SubscriberBuilder,
};

pub use shm_cdr;
pub use transport::zenoh_line::ZenohLine;

use rmw::TopicType;
use shm_cdr::RosMessage;
use zenoh::Session;

/// Typed publishers and subscribers on a plain key expression of your choice,
/// declared on any `zenoh::Session`. For rmw_zenoh-compatible topics, declare them
/// on a [`RosNode`] instead.
pub trait SessionExt {
    /// A publisher of `T` on `key_expr` (heap only unless `.shm(..)` is given).
    fn declare_ros_publisher<T: RosMessage>(
        &self,
        key_expr: impl Into<String>,
    ) -> PublisherBuilder<'_, T>;

    /// A subscriber to `T` on `key_expr`.
    fn declare_ros_subscriber<T: RosMessage>(
        &self,
        key_expr: impl Into<String>,
    ) -> SubscriberBuilder<'_, T>;
}

impl SessionExt for Session {
    fn declare_ros_publisher<T: RosMessage>(
        &self,
        key_expr: impl Into<String>,
    ) -> PublisherBuilder<'_, T> {
        PublisherBuilder::new(self, key_expr.into(), TopicType::of::<T>())
    }

    fn declare_ros_subscriber<T: RosMessage>(
        &self,
        key_expr: impl Into<String>,
    ) -> SubscriberBuilder<'_, T> {
        SubscriberBuilder::new(self, key_expr.into(), TopicType::of::<T>())
    }
}
