//! Loaned messages: a message built in place in the buffer it is published
//! from, one exact-size shared-memory chunk (or heap buffer), sent as it lies.
//!
//! A loan is a typestate. [`RosPublisher::loan`] takes the lengths of the
//! message's strings and sequences, allocates exactly its encoded size and lays
//! the message out there ([`shm_cdr::loan`]). [`Loan::fields`] hands out every
//! field at its final offset; [`Loan::publish`] consumes the loan and sends the
//! buffer without a copy, refusing if a string or sequence was left unwritten; a
//! loan dropped unsent returns its chunk to the pool.

use std::fmt;
use std::future::{Future, IntoFuture};
use std::pin::Pin;

use bytes::Bytes;
use shm_cdr::loan::{self, AlignedBuffer, InPlace, LoanError, Written};
use shm_cdr::RosMessage;
use zenoh::bytes::ZBytes;
use zenoh::shm::ZShmMut;
use zenoh::{Resolvable, Wait};

use crate::transport::encoded::{EncodedPayload, PayloadKind};
use crate::transport::payload::{routed, ShmPolicy};
use crate::transport::publisher::{PublishError, PublishOutcome, RosPublisher};

/// Where a loan's bytes lie.
enum Buffer {
    Shm(ZShmMut),
    Heap(AlignedBuffer),
}

impl Buffer {
    fn as_mut_slice(&mut self) -> &mut [u8] {
        match self {
            Self::Shm(chunk) => chunk,
            Self::Heap(buffer) => buffer.as_mut_slice(),
        }
    }

    fn into_zbytes(self) -> ZBytes {
        match self {
            Self::Shm(chunk) => ZBytes::from(chunk),
            Self::Heap(buffer) => {
                // The storage goes to Zenoh as is, sliced to the message: no copy.
                let (storage, range) = buffer.into_parts();
                ZBytes::from(Bytes::from(storage).slice(range))
            }
        }
    }
}

/// A message of type `T` being built in place, to publish without a copy.
///
/// Get one from [`RosPublisher::loan`], write its fields through
/// [`fields`](Self::fields), then [`publish`](Self::publish) it. Dropping it
/// unsent gives its buffer back.
#[must_use = "a loan does nothing until published; dropping it returns its buffer"]
pub struct Loan<'p, T: InPlace> {
    publisher: &'p RosPublisher<T>,
    buffer: Buffer,
    lens: T::Lens,
    written: Written,
    kind: PayloadKind,
    size: usize,
}

impl<T: InPlace> fmt::Debug for Loan<'_, T> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Loan")
            .field("kind", &self.kind)
            .field("size", &self.size)
            .field("unwritten", &self.written.pending())
            .finish()
    }
}

impl<T: RosMessage + InPlace> RosPublisher<T> {
    /// Lend a buffer for one message whose strings and sequences have the lengths
    /// `lens`, laid out in place: exactly its encoded size, from the pool at or
    /// above the threshold (the body 8-aligned, so every number can be referenced
    /// where it lies), else from the heap, laid out the same way. When the pool
    /// stays full for the configured wait, or the message is larger than the whole
    /// pool, or there is no pool, the loan is on the heap and [`Loan::kind`]
    /// says so ([`PayloadKind::HeapFallback`], [`PayloadKind::TooLargeForPool`],
    /// [`PayloadKind::PoolUnavailable`]); so it is while a subscribing session
    /// has not shown it maps the pool, or cannot ([`PayloadKind::ReceiverPending`],
    /// [`PayloadKind::ReceiverCannotMap`]). A loan in the pool that such a
    /// session appears for before it is published is copied to the heap then.
    ///
    /// Fails if the lengths break a bound or cannot be laid out.
    pub fn loan(&self, lens: T::Lens) -> Result<Loan<'_, T>, LoanError> {
        let size = loan::encoded_size::<T>(&lens)?;
        let (buffer, kind) = allocate(self.policy(), size);
        let mut loan = Loan {
            publisher: self,
            buffer,
            lens,
            written: Written::new(),
            kind,
            size,
        };
        // Lay it out once now: a bound or array length that does not hold is an
        // error here, where the lengths were given.
        loan.fields()?;
        Ok(loan)
    }
}

/// A buffer of `size` bytes for a message, as `policy` places it.
fn allocate(policy: Option<&ShmPolicy>, size: usize) -> (Buffer, PayloadKind) {
    let Some(policy) = policy.filter(|p| size >= p.threshold) else {
        return (Buffer::Heap(AlignedBuffer::new(size)), PayloadKind::Heap);
    };
    match policy
        .gate()
        .map_or_else(|| policy.context.place(size), Err)
    {
        Ok(chunk) => (Buffer::Shm(chunk), PayloadKind::Shm),
        Err(heap) => (Buffer::Heap(AlignedBuffer::new(size)), heap),
    }
}

