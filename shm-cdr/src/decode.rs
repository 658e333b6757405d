//! Reading: the [`CdrDecode`] trait and the bounds-checked [`Reader`].

use std::marker::PhantomData;

use crate::endian::ByteOrder;
use crate::error::{DecodeError, DecodeErrorKind};
use crate::layout::{align_up, plain_extend, plain_slice, PlainLayout};

/// Size of the encapsulation header, the origin of error offsets.
pub(crate) const HEADER_LEN: usize = 4;

/// A value that can be read from CDR, possibly borrowing from the input (`'de`).
///
/// Implementations never panic and never allocate more than the remaining input
/// justifies: a sequence checks `count × MIN_WIRE_SIZE ≤ remaining` before it
/// reserves anything.
#[diagnostic::on_unimplemented(
    message = "`{Self}` cannot be decoded from CDR",
    label = "no CDR decoding",
    note = "borrowed fields can be &str, &[u8], Cow<str> or Cow<[T]>; other field types must be owned (Vec<T>, String, ...) or derive RosMessage"
)]
pub trait CdrDecode<'de>: Sized {
    /// The fewest bytes one value can take on the wire (at least 1).
    const MIN_WIRE_SIZE: usize;

    /// Set when every CDR encoding of `Self` is a valid `Self` in memory, so
    /// sequences of it are read with one copy (see [`PlainLayout`]).
    const PLAIN: Option<PlainLayout<Self>> = None;

    /// Read one value at the reader's position.
    fn decode<B: ByteOrder>(r: &mut Reader<'de, B>) -> Result<Self, DecodeError>;

    /// Read one value into `self`, reusing the memory it owns: strings and vectors
    /// keep their capacity, through derived structs, sequences and arrays, so a
    /// subscriber that decodes every message into the same value stops allocating
    /// once it has seen the largest one. The value read equals
    /// [`decode`](Self::decode)'s. On error, `self` is left valid, holding an
    /// unspecified mix of old and new contents.
    ///
    /// The default replaces `self` with [`decode`](Self::decode)'s result: right
    /// for types that own no memory.
    #[inline]
    fn decode_into<B: ByteOrder>(&mut self, r: &mut Reader<'de, B>) -> Result<(), DecodeError> {
        *self = Self::decode(r)?;
        Ok(())
    }

    /// Read `n` consecutive values (the caller has checked `n` against the input):
    /// one copy for [plain](Self::PLAIN) types in host byte order, element by
    /// element otherwise. As in
    /// [`CdrEncode::encode_slice`](crate::CdrEncode::encode_slice), a plain run
    /// that starts at a phase where memory and wire layout differ reads its first
    /// elements one by one until they agree.
    #[inline]
    fn decode_vec<B: ByteOrder>(
        r: &mut Reader<'de, B>,
        n: usize,
    ) -> Result<Vec<Self>, DecodeError> {
        // Allocated at its size at once (`n` is bounded by the input): an
        // empty vector reserved for `n` takes the growth path.
        let mut out = Vec::with_capacity(n);
        extend_decoded(r, n, &mut out)?;
        Ok(out)
    }

    /// Read a fixed array of `N` values. Numbers override this with one copy onto
    /// the stack; other types read element by element.
    #[inline]
    fn decode_array<B: ByteOrder, const N: usize>(
        r: &mut Reader<'de, B>,
    ) -> Result<[Self; N], DecodeError> {
        let at = r.position();
        let items = Self::decode_vec(r, N)?;
        let got = items.len();
        <[Self; N]>::try_from(items).map_err(|_| {
            // Only a faulty `decode_vec` returns another count; report, don't panic.
            r.error_at(
                at,
                DecodeErrorKind::UnexpectedEof {
                    needed: N,
                    remaining: got,
                },
            )
        })
    }

    /// Read `n` consecutive values into a [`std::borrow::Cow`]: borrowed from the
    /// input when they lie there as `&[Self]` would, copied otherwise.
    ///
    /// They are borrowed, in O(1), when `Self` is [plain](Self::PLAIN) (numbers,
    /// structs packed from them), the input is in the host's byte order, the run
    /// starts at a phase where memory and wire layout agree, and its first byte is
    /// aligned for `Self` in memory. A shared-memory payload from shm-runtime
    /// (body 8-aligned) meets the last condition for every type; a payload from
    /// elsewhere may not (an `f64` run 4 bytes off its alignment), and is then
    /// copied: `Cow::Borrowed` or `Cow::Owned` says which happened.
    #[inline]
    fn decode_cow_slice<B: ByteOrder>(
        r: &mut Reader<'de, B>,
        n: usize,
    ) -> Result<std::borrow::Cow<'de, [Self]>, DecodeError>
    where
        Self: Clone,
    {
        if let (true, Some(plain)) = (B::NATIVE, Self::PLAIN) {
            if n > 0 && plain.bulk_at(r.position()) {
                let at = r.position();
                let len = n.saturating_mul(std::mem::size_of::<Self>());
                let bytes = r.read_aligned_bytes(plain.first_align(), len)?;
                if let Some(items) = plain_slice(plain, bytes) {
                    return Ok(std::borrow::Cow::Borrowed(items));
                }
                // `n` elements were just read: room for them is no more
                // than the input holds.
                let mut out = Vec::with_capacity(n);
                return match plain_extend(plain, &mut out, bytes, n) {
                    Some(()) => Ok(std::borrow::Cow::Owned(out)),
                    None => Err(r.error_at(
                        at,
                        DecodeErrorKind::UnexpectedEof {
                            needed: len,
                            remaining: bytes.len(),
                        },
                    )),
                };
            }
        }
        Self::decode_vec(r, n).map(std::borrow::Cow::Owned)
    }
}

