//! What a published message became: its bytes and where they lie.

use zenoh::bytes::ZBytes;

/// Where a published message's bytes went.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
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
    /// Above the threshold, but the memory-lock limit left no room for a pool
    /// (see [`PoolSize::AtMost`](crate::PoolSize::AtMost)): encoded on the
    /// heap (counted in [`ShmStats::unavailable`](crate::ShmStats), warned
    /// about once).
    PoolUnavailable,
    /// Above the threshold, but a session that subscribes to the publisher
    /// had not answered whether it maps the pool (two round trips: its
    /// receiver token is confirmed, then the pool probed; once per session
    /// and pool) within the pool's `alloc_timeout`: encoded on the
    /// heap meanwhile (counted in [`ShmStats::pending`](crate::ShmStats)).
    ReceiverPending,
    /// Above the threshold, but a session that subscribes to the publisher
    /// cannot map the pool (its process's memory-lock limit, most often):
    /// encoded on the heap, so that it gets every message (counted in
    /// [`ShmStats::cannot_map`](crate::ShmStats), warned about once; see
    /// [`RosPublisher::receivers`](crate::RosPublisher::receivers)).
    ReceiverCannotMap,
}

impl PayloadKind {
    /// Whether the bytes lie (at least partly) in shared memory.
    pub fn is_shm(self) -> bool {
        matches!(self, Self::Shm | Self::Spliced)
    }
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
    /// Of those, the bytes that travel inline, not as a shared-memory
    /// descriptor: 0 for [`PayloadKind::Shm`], the metadata around the blocks
    /// for [`PayloadKind::Spliced`], all of them on the heap.
    pub inline: usize,
}
