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
        let mut encoded = EncodedPayload {
            bytes: self.buffer.into_zbytes(),
            kind: self.kind,
            size: self.size,
            inline: if self.kind == PayloadKind::Shm {
                0
            } else {
                self.size
            },
        };
        if let Some(policy) = publisher.policy() {
            encoded = routed(encoded, policy);
            policy.context.count(encoded.kind, encoded.size);
        }
        Ok((encoded, publisher))
    }
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
