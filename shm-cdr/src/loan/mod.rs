//! Messages built in place: lay a message out in its final buffer from the lengths
//! of its strings and sequences, then write every field straight where it goes.
//!
//! `#[derive(RosMessage)]` with `#[ros(loan)]` on a struct `Foo` (with no generic
//! parameters) also generates `FooLens`, the lengths of its variable parts, and
//! `FooMut<'a>`, write access to every field at its final offset, and implements
//! [`InPlace`]. Every generated standard interface has it:
//!
//! ```
//! use shm_cdr::loan::{self, InPlace};
//! use shm_cdr::RosMessage;
//!
//! #[derive(RosMessage, Debug, Default, PartialEq)]
//! #[ros(type_name = "my_pkg/msg/Scan", loan)]
//! struct Scan {
//!     frame_id: String,
//!     angle_min: f32,
//!     ranges: Vec<f32>,
//!     poses: Vec<f64>,
//! }
//!
//! let lens = ScanLens { frame_id: 5, ranges: 1080, poses: 3, ..Default::default() };
//! let mut buffer = loan::AlignedBuffer::new(loan::encoded_size::<Scan>(&lens)?);
//! let written = loan::Written::new();
//! let scan = loan::carve::<Scan>(&lens, buffer.as_mut_slice(), &written)?;
//! *scan.angle_min = -1.5;
//! scan.frame_id.write("laser")?;
//! let ranges = scan.ranges.write_with(|i| i as f32 * 0.01); // in place, no copy
//! ranges[0] = 0.5;
//! scan.poses.write_slice(&[1.0, 2.0, 3.0])?;
//! written.check()?; // every string and sequence was written
//!
//! let expected = Scan {
//!     frame_id: "laser".into(),
//!     angle_min: -1.5,
//!     ranges: (0..1080).map(|i| if i == 0 { 0.5 } else { i as f32 * 0.01 }).collect(),
//!     poses: vec![1.0, 2.0, 3.0],
//! };
//! assert_eq!(buffer.as_slice(), shm_cdr::to_vec(&expected)?); // byte for byte
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! What goes where:
//! - numbers are `&mut` references into the buffer, zero until set; a `bool`
//!   is a [`LoanBool`] (`set`/`get`), since the buffer may be shared memory
//!   that another process can write, and a byte there need not be a `bool`;
//! - a sequence (or array) of numbers, or of structs whose memory layout is their
//!   CDR layout ([`PlainLayout`](crate::layout::PlainLayout)), is an [`Uninit`]
//!   run: write it once (from a slice, a function of the index, an iterator, a
//!   value) and get a `&mut [T]` lying in the buffer; nothing is copied later;
//! - a string is a [`StrSlot`] of the stated length;
//! - a nested message is its own `…Mut`; a sequence of messages that cannot be
//!   written as one run is a `Vec` of them ([`Run`]).
//!
//! The buffer's body (after the 4-byte header) must be 8-aligned in memory, so that
//! every number in it is naturally aligned: [`AlignedBuffer`] on the heap, and
//! shm-runtime's shared-memory chunks, are laid out that way. Padding is zeroed;
//! strings and runs count as unwritten until written, and [`Written::check`] says
//! how many are left, so a message never goes out with stale bytes from a previous
//! one. The byte order is the host's (named in the header), so on every common host
//! the result is byte for byte what [`to_vec`](crate::to_vec) writes.

use std::cell::Cell;
use std::fmt;

use crate::decode::HEADER_LEN;
use crate::encode::CdrEncode;
use crate::endian::Endianness;
use crate::layout::align_up;

mod slots;
#[cfg(all(test, feature = "msgs"))]
mod tests;

pub use slots::{AlignedBuffer, LoanBool, Run, SeqLens, StrSlot, Uninit, WStrSlot};

