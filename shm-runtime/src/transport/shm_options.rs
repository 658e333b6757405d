//! [`ShmOptions`]: the shared-memory options of every builder of an entity
//! that sends messages, written once.

use crate::transport::pool::ShmContext;
use crate::transport::publisher::ShmSettings;

/// The shared-memory options of a builder of an entity that sends messages:
/// [`PublisherBuilder`](crate::PublisherBuilder) (its messages),
/// [`ServiceClientBuilder`](crate::service::ServiceClientBuilder) (its
/// requests) and [`ServiceServerBuilder`](crate::service::ServiceServerBuilder)
/// (its replies). Each overrides what the entity inherits from its node
/// ([`RosNodeBuilder::shm`](crate::RosNodeBuilder::shm)); in the
/// [`prelude`](crate::prelude), as Zenoh's own builder traits are in
/// Zenoh's.
///
/// ```no_run
/// use shm_runtime::prelude::*;
/// use shm_cdr::msgs::std_msgs::String as RosString;
///
/// let session = zenoh::open(zenoh::Config::default()).wait()?;
/// let shm = ShmContext::new(ShmConfig::enabled())?;
/// let node = RosNode::builder(&session, "talker").shm(&shm).wait()?;
/// // Small text on the heap whatever the pool's threshold, ...
/// let chatter = node.declare_publisher::<RosString>("chatter").without_shm().wait()?;
/// // ... and this publisher's messages in shared memory from 1 KiB on.
/// let big = node
///     .declare_publisher::<RosString>("big")
///     .shm_threshold(1024)
///     .wait()?;
/// # Ok::<(), Box<dyn std::error::Error + Send + Sync>>(())
/// ```
pub trait ShmOptions: Sized + sealed::Settings {
    /// Send through this shared-memory pool (overrides the node's).
    fn shm(mut self, context: &ShmContext) -> Self {
        self.shm_settings().use_pool(context);
        self
    }

    /// Use shared memory for messages of at least `bytes` encoded bytes
    /// (overrides the pool's threshold).
    fn shm_threshold(mut self, bytes: usize) -> Self {
        self.shm_settings().threshold(bytes);
        self
    }

    /// Never send from shared memory.
    fn without_shm(mut self) -> Self {
        self.shm_settings().off();
        self
    }
}

impl<B: sealed::Settings> ShmOptions for B {}

pub(crate) mod sealed {
    use super::ShmSettings;

    /// Where a builder keeps its shared-memory settings; implemented only in
    /// this crate, so the options mean the same on every builder.
    pub trait Settings {
        /// The settings the options change.
        fn shm_settings(&mut self) -> &mut ShmSettings;
    }
}