/// A type that decodes without borrowing from the input.
pub trait DecodeOwned: for<'de> CdrDecode<'de> {}
impl<T: for<'de> CdrDecode<'de>> DecodeOwned for T {}

/// Most segments a [`Reader`] walks (a spliced payload has two per shared-memory
/// field, plus one).
pub const MAX_SEGMENTS: usize = 16;

/// Append `n` values read from `r` to `out` (the caller has checked `n` against
/// the input, so reserving for them is bounded by it). The body of
/// [`CdrDecode::decode_vec`], shared with [`CdrDecode::decode_into`] for vectors.
#[inline]
pub(crate) fn extend_decoded<'de, T: CdrDecode<'de>, B: ByteOrder>(
    r: &mut Reader<'de, B>,
    n: usize,
    out: &mut Vec<T>,
) -> Result<(), DecodeError> {
    let end = out.len() + n;
    out.reserve(n);
    if let (true, Some(plain)) = (B::NATIVE, T::PLAIN) {
        // The phase repeats with period 8, so 8 elements always suffice to find a
        // matching phase if there is one.
        for _ in 0..8 {
            let left = end - out.len();
            if left == 0 {
                return Ok(());
            }
            if plain.bulk_at(r.position()) {
                let len = left.saturating_mul(std::mem::size_of::<T>());
                let at = r.position();
                let bytes = r.read_aligned_bytes(plain.first_align(), len)?;
                return match plain_extend(plain, out, bytes, left) {
                    Some(()) => Ok(()),
                    None => Err(r.error_at(
                        at,
                        DecodeErrorKind::UnexpectedEof {
                            needed: len,
                            remaining: bytes.len(),
                        },
                    )),
                };
            }
            out.push(T::decode(r)?);
        }
    }
    while out.len() < end {
        out.push(T::decode(r)?);
    }
    Ok(())
}

/// Reads CDR from a byte slice, or from a few consecutive slices (a payload that
/// arrived in fragments), checking every access.
///
/// Positions are stream positions counted from the byte after the encapsulation
/// header, so alignment is right across fragments; error offsets are reported from
/// the start of the whole input.
pub struct Reader<'de, B: ByteOrder> {
    /// The current segment.
    data: &'de [u8],
    /// Stream position of `data[0]`.
    base: usize,
    /// Stream position of the next byte to read.
    pos: usize,
    /// Stream length over all segments.
    end: usize,
    /// Segments after the current one; `None` for a single slice, so the common
    /// case costs nothing to set up.
    rest: Option<Box<[&'de [u8]]>>,
    /// Index in `rest` of the next segment.
    next: usize,
    /// The input lies in memory other processes may write (see [`shared`](Self::shared)).
    shared: bool,
    order: PhantomData<B>,
}

impl<'de, B: ByteOrder> Reader<'de, B> {
    /// A reader over a message body (the bytes after the encapsulation header).
    pub fn new(body: &'de [u8]) -> Self {
        Self {
            data: body,
            base: 0,
            pos: 0,
            end: body.len(),
            rest: None,
            next: 0,
            shared: false,
            order: PhantomData,
        }
    }

    /// Mark the input as memory other processes may write while what is
    /// decoded from it lives (shared memory): what must be checked to be valid
    /// is copied first and checked in the copy. Strings are: a `Cow<str>`
    /// field is read owned, a `&str` field is a
    /// [`DecodeErrorKind::SharedBorrow`] error. Byte and number slices still
    /// borrow: every bit pattern is a valid value of them, so a rewrite can
    /// change what they read, never make it invalid.
    pub fn shared(mut self) -> Self {
        self.shared = true;
        self
    }

    /// Whether the input is [shared](Self::shared).
    #[inline(always)]
    pub fn is_shared(&self) -> bool {
        self.shared
    }