/// A field type that can be laid out in a buffer from its lengths alone, and
/// then written in place.
///
/// # Invariant
/// For every value `v` and start position `p`:
/// `end_in_place(&v.lens(), p) == Some(v.encoded_end(p))`, and carving
/// `v.lens()` at `p` then [`write_in_place`](Self::write_in_place) leaves exactly
/// the bytes `encode` writes (in the host's byte order). The property tests check
/// it for every shape the derive produces.
#[diagnostic::on_unimplemented(
    message = "`{Self}` cannot be built in place",
    label = "no in-place layout",
    note = "numbers, bool, strings, sequences, arrays and structs with #[derive(RosMessage)] and #[ros(loan)] can: add `loan` to the nested message's #[ros(...)]"
)]
pub trait InPlace: CdrEncode {
    /// The lengths of this value's variable parts (`()` when it has none).
    type Lens: Clone + Default + fmt::Debug + PartialEq;
    /// Write access to a value of this type laid out in a buffer.
    type Mut<'a>;

    /// The lengths of `self`: carving them lays out a value like `self`.
    fn lens(&self) -> Self::Lens;

    /// The position after a value of these lengths that starts at `start`, or
    /// `None` if it would not fit in memory.
    fn end_in_place(lens: &Self::Lens, start: usize) -> Option<usize>;

    /// Lay out a value of these lengths at the carver's position: zero its
    /// padding and numbers, write its length prefixes and terminators, and hand
    /// back the places its contents go.
    fn carve<'a>(lens: &Self::Lens, c: &mut Carver<'a>) -> Result<Self::Mut<'a>, LoanError>;

    /// Write `self` through `place`, which was carved from `self.lens()`.
    fn write_in_place(&self, place: Self::Mut<'_>) -> Result<(), LoanError>;
}

/// An element type of sequences and arrays built in place: it decides how a run
/// of itself is laid out (numbers as one [`Uninit`] slice, strings one by one).
pub trait InPlaceElement: InPlace + Sized {
    /// The lengths of a run of elements.
    type RunLens: Clone + Default + fmt::Debug + PartialEq;
    /// Write access to a run of elements.
    type RunMut<'a>;

    /// The lengths of `items`.
    fn run_lens(items: &[Self]) -> Self::RunLens;

    /// How many elements the lengths describe.
    fn run_count(lens: &Self::RunLens) -> usize;

    /// The position after `n` elements of these lengths starting at `start`.
    fn run_end(lens: &Self::RunLens, n: usize, start: usize) -> Option<usize>;

    /// Lay out `n` elements of these lengths (no count prefix).
    fn carve_run<'a>(
        lens: &Self::RunLens,
        n: usize,
        c: &mut Carver<'a>,
    ) -> Result<Self::RunMut<'a>, LoanError>;

    /// Write `items` through `place`, carved from `run_lens(items)`.
    fn write_run(items: &[Self], place: Self::RunMut<'_>) -> Result<(), LoanError>;

    /// The lengths of a fixed array of elements (`()` for numbers).
    type ArrayLens: Clone + Default + fmt::Debug + PartialEq;
    /// Write access to a fixed array of elements (`&mut [T; N]`, zeroed, for
    /// numbers and `bool`).
    type ArrayMut<'a, const N: usize>;

    /// The lengths of `items`.
    fn array_lens<const N: usize>(items: &[Self; N]) -> Self::ArrayLens;

    /// The position after an array of these lengths starting at `start`.
    fn array_end<const N: usize>(lens: &Self::ArrayLens, start: usize) -> Option<usize>;

    /// Lay out an array of these lengths.
    fn carve_array<'a, const N: usize>(
        lens: &Self::ArrayLens,
        c: &mut Carver<'a>,
    ) -> Result<Self::ArrayMut<'a, N>, LoanError>;

    /// Write `items` through `place`, carved from `array_lens(items)`.
    fn write_array<const N: usize>(
        items: &[Self; N],
        place: Self::ArrayMut<'_, N>,
    ) -> Result<(), LoanError>;
}

