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

/// What a chunk of `len` bytes takes from the inner backend: 4 more bytes if it
/// is shifted, rounded up to 8, at an alignment of at least 8. Every inner chunk
/// is then 8-aligned, so a chunk id at 4 mod 8 is always a shifted one, and
/// `free` can tell them apart from the id alone.
fn inner_layout(
    len: NonZeroUsize,
    align: AllocAlignment,
    shifted: bool,
) -> Result<MemoryLayout, ZLayoutError> {
    let extra = if shifted { SHIFT } else { 0 };
    let inner_len = len
        .get()
        .checked_add(extra + 7)
        .ok_or(ZLayoutError::IncorrectLayoutArgs)?
        & !7;
    let align = align.max(AllocAlignment::ALIGN_8_BYTES);
    // An alignment above 8 already made `len` a multiple of it.
    MemoryLayout::new(inner_len, align)
}

/// The POSIX (talc) backend, with message chunks shifted by 4 bytes.
pub struct CdrBackend {
    inner: PosixShmProviderBackend,
}

// By hand: Zenoh 1.9's POSIX backend has no `Debug`.
impl std::fmt::Debug for CdrBackend {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("CdrBackend")
            .field("protocol", &self.inner.id())
            .finish_non_exhaustive()
    }
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
        let shift = shifted(layout);
        let len = layout.size();
        let inner = inner_layout(len, layout.alignment(), shift)
            .map_err(|_| zenoh::shm::ZAllocError::Other)?;
        let chunk = self.inner.alloc(&inner)?;
        let offset = if shift { SHIFT } else { 0 };
        // The chunk id is the byte offset in the segment (the POSIX segment is an
        // array of bytes), so the shifted chunk is the same segment at +4.
        let Some(id) = chunk.descriptor.chunk.checked_add(offset as u32) else {
            self.inner.free(&chunk.descriptor);
            return Err(zenoh::shm::ZAllocError::Other);
        };
        let base = chunk.data.ptr();
        // `wrapping_add`: no `unsafe` needed to compute the address; it is in
        // bounds, since the inner chunk is at least `len + offset` bytes long.
        let data = PtrInSegment::new(base.wrapping_add(offset).cast_mut(), Arc::new(chunk.data));
        Ok(AllocatedChunk::new(
            ChunkDescriptor::new(chunk.descriptor.segment, id, len),
            data,
        ))
    }

    fn free(&self, chunk: &ChunkDescriptor) {
        // Inner chunks are 8-aligned, so a chunk id at 4 mod 8 is a shifted one.
        let shift = chunk.chunk as usize % 8 == SHIFT;
        let offset = if shift { SHIFT as u32 } else { 0 };
        // `alloc` succeeded with this length, so its inner layout exists (an
        // explicit alignment above 8 only changes where, not how much).
        if let Ok(inner) = inner_layout(chunk.len, AllocAlignment::ALIGN_1_BYTE, shift) {
            let inner = ChunkDescriptor::new(chunk.segment, chunk.chunk - offset, inner.size());
            self.inner.free(&inner);
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
        inner_layout(layout.size(), layout.alignment(), shifted(&layout))?;
        Ok(layout)
    }
}