    /// A reader over a body that arrived as consecutive segments. Values inside one
    /// segment are borrowed from it; a value that straddles two segments is a
    /// [`DecodeErrorKind::Fragmented`] error (then decode a contiguous copy).
    /// `None` if there are more than [`MAX_SEGMENTS`] segments.
    pub fn from_segments(segments: &[&'de [u8]]) -> Option<Self> {
        let (first, others) = segments.split_first()?;
        if segments.len() > MAX_SEGMENTS {
            return None;
        }
        let mut reader = Self::new(first);
        reader.end += others.iter().map(|s| s.len()).sum::<usize>();
        reader.rest = Some(others.into());
        Some(reader)
    }

    /// The current position, counted from the start of the body.
    #[inline(always)]
    pub fn position(&self) -> usize {
        self.pos
    }

    /// Bytes left after the current position.
    #[inline(always)]
    pub fn remaining(&self) -> usize {
        self.end - self.pos
    }

    /// A reader over one contiguous body, at position `pos` (clamped to its
    /// end): to read again, later, what a first pass checked.
    pub(crate) fn at(body: &'de [u8], pos: usize, shared: bool) -> Self {
        let mut reader = Self::new(body);
        reader.pos = pos.min(reader.end);
        reader.shared = shared;
        reader
    }

    /// Go back to `pos`, a position this reader was at before: to read again
    /// what a quick check refused, for the exact error. Only for readers over
    /// one contiguous body ([`at`](Self::at)).
    #[inline]
    pub(crate) fn rewind(&mut self, pos: usize) {
        debug_assert!(self.rest.is_none() && pos <= self.pos);
        self.pos = pos.min(self.end);
    }

    /// Whether the body is one contiguous slice (not [segments](Self::from_segments)),
    /// so that [`rewind`](Self::rewind) may be used.
    #[inline(always)]
    pub(crate) fn is_contiguous(&self) -> bool {
        self.rest.is_none()
    }

    /// An error of `kind` at body position `pos`.
    #[cold]
    pub fn error_at(&self, pos: usize, kind: DecodeErrorKind) -> DecodeError {
        DecodeError::new(kind, pos + HEADER_LEN)
    }

    /// Skip the padding before a value aligned to `align`, then take `len` bytes.
    #[inline(always)]
    fn take_aligned(&mut self, align: usize, len: usize) -> Result<&'de [u8], DecodeError> {
        let start = align_up(self.pos, align);
        let lo = start - self.base;
        match lo.checked_add(len) {
            Some(hi) if hi <= self.data.len() => {
                self.pos = start + len;
                Ok(&self.data[lo..hi])
            }
            _ => self.take_slow(start, len),
        }
    }

    /// `take_aligned` when the value is not in the current segment: move to the
    /// segment that holds its start, or report why it cannot be read.
    #[cold]
    fn take_slow(&mut self, start: usize, len: usize) -> Result<&'de [u8], DecodeError> {
        match start.checked_add(len) {
            Some(stop) if stop <= self.end => {}
            _ => {
                return Err(self.error_at(
                    self.pos,
                    DecodeErrorKind::UnexpectedEof {
                        needed: start.saturating_add(len) - self.pos,
                        remaining: self.remaining(),
                    },
                ))
            }
        }
        if let Some(rest) = &self.rest {
            while start >= self.base + self.data.len() && self.next < rest.len() {
                self.base += self.data.len();
                self.data = rest[self.next];
                self.next += 1;
            }
        }
        let lo = start - self.base;
        match self.data.get(lo..lo + len) {
            Some(bytes) => {
                self.pos = start + len;
                Ok(bytes)
            }
            None => Err(self.error_at(start, DecodeErrorKind::Fragmented { len })),
        }
    }

    /// Read one primitive of `N` bytes aligned to `N`, in wire byte order.
    #[inline(always)]
    pub fn read_primitive<const N: usize>(&mut self) -> Result<[u8; N], DecodeError> {
        let start = align_up(self.pos, N);
        // No overflow: `start` is at most 7 bytes past a position inside the input.
        let lo = start - self.base;
        let bytes = match self.data.get(lo..lo + N) {
            Some(bytes) => {
                self.pos = start + N;
                bytes
            }
            None => self.take_slow(start, N)?,
        };
        let mut out = [0u8; N];
        out.copy_from_slice(bytes);
        Ok(out)
    }

    /// Take `len` raw bytes with no alignment, borrowed from the input.
    #[inline(always)]
    pub fn read_bytes(&mut self, len: usize) -> Result<&'de [u8], DecodeError> {
        self.take_aligned(1, len)
    }

    /// Skip to `align`, then take `len` bytes borrowed from the input.
    #[inline(always)]
    pub fn read_aligned_bytes(
        &mut self,
        align: usize,
        len: usize,
    ) -> Result<&'de [u8], DecodeError> {
        self.take_aligned(align, len)
    }

    /// Read a `u32` element count and check that `count` elements of at least
    /// `min_element_size` bytes fit in the rest of the input, so that nothing is
    /// allocated on the word of a hostile length prefix.
    #[inline(always)]
    pub fn read_count(&mut self, min_element_size: usize) -> Result<usize, DecodeError> {
        let at = self.pos;
        let count = u32::from_ne_bytes(self.read_primitive::<4>()?);
        let count = if B::NATIVE { count } else { count.swap_bytes() };
        let min = min_element_size.max(1);
        let remaining = self.remaining();
        // Checked: on 32-bit targets count × min can exceed usize.
        match (count as usize).checked_mul(min) {
            Some(needed) if needed <= remaining => Ok(count as usize),
            _ => Err(self.error_at(
                at,
                DecodeErrorKind::LengthExceedsInput {
                    count,
                    min_element_size: min,
                    remaining,
                },
            )),
        }
    }
}