/// Counts the strings and runs of one layout that are still unwritten.
#[derive(Debug, Default)]
pub struct Written {
    pending: Cell<usize>,
}

impl Written {
    /// A counter with nothing pending.
    pub fn new() -> Self {
        Self::default()
    }

    /// How many strings and runs are still to be written.
    pub fn pending(&self) -> usize {
        self.pending.get()
    }

    /// `Ok` when every string and run has been written.
    pub fn check(&self) -> Result<(), LoanError> {
        match self.pending.get() {
            0 => Ok(()),
            pending => Err(LoanError::Unwritten { pending }),
        }
    }

    pub(crate) fn add(&self) {
        self.pending.set(self.pending.get() + 1);
    }

    pub(crate) fn done(&self) {
        self.pending.set(self.pending.get().saturating_sub(1));
    }

    pub(crate) fn reset(&self) {
        self.pending.set(0);
    }
}

/// Cuts a message body into the places its fields go, front to back.
pub struct Carver<'a> {
    rest: &'a mut [u8],
    pos: usize,
    written: &'a Written,
    /// The field being laid out, for errors that name it.
    field: &'static str,
}

impl fmt::Debug for Carver<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Carver")
            .field("pos", &self.pos)
            .field("left", &self.rest.len())
            .finish()
    }
}

impl<'a> Carver<'a> {
    /// Name the field laid out next (the derive calls it before each field),
    /// so that a value of the wrong length written there is an error naming
    /// it.
    #[doc(hidden)]
    pub fn field(&mut self, name: &'static str) {
        self.field = name;
    }

    /// The field being laid out (`""` before the first).
    pub(crate) fn current_field(&self) -> &'static str {
        self.field
    }

    /// The current position, counted from the start of the body.
    pub fn position(&self) -> usize {
        self.pos
    }

    /// Bytes left to lay out.
    pub fn remaining(&self) -> usize {
        self.rest.len()
    }

    /// Skip the zeroed padding up to `align`, then take `len` bytes.
    pub fn take(&mut self, align: usize, len: usize) -> Result<&'a mut [u8], LoanError> {
        let pad = align_up(self.pos, align) - self.pos;
        let needed = pad.checked_add(len).ok_or(LoanError::TooLarge)?;
        if needed > self.rest.len() {
            return Err(LoanError::BufferTooSmall {
                at: HEADER_LEN + self.pos,
                needed,
                left: self.rest.len(),
            });
        }
        let (front, rest) = std::mem::take(&mut self.rest).split_at_mut(needed);
        self.rest = rest;
        self.pos += needed;
        let (padding, slot) = front.split_at_mut(pad);
        padding.fill(0);
        Ok(slot)
    }

    /// Write a `u32` count in the host's byte order, 4-aligned.
    pub fn count(&mut self, n: usize) -> Result<(), LoanError> {
        let n = u32::try_from(n).map_err(|_| LoanError::TooLarge)?;
        self.take(4, 4)?.copy_from_slice(&n.to_ne_bytes());
        Ok(())
    }

    /// The counter of unwritten strings and runs.
    pub fn written(&self) -> &'a Written {
        self.written
    }

    /// The body position as an offset in the whole message, for errors.
    pub(crate) fn offset(&self) -> usize {
        HEADER_LEN + self.pos
    }
}

/// The exact size of a message of these lengths, header included.
pub fn encoded_size<M: InPlace>(lens: &M::Lens) -> Result<usize, LoanError> {
    M::end_in_place(lens, 0)
        .and_then(|end| end.checked_add(HEADER_LEN))
        .ok_or(LoanError::TooLarge)
}

/// The byte order loans write in: the host's.
pub const HOST_ORDER: Endianness = if cfg!(target_endian = "little") {
    Endianness::Little
} else {
    Endianness::Big
};

