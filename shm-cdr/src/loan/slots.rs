//! The places a carved message hands out: runs of numbers, strings, runs of
//! messages, and a heap buffer laid out like a shared-memory chunk.

use std::fmt;
use std::ops::Range;

use super::{InPlace, LoanError, Written};
use crate::encode::CdrEncode;
use crate::layout::plain_slice_mut;

/// A run of `T` lying at its final place in the buffer, not yet written.
///
/// Write it once, with one of the methods that consume it; each returns the run
/// as a `&mut [T]`, still in the buffer, for any further changes. Until then it
/// counts as unwritten ([`Written::check`]).
pub struct Uninit<'a, T> {
    items: &'a mut [T],
    at: usize,
    field: &'static str,
    written: &'a Written,
}

impl<T> fmt::Debug for Uninit<'_, T> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Uninit")
            .field("len", &self.items.len())
            .field("at", &self.at)
            .finish()
    }
}

impl<'a, T> Uninit<'a, T> {
    /// A run over `items`, at message offset `at`. Counts as unwritten unless
    /// empty.
    pub(crate) fn new(
        items: &'a mut [T],
        at: usize,
        field: &'static str,
        written: &'a Written,
    ) -> Self {
        if !items.is_empty() {
            written.add();
        }
        Self {
            items,
            at,
            field,
            written,
        }
    }

    /// The number of elements laid out.
    pub fn len(&self) -> usize {
        self.items.len()
    }

    /// Whether the run is empty.
    pub fn is_empty(&self) -> bool {
        self.items.is_empty()
    }

    /// The offset of the first element in the message (header included).
    pub fn offset(&self) -> usize {
        self.at
    }

    fn finish(self) -> &'a mut [T] {
        if !self.items.is_empty() {
            self.written.done();
        }
        self.items
    }

    /// Copy `values` in (one `memcpy`); they must be exactly as many as laid out.
    pub fn write_slice(self, values: &[T]) -> Result<&'a mut [T], LoanError>
    where
        T: Copy,
    {
        if values.len() != self.items.len() {
            return Err(LoanError::LengthMismatch {
                field: self.field,
                at: self.at,
                expected: self.items.len(),
                got: values.len(),
            });
        }
        self.items.copy_from_slice(values);
        Ok(self.finish())
    }

    /// Copy `values` in as their bytes (for plain types that are not `Copy`,
    /// e.g. derived messages); exactly as many as laid out.
    pub fn write_plain(self, values: &[T]) -> Result<&'a mut [T], LoanError>
    where
        T: CdrEncode,
    {
        let Some(proof) = T::PLAIN else {
            return Err(LoanError::NotPlain { at: self.at });
        };
        if values.len() != self.items.len() {
            return Err(LoanError::LengthMismatch {
                field: self.field,
                at: self.at,
                expected: self.items.len(),
                got: values.len(),
            });
        }
        crate::layout::plain_bytes_mut(proof, self.items)
            .copy_from_slice(crate::layout::plain_bytes(proof, values));
        Ok(self.finish())
    }

    /// Write element `i` as `f(i)`, for every index.
    pub fn write_with(self, mut f: impl FnMut(usize) -> T) -> &'a mut [T] {
        for (i, item) in self.items.iter_mut().enumerate() {
            *item = f(i);
        }
        self.finish()
    }

    /// Write the values of `values`, which must yield exactly as many as laid out.
    /// On a count mismatch the run stays unwritten.
    pub fn write_iter(self, values: impl IntoIterator<Item = T>) -> Result<&'a mut [T], LoanError> {
        let mut values = values.into_iter();
        let mut n = 0;
        for (item, value) in self.items.iter_mut().zip(&mut values) {
            *item = value;
            n += 1;
        }
        let extra = values.count();
        if n != self.items.len() || extra != 0 {
            return Err(LoanError::LengthMismatch {
                field: self.field,
                at: self.at,
                expected: self.items.len(),
                got: n + extra,
            });
        }
        Ok(self.finish())
    }

    /// Set every element to `value` (e.g. `0.0` before writing at random
    /// indices).
    pub fn fill(self, value: T) -> &'a mut [T]
    where
        T: Copy,
    {
        self.items.fill(value);
        self.finish()
    }

    /// Take the run as it lies, promising to write every element: until then each
    /// holds whatever the buffer held (a previous message's bytes; never
    /// uninitialized memory, and always a valid `T`).
    pub fn assume_written(self) -> &'a mut [T] {
        self.finish()
    }

    /// See the run's bytes as elements of another plain type `P` (e.g. the
    /// `uint8[] data` of a `PointCloud2` as the point structs it holds). Fails if
    /// `P` is not plain ([`CdrEncode::PLAIN`]), the bytes are not a whole number
    /// of `P`s, or not aligned for `P`.
    pub fn cast<P: CdrEncode>(self) -> Result<Uninit<'a, P>, LoanError>
    where
        T: CdrEncode,
    {
        let (Some(from), Some(to)) = (T::PLAIN, P::PLAIN) else {
            return Err(LoanError::NotPlain { at: self.at });
        };
        let (at, field, written) = (self.at, self.field, self.written);
        let bytes = crate::layout::plain_bytes_mut(from, self.items);
        let len = bytes.len();
        match plain_slice_mut(to, bytes) {
            // The same bytes, so the same pending state: nothing to count again.
            Some(items) => Ok(Uninit {
                items,
                at,
                field,
                written,
            }),
            None => Err(LoanError::NotWhole {
                at,
                bytes: len,
                element: std::mem::size_of::<P>(),
            }),
        }
    }
}

