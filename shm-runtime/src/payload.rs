//! Turning a message into a Zenoh payload: exact size first, then one write into
//! shared memory (at or above the threshold) or the heap.

use shm_cdr::{CdrEncode, EncodeError};
use zenoh::bytes::ZBytes;

use crate::pool::ShmContext;
use crate::shm_bytes::{self, Splice};

/// Where a published message's bytes went.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PayloadKind {
    /// Below the threshold, or no SHM configured: encoded into a heap buffer.
    Heap,
    /// Encoded straight into a shared-memory buffer of exactly its size.
    Shm,
    /// The metadata was encoded on the heap around the application's own
    /// shared-memory field(s), which were appended as fragments without a copy.
    Spliced,
    /// Above the threshold, but the pool stayed full for the bounded wait: encoded
    /// on the heap instead (counted in [`ShmStats::fallbacks`](crate::ShmStats)).
    HeapFallback,
    /// Above the threshold, but larger than the whole pool, so it can never fit:
    /// encoded on the heap (counted in [`ShmStats::too_large`](crate::ShmStats),
    /// warned about once).
    TooLargeForPool,
}

/// An encoded message, ready to put.
#[derive(Debug)]
pub struct EncodedPayload {
    /// The bytes: exactly the CDR encoding, nothing more.
    pub bytes: ZBytes,
    /// Where they are.
    pub kind: PayloadKind,
    /// The encoded size in bytes, header included.
    pub size: usize,
}

/// How a publisher encodes: with a pool and threshold, or heap only.
#[derive(Debug, Clone)]
pub(crate) struct ShmPolicy {
    pub(crate) context: ShmContext,
    pub(crate) threshold: usize,
}

/// Encode `msg` for publishing under `policy`.
pub(crate) fn encode_payload<T: CdrEncode + ?Sized>(
    msg: &T,
    policy: Option<&ShmPolicy>,
) -> Result<EncodedPayload, EncodeError> {
    let size = match shm_bytes::encode_spliced(msg)? {
        Splice::Done(spliced) => {
            if let Some(policy) = policy {
                policy.context.count_shm();
            }
            return Ok(spliced);
        }
        Splice::NotNeeded(size) => size,
    };
    let mut kind = PayloadKind::Heap;
    let too_large = |p: &ShmPolicy| size > p.context.config().pool_size;
    if let Some(policy) = policy.filter(|p| size >= p.threshold && too_large(p)) {
        policy.context.count_too_large(size);
        kind = PayloadKind::TooLargeForPool;
    } else if let Some(policy) = policy.filter(|p| size >= p.threshold) {
        match policy
            .context
            .alloc_bounded(size, policy.context.config().alloc_timeout)
        {
            Some(mut buffer) => {
                // The provider hands out exactly `size` bytes, so the payload is the
                // encoding and nothing else.
                shm_cdr::encode_into(msg, &mut buffer)?;
                policy.context.count_shm();
                return Ok(EncodedPayload {
                    bytes: ZBytes::from(buffer),
                    kind: PayloadKind::Shm,
                    size,
                });
            }
            None => {
                policy.context.count_fallback(size);
                kind = PayloadKind::HeapFallback;
            }
        }
    } else if let Some(policy) = policy {
        policy.context.count_heap();
    }
    // Heap path: a buffer of exactly `size` bytes, written once.
    let mut buffer = vec![0u8; size];
    shm_cdr::encode_into(msg, &mut buffer)?;
    Ok(EncodedPayload {
        bytes: ZBytes::from(buffer),
        kind,
        size,
    })
}