/// Lay out a message of `lens` in `message` (header included, exactly
/// [`encoded_size`] bytes, its body 8-aligned in memory) and return the places
/// its fields go. `written` counts the strings and runs still to write; it is
/// reset first.
pub fn carve<'a, M: InPlace>(
    lens: &M::Lens,
    message: &'a mut [u8],
    written: &'a Written,
) -> Result<M::Mut<'a>, LoanError> {
    let size = encoded_size::<M>(lens)?;
    if message.len() != size {
        return Err(LoanError::SizeMismatch {
            size,
            buffer: message.len(),
        });
    }
    let (header, body) = message.split_at_mut(HEADER_LEN);
    if !(body.as_ptr() as usize).is_multiple_of(8) {
        return Err(LoanError::Misaligned {
            address: body.as_ptr() as usize,
        });
    }
    header.copy_from_slice(&HOST_ORDER.header());
    written.reset();
    let mut c = Carver {
        rest: body,
        pos: 0,
        written,
        field: "",
    };
    let place = M::carve(lens, &mut c)?;
    debug_assert!(c.rest.is_empty(), "end_in_place disagrees with carve");
    Ok(place)
}

/// Why a message could not be built in place.
#[derive(Debug, Clone, PartialEq, Eq)]
#[non_exhaustive]
pub enum LoanError {
    /// The lengths describe a message larger than memory (or a count over
    /// `u32::MAX`).
    TooLarge,
    /// A bounded string or sequence was given more than its bound.
    BoundExceeded {
        /// The length given.
        len: usize,
        /// The bound.
        bound: usize,
    },
    /// A fixed array was given lengths for another number of elements.
    ArrayLength {
        /// The lengths given.
        len: usize,
        /// The array's length.
        expected: usize,
    },
    /// A value written into a place of another length.
    LengthMismatch {
        /// The field (its Rust name; `""` where it is not known).
        field: &'static str,
        /// Offset of the place in the message.
        at: usize,
        /// The length the place was laid out for.
        expected: usize,
        /// The length of the value.
        got: usize,
    },
    /// The buffer is not the size the lengths need.
    SizeMismatch {
        /// The size the lengths need.
        size: usize,
        /// The buffer's length.
        buffer: usize,
    },
    /// The buffer ran out (a faulty `InPlace` implementation).
    BufferTooSmall {
        /// Offset in the message.
        at: usize,
        /// Bytes needed there.
        needed: usize,
        /// Bytes left.
        left: usize,
    },
    /// The message body is not 8-aligned in memory, so numbers cannot be
    /// referenced in place.
    Misaligned {
        /// The body's address.
        address: usize,
    },
    /// A run seen as elements of a type that is not plain.
    NotPlain {
        /// Offset of the run in the message.
        at: usize,
    },
    /// A run seen as elements of another type is not a whole number of them
    /// (or not aligned for them).
    NotWhole {
        /// Offset of the run in the message.
        at: usize,
        /// The run's length in bytes.
        bytes: usize,
        /// The size of the element type.
        element: usize,
    },
    /// Strings or runs that were laid out but never written.
    Unwritten {
        /// How many.
        pending: usize,
    },
}