impl<'p, T: RosMessage + InPlace> Loan<'p, T> {
    /// The message's fields at their final offsets: numbers as `&mut` (zero until
    /// set), strings as slots of the stated length, sequences of numbers and plain
    /// structs as runs to write once (see [`shm_cdr::loan`]).
    ///
    /// Each call lays the message out afresh: numbers back to zero, every string
    /// and sequence unwritten again.
    pub fn fields(&mut self) -> Result<T::Mut<'_>, LoanError> {
        loan::carve::<T>(&self.lens, self.buffer.as_mut_slice(), &self.written)
    }

    /// Where the message lies: [`PayloadKind::Shm`] for a pool chunk, else one of
    /// the heap kinds.
    pub fn kind(&self) -> PayloadKind {
        self.kind
    }

    /// The message's encoded size in bytes, header included.
    pub fn size(&self) -> usize {
        self.size
    }

    /// Strings and sequences laid out but not yet written.
    pub fn unwritten(&self) -> usize {
        self.written.pending()
    }

    /// Publish the buffer as it lies; resolve with `.wait()` or `.await`. Refused
    /// ([`PublishError::Loan`]) while a string or sequence is unwritten.
    pub fn publish(self) -> LoanPublish<'p, T> {
        LoanPublish { loan: self }
    }

    /// Check and count: the payload the put carries.
    fn encoded(self) -> Result<(EncodedPayload, &'p RosPublisher<T>), PublishError> {
        self.written.check().map_err(PublishError::Loan)?;
        let publisher = self.publisher;
        let encoded = lent_payload(
            self.buffer.into_zbytes(),
            self.kind,
            self.size,
            publisher.policy(),
        );
        Ok((encoded, publisher))
    }
}

/// A lent buffer's bytes as they go out under `policy`: by the heap while a
/// subscribing session has not shown it maps the pool ([`routed`]), counted
/// in the pool's statistics.
fn lent_payload(
    bytes: ZBytes,
    kind: PayloadKind,
    size: usize,
    policy: Option<&ShmPolicy>,
) -> EncodedPayload {
    let mut encoded = EncodedPayload {
        bytes,
        kind,
        size,
        inline: if kind == PayloadKind::Shm { 0 } else { size },
    };
    if let Some(policy) = policy {
        encoded = routed(encoded, policy);
        policy.context.count(encoded.kind, encoded.size);
    }
    encoded
}

/// A pending publish of a loan; resolve with `.wait()` or `.await`.
#[must_use = "resolve the publish with .wait() or .await"]
pub struct LoanPublish<'p, T: InPlace> {
    loan: Loan<'p, T>,
}

impl<T: InPlace> fmt::Debug for LoanPublish<'_, T> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("LoanPublish")
            .field("loan", &self.loan)
            .finish()
    }
}

impl<T: RosMessage + InPlace> Resolvable for LoanPublish<'_, T> {
    type To = Result<PublishOutcome, PublishError>;
}

impl<T: RosMessage + InPlace> Wait for LoanPublish<'_, T> {
    fn wait(self) -> Self::To {
        let (encoded, publisher) = self.loan.encoded()?;
        publisher.put_encoded_wait(encoded)
    }
}

impl<'p, T: RosMessage + InPlace> IntoFuture for LoanPublish<'p, T> {
    type Output = Result<PublishOutcome, PublishError>;
    type IntoFuture = Pin<Box<dyn Future<Output = Self::Output> + Send + 'p>>;

    fn into_future(self) -> Self::IntoFuture {
        let prepared = self
            .loan
            .encoded()
            .and_then(|(encoded, publisher)| Ok((publisher.prepare_encoded(encoded)?, publisher)));
        Box::pin(async move {
            let (prepared, publisher) = prepared?;
            prepared.put_async(publisher.zenoh()).await
        })
    }
}

