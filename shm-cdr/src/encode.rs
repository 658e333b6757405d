//! Writing: the [`CdrEncode`] trait and the bounds-checked [`Writer`].

use std::marker::PhantomData;
use std::mem::MaybeUninit;

use crate::endian::ByteOrder;
use crate::error::{EncodeError, EncodeErrorKind};
use crate::layout::{
    align_up, plain_bytes, uninit_view, write_bytes_into, zeroed_bytes, FixedLayout, PlainLayout,
};
use crate::splice::{SpliceSink, SpliceSizing};

/// A value with a CDR encoding and an exact encoded size.
///
/// # Invariant
/// For every value and every start position `p` (counted from the byte after the
/// encapsulation header), `encode` called on a writer at position `p` either fails
/// or leaves it at exactly `encoded_end(p)`; and when [`Self::FIXED_LAYOUT`] is
/// `Some(l)`, `encoded_end(p) == l.end(p)` for every value. The property tests and
/// the fuzz targets check this for every shape the derive produces.
#[diagnostic::on_unimplemented(
    message = "`{Self}` has no CDR encoding",
    label = "no CDR encoding",
    note = "field types must be ROS 2 types: numbers, bool, strings, sequences, arrays, or structs with #[derive(RosMessage)]"
)]
pub trait CdrEncode {
    /// Set when the encoded size never depends on the value, only on the start
    /// phase. Lets sequences and arrays of this type be sized in O(1).
    const FIXED_LAYOUT: Option<FixedLayout> = None;

    /// Set when a `Self` in memory is its CDR encoding (numbers, and structs and
    /// arrays packed from them): sequences of it are then copied in bulk whenever
    /// their start phase allows. See [`PlainLayout`] for the proof it carries.
    const PLAIN: Option<PlainLayout<Self>> = None;

    /// Set when a value of this type may hold a run a [splicing](crate::splice)
    /// write leaves out: a type that splices, and every sequence, array and
    /// struct that holds one. Every other type sizes and writes as it always
    /// does, whoever asks.
    const SPLICES: bool = false;

    /// The position after this value when it is encoded starting at `start`.
    fn encoded_end(&self, start: usize) -> usize;