impl fmt::Display for LoanError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::TooLarge => f.write_str("the lengths describe a message too large to lay out (a count over u32::MAX or a size over usize::MAX)"),
            Self::BoundExceeded { len, bound } => write!(f, "length {len} exceeds the field's bound of {bound}"),
            Self::ArrayLength { len, expected } => write!(f, "lengths for {len} elements given to an array of {expected}"),
            Self::LengthMismatch { field, at, expected, got } => {
                if !field.is_empty() {
                    write!(f, "field `{field}` ")?;
                }
                write!(f, "at byte {at}: a value of length {got} written where {expected} was laid out; state that length in the lens (`SeqLens::Count(n)` lays out n elements with empty strings and sequences: give each element's lengths with `SeqLens::Each`)")
            }
            Self::SizeMismatch { size, buffer } => write!(f, "the message needs exactly {size} bytes, the buffer has {buffer}"),
            Self::BufferTooSmall { at, needed, left } => write!(f, "at byte {at}: {needed} bytes needed, {left} left"),
            Self::Misaligned { address } => write!(f, "the message body at {address:#x} is not 8-aligned: numbers cannot be placed in it (use loan::AlignedBuffer or a pool chunk)"),
            Self::NotPlain { at } => write!(f, "at byte {at}: the run's elements are not plain (their memory is not their CDR encoding), so they cannot be placed as a slice"),
            Self::NotWhole { at, bytes, element } => write!(f, "at byte {at}: a run of {bytes} bytes is not a whole number of {element}-byte elements aligned for them"),
            Self::Unwritten { pending } => write!(f, "{pending} string(s) or sequence(s) laid out but never written; write each one (write, write_slice, write_with, fill)"),
        }
    }
}

impl std::error::Error for LoanError {}

// --- Building blocks for the implementations in `wire/` and derived code. --------

/// One number (or other plain value) of alignment `align`, zeroed, in place.
pub(crate) fn carve_plain_one<'a, T: CdrEncode>(
    c: &mut Carver<'a>,
    align: usize,
) -> Result<&'a mut T, LoanError> {
    let at = c.offset();
    let proof = T::PLAIN.ok_or(LoanError::NotPlain { at })?;
    let slot = c.take(align, std::mem::size_of::<T>())?;
    slot.fill(0);
    let address = slot.as_ptr() as usize;
    match crate::layout::plain_slice_mut(proof, slot) {
        Some([one]) => Ok(one),
        _ => Err(LoanError::Misaligned { address }),
    }
}

/// `N` plain values, zeroed, in place, as an array.
pub(crate) fn carve_plain_array<'a, T: CdrEncode, const N: usize>(
    c: &mut Carver<'a>,
    align: usize,
) -> Result<&'a mut [T; N], LoanError> {
    let at = c.offset();
    let proof = T::PLAIN.ok_or(LoanError::NotPlain { at })?;
    let slot = c.take(align, N * std::mem::size_of::<T>())?;
    slot.fill(0);
    let address = slot.as_ptr() as usize;
    crate::layout::plain_slice_mut(proof, slot)
        .and_then(|items| <&mut [T; N]>::try_from(items).ok())
        .ok_or(LoanError::Misaligned { address })
}

/// The end of `n` plain values starting at `start` (no alignment when `n == 0`).
pub(crate) fn plain_run_end<T: CdrEncode>(n: usize, start: usize) -> Option<usize> {
    if n == 0 {
        return Some(start);
    }
    let proof = T::PLAIN?;
    align_up(start, proof.first_align()).checked_add(n.checked_mul(std::mem::size_of::<T>())?)
}

/// `n` plain values in place, as one run (`None` if the run starts at a phase
/// where memory and wire layout differ, or `T` is not plain).
pub(crate) fn carve_plain_run<'a, T: CdrEncode>(
    n: usize,
    c: &mut Carver<'a>,
) -> Option<Result<Uninit<'a, T>, LoanError>> {
    let proof = T::PLAIN?;
    if n > 0 && !proof.bulk_at(c.position()) {
        return None;
    }
    let align = if n == 0 { 1 } else { proof.first_align() };
    let len = match n.checked_mul(std::mem::size_of::<T>()) {
        Some(len) => len,
        None => return Some(Err(LoanError::TooLarge)),
    };
    let written = c.written();
    let field = c.current_field();
    Some(c.take(align, len).and_then(|slot| {
        let at = HEADER_LEN + c.position() - len;
        let address = slot.as_ptr() as usize;
        crate::layout::plain_slice_mut(proof, slot)
            .map(|items| Uninit::new(items, at, field, written))
            .ok_or(LoanError::Misaligned { address })
    }))
}