/// A string of a stated length lying at its final place (its count and
/// terminator already written), not yet written.
pub struct StrSlot<'a> {
    bytes: &'a mut [u8],
    at: usize,
    field: &'static str,
    written: &'a Written,
}

impl fmt::Debug for StrSlot<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("StrSlot")
            .field("len", &self.bytes.len())
            .field("at", &self.at)
            .finish()
    }
}

impl<'a> StrSlot<'a> {
    pub(crate) fn new(
        bytes: &'a mut [u8],
        at: usize,
        field: &'static str,
        written: &'a Written,
    ) -> Self {
        if !bytes.is_empty() {
            written.add();
        }
        Self {
            bytes,
            at,
            field,
            written,
        }
    }

    /// The length in bytes laid out (without the terminator).
    pub fn len(&self) -> usize {
        self.bytes.len()
    }

    /// Whether the string is empty.
    pub fn is_empty(&self) -> bool {
        self.bytes.is_empty()
    }

    /// Write `s`, which must be exactly as long as laid out.
    pub fn write(self, s: &str) -> Result<(), LoanError> {
        self.write_bytes(s.as_bytes())
    }

    /// Write raw bytes (ROS 2 strings are not checked for UTF-8 on the wire).
    pub fn write_bytes(self, s: &[u8]) -> Result<(), LoanError> {
        if s.len() != self.bytes.len() {
            return Err(LoanError::LengthMismatch {
                field: self.field,
                at: self.at,
                expected: self.bytes.len(),
                got: s.len(),
            });
        }
        self.bytes.copy_from_slice(s);
        if !s.is_empty() {
            self.written.done();
        }
        Ok(())
    }
}

/// A `wstring` of a stated number of UTF-16 code units lying at its final place,
/// not yet written.
pub struct WStrSlot<'a> {
    units: &'a mut [u8],
    at: usize,
    field: &'static str,
    written: &'a Written,
}

impl fmt::Debug for WStrSlot<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("WStrSlot")
            .field("units", &(self.units.len() / 4))
            .field("at", &self.at)
            .finish()
    }
}

impl<'a> WStrSlot<'a> {
    pub(crate) fn new(
        units: &'a mut [u8],
        at: usize,
        field: &'static str,
        written: &'a Written,
    ) -> Self {
        if !units.is_empty() {
            written.add();
        }
        Self {
            units,
            at,
            field,
            written,
        }
    }

    /// The UTF-16 code units laid out.
    pub fn len(&self) -> usize {
        self.units.len() / 4
    }

    /// Whether the string is empty.
    pub fn is_empty(&self) -> bool {
        self.units.is_empty()
    }

    /// Write `s`, which must be exactly as many UTF-16 code units as laid out.
    pub fn write(self, s: &str) -> Result<(), LoanError> {
        let got = s.encode_utf16().count();
        if got != self.len() {
            return Err(LoanError::LengthMismatch {
                field: self.field,
                at: self.at,
                expected: self.len(),
                got,
            });
        }
        for (dst, unit) in self.units.chunks_exact_mut(4).zip(s.encode_utf16()) {
            dst.copy_from_slice(&u32::from(unit).to_ne_bytes());
        }
        if got != 0 {
            self.written.done();
        }
        Ok(())
    }
}

/// The lengths of a run of messages: a count of messages with default lengths
/// (all a message with no strings or sequences needs), or one set per message.
#[derive(Debug, Clone, PartialEq)]
pub enum SeqLens<L> {
    /// This many elements, each with default lengths.
    Count(usize),
    /// One element per entry, with these lengths.
    Each(Vec<L>),
}

