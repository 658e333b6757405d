//! A received sample: where its payload lies, its attachment, and decoding
//! into any message type.

use std::fmt;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, OnceLock};

use shm_cdr::{CdrDecode, DecodeError};
use zenoh::bytes::ZBytes;
use zenoh::sample::Sample;

use crate::rmw::{Attachment, AttachmentError};
use crate::transport::type_check::sample_type;

/// A received sample, decodable into any message type (owned or borrowing from
/// the sample).
///
/// # Example
///
/// ```no_run
/// # fn main() -> Result<(), Box<dyn std::error::Error + Send + Sync>> {
/// use shm_cdr::msgs::sensor_msgs::Image;
/// use shm_runtime::RosNode;
/// use zenoh::Wait;
///
/// # let session = zenoh::open(shm_runtime::rmw::config::session_config()?).wait()?;
/// # let node = RosNode::builder(&session, "viewer").wait()?;
/// let subscriber = node.declare_subscriber::<Image>("image").wait()?;
/// let sample = subscriber.recv()?;
/// // Where it lies: in the publisher's shared memory, mapped here, or copied.
/// println!("{} bytes in shared memory", sample.shm_len());
/// // Owned, or into a message kept from one sample to the next.
/// let mut image: Image = sample.decode()?;
/// sample.decode_into(&mut image)?;
/// # Ok(())
/// # }
/// ```
pub struct RosSample {
    sample: Sample,
    /// A contiguous copy, made at most once, for payloads that arrived in more
    /// fragments than can be borrowed from.
    copy: OnceLock<Vec<u8>>,
    /// What this sample counts against its subscriber's memory budget.
    _held: Option<Held>,
}

/// Bytes a sample counts against its subscriber's budget, given back when the
/// sample is dropped (which is also when its shared-memory chunk is).
struct Held {
    counter: Arc<AtomicUsize>,
    bytes: usize,
}

impl Drop for Held {
    fn drop(&mut self) {
        self.counter.fetch_sub(self.bytes, Ordering::Relaxed);
    }
}

impl fmt::Debug for RosSample {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("RosSample")
            .field("key_expr", &self.sample.key_expr().as_str())
            .field("len", &self.sample.payload().len())
            .field("shm", &self.is_shm())
            .finish()
    }
}

impl RosSample {
    pub(crate) fn new(sample: Sample) -> Self {
        Self::queued(sample, None)
    }

    /// A sample that counts `bytes` against `counter` until dropped.
    pub(crate) fn queued(sample: Sample, held: Option<(Arc<AtomicUsize>, usize)>) -> Self {
        Self {
            sample,
            copy: OnceLock::new(),
            _held: held.map(|(counter, bytes)| Held { counter, bytes }),
        }
    }

    /// The Zenoh sample.
    pub fn sample(&self) -> &Sample {
        &self.sample
    }

    /// The payload.
    pub fn payload(&self) -> &ZBytes {
        self.sample.payload()
    }

    /// The key expression it was published on.
    pub fn key_expr(&self) -> &str {
        self.sample.key_expr().as_str()
    }

    /// The message type (name, RIHS01 hash) the sample's encoding names, if any:
    /// publishers on a plain key name it; a node's publishers, like
    /// rmw_zenoh_cpp's, do not, as their key expression names the type.
    pub fn message_type(&self) -> Option<(String, String)> {
        sample_type(&self.sample)
    }

    /// Whether the message lies in shared memory, wholly (encoded into a pool,
    /// or loaned) or in part (the block of a spliced `ShmBytes` field, which
    /// arrives as its own fragment between the metadata around it): what a
    /// decode borrows from it is read where the publisher wrote it.
    pub fn is_shm(&self) -> bool {
        self.shm_len() > 0
    }

    /// How many bytes of the payload lie in shared memory: all of them for a
    /// message encoded into a pool, a spliced block's for a `ShmBytes` field,
    /// 0 for a payload that travelled as bytes.
    pub fn shm_len(&self) -> usize {
        crate::transport::payload::shm_len(self.sample.payload())
    }

    /// How many fragments the payload arrived in (1 for a single buffer; 3 for a
    /// message with one spliced shared-memory field).
    pub fn fragments(&self) -> usize {
        self.sample.payload().slices().count()
    }

    /// The rmw_zenoh attachment, if the sample carries one.
    pub fn attachment(&self) -> Option<Result<Attachment, AttachmentError>> {
        let bytes = self.sample.attachment()?.to_bytes();
        Some(Attachment::parse(&bytes))
    }

    /// Decode the payload as `M`, borrowing from the sample where `M` has borrowed
    /// fields: from the single slice, or from each fragment of a spliced payload
    /// (a `&[u8]` field then points into the shared-memory block); a payload in
    /// other fragments is copied once into a contiguous buffer first.
    pub fn decode<'a, M: CdrDecode<'a>>(&'a self) -> Result<M, DecodeError> {
        crate::transport::payload::decode(self.sample.payload(), &self.copy)
    }

    /// [`decode`](Self::decode) into an existing value, reusing the memory it owns
    /// (see [`shm_cdr::from_bytes_into`]): a subscriber that keeps one message and
    /// decodes every sample into it allocates only when a message outgrows it.
    pub fn decode_into<'a, M: CdrDecode<'a>>(&'a self, out: &mut M) -> Result<(), DecodeError> {
        crate::transport::payload::decode_into(self.sample.payload(), &self.copy, out)
    }
}