    /// Write this value at the writer's position, zeroing every padding byte.
    fn encode<B: ByteOrder>(&self, w: &mut Writer<'_, B>) -> Result<(), EncodeError>;

    /// The position after this value when a [splicing](crate::splice) write
    /// encodes it from `start`: each run left out counts its filler only, and
    /// is tallied in `sizing`. [`encoded_end`](Self::encoded_end) unless
    /// [`SPLICES`](Self::SPLICES).
    #[inline]
    fn spliced_end(&self, start: usize, sizing: &mut SpliceSizing) -> usize {
        let _ = sizing;
        self.encoded_end(start)
    }

    /// Write this value as a [splicing](crate::splice) write does: each run
    /// left out goes to `sink`, with only its filler written.
    /// [`encode`](Self::encode) unless [`SPLICES`](Self::SPLICES).
    #[inline]
    fn encode_spliced<B: ByteOrder>(
        &self,
        w: &mut Writer<'_, B>,
        sink: &mut dyn SpliceSink,
    ) -> Result<(), EncodeError> {
        let _ = sink;
        self.encode(w)
    }

    /// The position after the elements of a sequence or array starting at `start`
    /// (no length prefix). O(1) for fixed-layout types.
    #[inline]
    fn slice_encoded_end(items: &[Self], start: usize) -> usize
    where
        Self: Sized,
    {
        match Self::FIXED_LAYOUT {
            Some(layout) => layout.repeat_end(start, items.len()),
            None => items.iter().fold(start, |pos, item| item.encoded_end(pos)),
        }
    }

    /// Write the elements of a sequence or array (no length prefix): one copy when
    /// the type is [plain](Self::PLAIN) and the byte order is the host's, element by
    /// element otherwise. A plain run whose first element starts at a phase where
    /// memory and wire layout differ (e.g. `{Time, f64}` right after a `u32` count)
    /// writes its first elements one by one until the stream reaches a phase where
    /// they agree, then copies the rest at once.
    #[inline]
    fn encode_slice<B: ByteOrder>(items: &[Self], w: &mut Writer<'_, B>) -> Result<(), EncodeError>
    where
        Self: Sized,
    {
        let mut rest = items;
        if let (true, Some(plain)) = (B::NATIVE, Self::PLAIN) {
            // The phase repeats with period 8, so 8 elements always suffice to find
            // a matching phase if there is one.
            for _ in 0..8 {
                let Some((first, others)) = rest.split_first() else {
                    return Ok(());
                };
                if plain.bulk_at(w.position()) {
                    return w.write_aligned(plain.first_align(), plain_bytes(plain, rest));
                }
                first.encode(w)?;
                rest = others;
            }
        }
        rest.iter().try_for_each(|item| item.encode(w))
    }
}

/// Zero alignment padding (0 to 7 bytes) with fixed-size stores: a plain loop or
/// `fill` becomes a call into `memset` for every padded field.
#[inline(always)]
pub(crate) fn zero_padding(padding: &mut [MaybeUninit<u8>]) {
    const ZERO: MaybeUninit<u8> = MaybeUninit::new(0);
    let n = padding.len();
    if n > 8 {
        zero_long_padding(padding);
    } else if n >= 4 {
        padding[..4].copy_from_slice(&[ZERO; 4]);
        padding[n - 4..].copy_from_slice(&[ZERO; 4]);
    } else if n > 0 {
        padding[0] = ZERO;
        padding[n / 2] = ZERO;
        padding[n - 1] = ZERO;
    }
}

/// Padding to an alignment above 8, which CDR never asks for (a caller of
/// [`Writer::aligned_slot`] may): kept out of line so the common case stays small.
#[cold]
#[inline(never)]
fn zero_long_padding(padding: &mut [MaybeUninit<u8>]) {
    padding.fill(MaybeUninit::new(0));
}

/// Writes CDR into a caller-provided buffer. Never writes outside it: a write that
/// does not fit returns [`EncodeErrorKind::BufferTooSmall`].
///
/// Positions are counted from the byte after the encapsulation header, which is
/// where CDR alignment is measured from.
pub struct Writer<'a, B: ByteOrder> {
    /// Invariant: when an encode returns `Ok`, `buf[..pos]` is initialized; and
    /// the writer never stores an uninitialized byte anywhere. Every public method
    /// that moves `pos` initializes (copies in or zeroes) all the bytes it moves
    /// over before it returns, and a method that fails does not move it; the
    /// crate's string encoders, through
    /// [`aligned_slot_uninit`](Self::aligned_slot_uninit), write their slots in
    /// full even when they fail (a caller's own `encode` may swallow an error).
    buf: &'a mut [MaybeUninit<u8>],
    pos: usize,
    order: PhantomData<B>,
}

impl<'a, B: ByteOrder> Writer<'a, B> {
    /// A writer over the message body (the bytes after the encapsulation header).
    pub fn new(body: &'a mut [u8]) -> Self {
        // SAFETY: the writer stores only initialized bytes (its invariant), so
        // `body` is still initialized when the borrow ends.
        #[allow(unsafe_code)]
        let body = unsafe { uninit_view(body) };
        Self::over_uninit(body)
    }

    /// A writer over memory that need not be initialized (a `Vec`'s spare
    /// capacity): after encoding, the first [`position`](Self::position) bytes are.
    pub(crate) fn over_uninit(body: &'a mut [MaybeUninit<u8>]) -> Self {
        Self {
            buf: body,
            pos: 0,
            order: PhantomData,
        }
    }

    /// The current position, counted from the start of the body.
    #[inline(always)]
    pub fn position(&self) -> usize {
        self.pos
    }

    #[cold]
    fn too_small(&self) -> EncodeError {
        // The exact total is filled in by the top-level entry point, which knows the
        // message; here we only know that the buffer ran out.
        EncodeError::new(EncodeErrorKind::BufferTooSmall {
            needed: self.buf.len() + 1,
            available: self.buf.len(),
        })
    }