/// A buffer of an exact size lent by a publisher for one message whose bytes
/// the caller lays out itself: a run-time typed message laid out around the
/// arrays it fills in place ([`shm_cdr::dynamic::InPlaceLayout`]), say.
/// Placed as [`RosPublisher::loan`] places a typed loan (the pool at or above
/// the threshold, else the heap, with the same fallbacks).
///
/// A typestate: written through [`as_mut_slice`](Self::as_mut_slice), then
/// [`freeze`](Self::freeze)n into a [`LoanedPayload`], which
/// [`RosPublisher::publish_loaned`] sends as it lies. Dropping it returns the
/// buffer.
///
/// ```no_run
/// use shm_cdr::dynamic::{DynamicType, Value};
/// use shm_cdr::msgs::sensor_msgs::Image;
/// use shm_cdr::RosMessage;
/// use shm_runtime::rmw::Qos;
/// use shm_runtime::RosNode;
/// use zenoh::Wait;
///
/// let session = zenoh::open(zenoh::Config::default()).wait()?;
/// let node = RosNode::builder(&session, "camera").wait()?;
/// let ty = DynamicType::from_description(&Image::full_description())?;
/// let publisher = node.declare_dynamic_publisher("image", &ty, Qos::default()).wait()?;
///
/// let mut image = ty.default_message();
/// image.set("encoding", Value::String("mono8".into()))?;
/// image.set("height", Value::U32(480))?;
/// image.set("width", Value::U32(640))?;
/// image.set("step", Value::U32(640))?;
/// let layout = ty.lay_out_in_place(&image, &[(&["data"], 640 * 480)])?;
///
/// let mut loan = publisher.loan_buffer(layout.size());
/// loan.as_mut_slice()[layout.arrays()[0].range()].fill(128); // the pixels, in place
/// layout.write_around(&image, loan.as_mut_slice())?;
/// publisher.publish_loaned(loan.freeze())?;
/// # Ok::<(), Box<dyn std::error::Error + Send + Sync>>(())
/// ```
#[must_use = "a loan does nothing until published; dropping it returns its buffer"]
pub struct BufferLoan {
    buffer: Buffer,
    kind: PayloadKind,
    size: usize,
    pool: Option<crate::ShmContext>,
}

impl fmt::Debug for BufferLoan {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("BufferLoan")
            .field("kind", &self.kind)
            .field("size", &self.size)
            .finish_non_exhaustive()
    }
}

impl BufferLoan {
    /// The buffer: exactly [`size`](Self::size) bytes, 8-aligned. A pool
    /// buffer holds whatever its last message left; write every byte.
    pub fn as_mut_slice(&mut self) -> &mut [u8] {
        self.buffer.as_mut_slice()
    }

    /// Where the buffer lies: [`PayloadKind::Shm`] for a pool chunk, else one
    /// of the heap kinds.
    pub fn kind(&self) -> PayloadKind {
        self.kind
    }

    /// The buffer's size in bytes.
    pub fn size(&self) -> usize {
        self.size
    }

    /// The buffer as written, no longer writable, ready to publish. No copy.
    pub fn freeze(self) -> LoanedPayload {
        LoanedPayload {
            bytes: self.buffer.into_zbytes(),
            kind: self.kind,
            size: self.size,
            pool: self.pool,
        }
    }
}

/// A [`BufferLoan`] frozen: its bytes as they will be sent. Cloning it is a
/// reference count, and a clone keeps the memory (a pool chunk stays taken)
/// for as long as it lives, after publishing too.
#[derive(Clone)]
pub struct LoanedPayload {
    bytes: ZBytes,
    kind: PayloadKind,
    size: usize,
    pool: Option<crate::ShmContext>,
}

impl fmt::Debug for LoanedPayload {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("LoanedPayload")
            .field("kind", &self.kind)
            .field("size", &self.size)
            .finish_non_exhaustive()
    }
}

impl LoanedPayload {
    /// Where the bytes lie (see [`BufferLoan::kind`]).
    pub fn kind(&self) -> PayloadKind {
        self.kind
    }

    /// Their size in bytes.
    pub fn size(&self) -> usize {
        self.size
    }
}

impl<T> RosPublisher<T> {
    /// Lend a buffer of exactly `size` bytes for one message the caller lays
    /// out itself (see [`BufferLoan`]); placed as [`loan`](Self::loan) places
    /// a typed one.
    pub fn loan_buffer(&self, size: usize) -> BufferLoan {
        let (buffer, kind) = allocate(self.policy(), size);
        BufferLoan {
            buffer,
            kind,
            size,
            pool: self.policy().map(|policy| policy.context.clone()),
        }
    }

    /// Publish a frozen [`BufferLoan`] as it lies, waiting; its bytes must be
    /// a message of the publisher's type, encapsulation header first (checked
    /// no further than the header, as [`publish_serialized`](Self::publish_serialized)).
    /// A buffer lent from another pool than this publisher's is refused
    /// ([`PublishError::OtherPool`]); one in the pool goes by the heap while a
    /// subscribing session has not shown it maps the pool, as every message
    /// does.
    pub fn publish_loaned(&self, payload: LoanedPayload) -> Result<PublishOutcome, PublishError> {
        let mut header = [0u8; shm_cdr::HEADER_LEN];
        let mut reader = payload.bytes.reader();
        let read = std::io::Read::read(&mut reader, &mut header).unwrap_or(0);
        if read < header.len() || shm_cdr::read_header(&header).is_err() {
            return Err(PublishError::NotCdr { len: payload.size });
        }
        let policy = self.policy();
        if payload.kind == PayloadKind::Shm {
            let same = match (&payload.pool, policy) {
                (Some(pool), Some(policy)) => pool.same_pool(&policy.context),
                _ => false,
            };
            if !same {
                return Err(PublishError::OtherPool);
            }
        }
        self.put_encoded_wait(lent_payload(
            payload.bytes,
            payload.kind,
            payload.size,
            policy,
        ))
    }
}
