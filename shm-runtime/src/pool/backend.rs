//! A POSIX shared-memory backend whose message chunks put the CDR body on an
//! 8-byte boundary.
//!
//! A CDR message is a 4-byte encapsulation header, then a body in which every
//! primitive is aligned to its size counted from the body's first byte. In a chunk
//! that starts on an 8-byte boundary (Zenoh's allocator hands those out), the body
//! starts at 4 mod 8, so every `f64`, `i64` and `u64` of the message sits 4 bytes
//! off its natural alignment: a `float64[]` can then be neither written through a
//! `&mut [f64]` in place (loans) nor read as a `&[f64]` (typed borrows).
//!
//! This backend places chunks requested with no alignment (Zenoh's default) at an
//! address that is 4 mod 8, so the body of a message written there starts on an
//! 8-byte boundary and every primitive in it is naturally aligned in memory. It
//! takes 4 more bytes from the inner allocator (8-byte aligned) and hands out the
//! chunk from its fifth byte; the chunk id Zenoh sends to readers is the offset in
//! the segment, so readers in any process (rmw_zenoh_cpp's too) map the same
//! address: the payload stays one contiguous shared-memory buffer of exactly the
//! requested size. Requests with an explicit alignment are passed through
//! unshifted (Zenoh requires their size to be a multiple of it).

use std::num::NonZeroUsize;
use std::sync::Arc;

use zenoh::shm::{
    AllocAlignment, AllocatedChunk, ChunkAllocResult, ChunkDescriptor, MemoryLayout,
    PosixShmProviderBackend, ProtocolID, PtrInSegment, ShmProviderBackend, WithProtocolID,
    ZLayoutError,
};

/// The shift: the length of the CDR encapsulation header.
const SHIFT: usize = 4;

/// What a shifted chunk of `len` bytes takes from the inner backend: 4 more
/// bytes, rounded up to 8 (Zenoh wants a size that is a multiple of the
/// alignment).
fn outer_layout(len: NonZeroUsize) -> Result<MemoryLayout, ZLayoutError> {
    let outer_len = len
        .get()
        .checked_add(SHIFT + 7)
        .ok_or(ZLayoutError::IncorrectLayoutArgs)?
        & !7;
    MemoryLayout::new(outer_len, AllocAlignment::ALIGN_8_BYTES)
}

/// The POSIX (talc) backend, with message chunks shifted by 4 bytes.
#[derive(Debug)]
pub struct CdrBackend {
    inner: PosixShmProviderBackend,
}

impl CdrBackend {
    pub(crate) fn new(inner: PosixShmProviderBackend) -> Self {
        Self { inner }
    }
}

/// Requests with no alignment (Zenoh's default, which must also be the layout's
/// size granularity) are shifted; explicit alignments are honoured as asked.
fn shifted(layout: &MemoryLayout) -> bool {
    layout.alignment() == AllocAlignment::ALIGN_1_BYTE
}

impl WithProtocolID for CdrBackend {
    fn id(&self) -> ProtocolID {
        // The chunks are ordinary POSIX chunks: readers map them with Zenoh's
        // POSIX client.
        self.inner.id()
    }
}

impl ShmProviderBackend for CdrBackend {
    fn alloc(&self, layout: &MemoryLayout) -> ChunkAllocResult {
        if !shifted(layout) {
            return self.inner.alloc(layout);
        }
        let len = layout.size();
        let outer = outer_layout(len).map_err(|_| zenoh::shm::ZAllocError::Other)?;
        let chunk = self.inner.alloc(&outer)?;
        // The chunk id is the byte offset in the segment (the POSIX segment is an
        // array of bytes), so the shifted chunk is the same segment at +4.
        let Some(id) = chunk.descriptor.chunk.checked_add(SHIFT as u32) else {
            self.inner.free(&chunk.descriptor);
            return Err(zenoh::shm::ZAllocError::Other);
        };
        let base = chunk.data.ptr();
        // `wrapping_add`: no `unsafe` needed to compute the address; it is in
        // bounds, since the inner chunk is `len + 4` bytes long.
        let data = PtrInSegment::new(base.wrapping_add(SHIFT).cast_mut(), Arc::new(chunk.data));
        Ok(AllocatedChunk::new(
            ChunkDescriptor::new(chunk.descriptor.segment, id, len),
            data,
        ))
    }

    fn free(&self, chunk: &ChunkDescriptor) {
        // Inner chunks are 8-aligned, so a chunk id at 4 mod 8 is one of ours.
        if chunk.chunk as usize % 8 != SHIFT {
            return self.inner.free(chunk);
        }
        // `alloc` succeeded with this length, so its outer layout exists.
        if let Ok(outer) = outer_layout(chunk.len) {
            let outer =
                ChunkDescriptor::new(chunk.segment, chunk.chunk - SHIFT as u32, outer.size());
            self.inner.free(&outer);
        }
    }

    fn defragment(&self) -> usize {
        self.inner.defragment().saturating_sub(SHIFT)
    }

    fn available(&self) -> usize {
        self.inner.available()
    }

    fn layout_for(&self, layout: MemoryLayout) -> Result<MemoryLayout, ZLayoutError> {
        // Kept as asked: talc honours any alignment in `alloc`, and a shifted
        // chunk's extra bytes are added there. (The inner `layout_for` refuses
        // any alignment above the one the backend was built with, 1.)
        if shifted(&layout) {
            outer_layout(layout.size())?;
        }
        Ok(layout)
    }
}