    /// Zero `pad` padding bytes and step over `len` more, returning those `len`
    /// bytes, which the caller must initialize before returning (the invariant).
    #[inline(always)]
    fn reserve_uninit(
        &mut self,
        pad: usize,
        len: usize,
    ) -> Result<&mut [MaybeUninit<u8>], EncodeError> {
        let start = self.pos;
        let end = start
            .checked_add(pad + len)
            .ok_or_else(|| self.too_small())?;
        if end > self.buf.len() {
            return Err(self.too_small());
        }
        self.pos = end;
        let (padding, slot) = self.buf[start..end].split_at_mut(pad);
        // Buffers (shared-memory pools especially) are reused: padding must not leak
        // whatever the previous message left there.
        zero_padding(padding);
        Ok(slot)
    }

    /// Reserve `pad` zeroed padding bytes followed by `len` zeroed bytes, returning
    /// the latter.
    #[inline(always)]
    pub(crate) fn reserve(&mut self, pad: usize, len: usize) -> Result<&mut [u8], EncodeError> {
        Ok(zeroed_bytes(self.reserve_uninit(pad, len)?))
    }

    /// Write one primitive of `N` bytes (already in wire byte order), aligned to `N`.
    #[inline(always)]
    pub fn write_primitive<const N: usize>(&mut self, bytes: [u8; N]) -> Result<(), EncodeError> {
        let pad = align_up(self.pos, N) - self.pos;
        self.reserve_uninit(pad, N)?
            .copy_from_slice(&bytes.map(MaybeUninit::new));
        Ok(())
    }

    /// Write raw bytes with no alignment (string contents, `u8` sequences).
    #[inline(always)]
    pub fn write_bytes(&mut self, bytes: &[u8]) -> Result<(), EncodeError> {
        write_bytes_into(self.reserve_uninit(0, bytes.len())?, bytes);
        Ok(())
    }

    /// Align to `align` (a power of two), zeroing the padding, and copy `bytes`
    /// there: a run of plain values in one copy.
    #[inline(always)]
    pub fn write_aligned(&mut self, align: usize, bytes: &[u8]) -> Result<(), EncodeError> {
        let pad = align_up(self.pos, align) - self.pos;
        write_bytes_into(self.reserve_uninit(pad, bytes.len())?, bytes);
        Ok(())
    }

    /// [`aligned_slot`](Self::aligned_slot) without zeroing the slot first, for
    /// strings (prefix, contents and NUL written once). The caller must write
    /// every byte of the slot before it returns, even when it returns an error
    /// (which a user's `encode` may swallow): `to_vec` hands out the bytes before
    /// the position as initialized.
    #[inline(always)]
    pub(crate) fn aligned_slot_uninit(
        &mut self,
        align: usize,
        len: usize,
    ) -> Result<&mut [MaybeUninit<u8>], EncodeError> {
        let pad = align_up(self.pos, align) - self.pos;
        self.reserve_uninit(pad, len)
    }

    /// Align to `align` (a power of two), zeroing the padding, and return a slot of
    /// `len` bytes to fill completely. The slot comes zeroed; to copy bytes that
    /// are already laid out, [`write_aligned`](Self::write_aligned) writes once.
    #[inline(always)]
    pub fn aligned_slot(&mut self, align: usize, len: usize) -> Result<&mut [u8], EncodeError> {
        let pad = align_up(self.pos, align) - self.pos;
        self.reserve(pad, len)
    }

    /// Align to `align`, zeroing the padding, and step over `len` bytes
    /// without writing them: they keep what the buffer holds there (an
    /// array someone fills in place). Returns where they start.
    ///
    /// # Safety
    /// The writer must be over initialized bytes (made by [`new`](Self::new)),
    /// so that the bytes stepped over are initialized, as the writer's
    /// invariant requires of every byte before its position.
    #[allow(unsafe_code)]
    pub(crate) unsafe fn skip_in_place(
        &mut self,
        align: usize,
        len: usize,
    ) -> Result<usize, EncodeError> {
        let pad = align_up(self.pos, align) - self.pos;
        let start = self.pos + pad;
        self.reserve_uninit(pad, len)?;
        Ok(start)
    }

    /// Write a `u32` length prefix, rejecting lengths that do not fit.
    #[inline(always)]
    pub fn write_len(&mut self, len: usize) -> Result<(), EncodeError> {
        let len = u32::try_from(len)
            .map_err(|_| EncodeError::new(EncodeErrorKind::LengthOverflow { len }))?;
        self.write_primitive(if B::LITTLE {
            len.to_le_bytes()
        } else {
            len.to_be_bytes()
        })
    }
}