/// The end of a run of messages with these lengths.
pub fn struct_run_end<T: InPlace>(
    lens: &SeqLens<T::Lens>,
    n: usize,
    start: usize,
) -> Option<usize> {
    match lens {
        SeqLens::Count(_) => {
            if let Some(layout) = T::FIXED_LAYOUT {
                // Each element takes at most its smallest size plus 7 bytes of
                // padding; bound the total before the saturating O(1) walk.
                n.checked_mul(layout.min_size() + 7)?.checked_add(start)?;
                return Some(layout.repeat_end(start, n));
            }
            let each = T::Lens::default();
            (0..n).try_fold(start, |pos, _| T::end_in_place(&each, pos))
        }
        SeqLens::Each(each) if each.len() == n => each
            .iter()
            .try_fold(start, |pos, lens| T::end_in_place(lens, pos)),
        SeqLens::Each(_) => None,
    }
}

/// The count a run of messages' lengths describe.
pub fn struct_run_count<L>(lens: &SeqLens<L>) -> usize {
    match lens {
        SeqLens::Count(n) => *n,
        SeqLens::Each(each) => each.len(),
    }
}

/// Lay out a run of `n` messages: one slice if they are plain and the phase
/// allows, else one by one.
pub fn struct_carve_run<'a, T: InPlace>(
    lens: &SeqLens<T::Lens>,
    n: usize,
    c: &mut Carver<'a>,
) -> Result<Run<'a, T>, LoanError> {
    if let SeqLens::Each(each) = lens {
        if each.len() != n {
            return Err(LoanError::ArrayLength {
                len: each.len(),
                expected: n,
            });
        }
    }
    if let SeqLens::Count(_) = lens {
        if let Some(run) = carve_plain_run::<T>(n, c) {
            return run.map(Run::Plain);
        }
    }
    let default = T::Lens::default();
    let mut places = Vec::with_capacity(n.min(c.remaining()));
    for i in 0..n {
        let lens = match lens {
            SeqLens::Each(each) => &each[i],
            SeqLens::Count(_) => &default,
        };
        places.push(T::carve(lens, c)?);
    }
    Ok(Run::Each(places))
}

/// The lengths of a run of messages: a count when every element has default
/// lengths.
pub fn struct_run_lens<T: InPlace>(items: &[T]) -> SeqLens<T::Lens> {
    let each: Vec<T::Lens> = items.iter().map(InPlace::lens).collect();
    let default = T::Lens::default();
    if each.iter().all(|lens| *lens == default) {
        SeqLens::Count(items.len())
    } else {
        SeqLens::Each(each)
    }
}

/// An array's lengths must be its default (`N` elements with default lengths),
/// a count of `N`, or `N` sets.
fn check_array<L>(lens: &SeqLens<L>, n: usize) -> Result<(), LoanError> {
    match lens {
        SeqLens::Count(len) if *len != 0 && *len != n => Err(LoanError::ArrayLength {
            len: *len,
            expected: n,
        }),
        SeqLens::Each(each) if each.len() != n => Err(LoanError::ArrayLength {
            len: each.len(),
            expected: n,
        }),
        _ => Ok(()),
    }
}

/// The end of a fixed array of `n` messages.
pub fn struct_array_end<T: InPlace>(
    lens: &SeqLens<T::Lens>,
    n: usize,
    start: usize,
) -> Option<usize> {
    check_array(lens, n).ok()?;
    struct_run_end::<T>(lens, n, start)
}

/// Lay out a fixed array of `n` messages.
pub fn struct_carve_array<'a, T: InPlace>(
    lens: &SeqLens<T::Lens>,
    n: usize,
    c: &mut Carver<'a>,
) -> Result<Run<'a, T>, LoanError> {
    check_array(lens, n)?;
    struct_carve_run(lens, n, c)
}

/// Write a run of messages.
pub fn struct_write_run<T: InPlace>(items: &[T], place: Run<'_, T>) -> Result<(), LoanError> {
    place.write_slice(items)
}