impl<L> Default for SeqLens<L> {
    fn default() -> Self {
        Self::Count(0)
    }
}

impl<L> From<usize> for SeqLens<L> {
    fn from(n: usize) -> Self {
        Self::Count(n)
    }
}

impl<L> From<Vec<L>> for SeqLens<L> {
    fn from(each: Vec<L>) -> Self {
        Self::Each(each)
    }
}

/// A run of messages laid out in place: one [`Uninit`] run when the message type
/// is plain and the run starts where memory and wire layout agree (e.g. a
/// `Pose[]`), else one `…Mut` per element.
pub enum Run<'a, T: InPlace> {
    /// The whole run as one slice of `T`.
    Plain(Uninit<'a, T>),
    /// Each element on its own.
    Each(Vec<T::Mut<'a>>),
}

impl<T: InPlace> fmt::Debug for Run<'_, T> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Plain(run) => f.debug_tuple("Plain").field(run).finish(),
            Self::Each(each) => f.debug_tuple("Each").field(&each.len()).finish(),
        }
    }
}

impl<'a, T: InPlace> Run<'a, T> {
    /// The number of elements laid out.
    pub fn len(&self) -> usize {
        match self {
            Self::Plain(run) => run.len(),
            Self::Each(each) => each.len(),
        }
    }

    /// Whether the run is empty.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Write `values` (exactly as many, with the lengths laid out).
    pub fn write_slice(self, values: &[T]) -> Result<(), LoanError> {
        match self {
            Self::Plain(run) => run.write_plain(values).map(drop),
            Self::Each(each) => write_each(values, each),
        }
    }

    /// The elements one by one (a plain run is split into `&mut T`s only through
    /// [`Run::Plain`]; this is `None` for it).
    pub fn into_each(self) -> Option<Vec<T::Mut<'a>>> {
        match self {
            Self::Plain(_) => None,
            Self::Each(each) => Some(each),
        }
    }
}

/// Write `values` into `places`, one by one.
pub(crate) fn write_each<T: InPlace>(
    values: &[T],
    places: Vec<T::Mut<'_>>,
) -> Result<(), LoanError> {
    if values.len() != places.len() {
        return Err(LoanError::LengthMismatch {
            field: "",
            at: 0,
            expected: places.len(),
            got: values.len(),
        });
    }
    values
        .iter()
        .zip(places)
        .try_for_each(|(value, place)| value.write_in_place(place))
}

/// A heap buffer for one message, laid out as a shared-memory chunk is: the
/// body (after the 4-byte header) 8-aligned in memory.
#[derive(Clone)]
pub struct AlignedBuffer {
    storage: Vec<u8>,
    message: Range<usize>,
}

impl fmt::Debug for AlignedBuffer {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("AlignedBuffer")
            .field("len", &self.message.len())
            .finish()
    }
}

impl AlignedBuffer {
    /// A zeroed buffer of `len` bytes.
    pub fn new(len: usize) -> Self {
        let storage = vec![0u8; len.saturating_add(7)];
        // The message starts at 4 mod 8, so its body starts at 0 mod 8. The
        // vector is never grown, so its heap block (and this offset) stays put.
        let start = 4usize.wrapping_sub(storage.as_ptr() as usize) & 7;
        Self {
            message: start..start + len,
            storage,
        }
    }

    /// The message bytes.
    pub fn as_slice(&self) -> &[u8] {
        &self.storage[self.message.clone()]
    }

    /// The message bytes, to carve.
    pub fn as_mut_slice(&mut self) -> &mut [u8] {
        &mut self.storage[self.message.clone()]
    }

    /// The storage and where the message lies in it (to hand the storage on
    /// without a copy, e.g. as `bytes::Bytes` sliced to the range).
    pub fn into_parts(self) -> (Vec<u8>, Range<usize>) {
        (self.storage, self.message)
    }
}

/// A `bool` field in a loaned buffer: one byte, `false` until set. A loaned
/// buffer may be shared memory, which every process that maps it can write;
/// a `&mut bool` there would be undefined behaviour the moment another
/// process wrote a byte other than 0 or 1, so the byte is kept as a byte and
/// read as `true` unless it is 0.
#[repr(transparent)]
#[derive(Debug, Default, PartialEq, Eq)]
pub struct LoanBool(u8);

impl LoanBool {
    /// Write `value` (as CDR encodes it: 1 or 0).
    #[inline]
    pub fn set(&mut self, value: bool) {
        self.0 = u8::from(value);
    }

    /// The value: `true` unless the byte is 0.
    #[inline]
    pub fn get(&self) -> bool {
        self.0 != 0
    }
}
