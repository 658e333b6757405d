//! [`Numbers`]: an array or sequence of numbers of a run-time typed message,
//! read from the wire bytes where they lie. CDR aligns a number to its size
//! from the start of the body, four bytes into the payload, so an `f64` array
//! in a buffer aligned to 8 sits 4 bytes off: a `&[f64]` of it cannot be
//! made, and a copy per array would cost an allocation, a copy and a free on
//! every decode. The wire bytes are kept instead, in whatever alignment and
//! byte order they come, and each element is read when asked for.

use std::borrow::Cow;
use std::fmt;

use crate::decode::{CdrDecode, Reader};
use crate::encode::{CdrEncode, Writer};
use crate::endian::{ByteOrder, Endianness};
use crate::error::{DecodeError, EncodeError};
use crate::layout::align_up;

mod sealed {
    pub trait Sealed {}
}

/// A number type an array of a run-time typed message may hold: `int16`
/// to `uint64`, `float32` and `float64`. Sealed; bytes and `int8` arrays
/// are slices, as their elements have no alignment or byte order.
pub trait Number:
    sealed::Sealed
    + Copy
    + PartialEq
    + PartialOrd
    + fmt::Debug
    + fmt::Display
    + bytemuck::Pod
    + Send
    + Sync
    + 'static
{
    /// The element with its bytes in the other order.
    #[doc(hidden)]
    fn swapped(self) -> Self;
}

macro_rules! number {
    ($($t:ty: |$x:ident| $swapped:expr),* $(,)?) => {$(
        impl sealed::Sealed for $t {}
        impl Number for $t {
            #[inline(always)]
            fn swapped(self) -> Self {
                let $x = self;
                $swapped
            }
        }
    )*};
}
number!(
    i16: |x| x.swap_bytes(),
    u16: |x| x.swap_bytes(),
    i32: |x| x.swap_bytes(),
    u32: |x| x.swap_bytes(),
    i64: |x| x.swap_bytes(),
    u64: |x| x.swap_bytes(),
    f32: |x| f32::from_bits(x.to_bits().swap_bytes()),
    f64: |x| f64::from_bits(x.to_bits().swap_bytes()),
);

/// The host's byte order.
const HOST: Endianness = if cfg!(target_endian = "little") {
    Endianness::Little
} else {
    Endianness::Big
};

/// The numbers of an array or sequence field of a run-time typed
/// [`Message`](super::Message): borrowed from the payload they were decoded
/// from, in its alignment and byte order, or owned.
///
/// Reading one costs what reading it from the wire costs; nothing is copied
/// or allocated when a message is decoded. [`as_slice`](Self::as_slice)
/// gives a `&[T]` where the bytes allow one (owned, or in host order and
/// aligned), [`to_cow`](Self::to_cow) one always.
///
/// ```
/// use shm_cdr::dynamic::{DynamicType, Numbers, Value};
/// use shm_cdr::msgs::sensor_msgs::Imu;
/// use shm_cdr::RosMessage;
///
/// let mut imu = Imu::default();
/// imu.orientation_covariance[4] = 0.25;
/// let bytes = shm_cdr::to_vec(&imu)?;
/// let ty = DynamicType::from_description(&Imu::full_description())?;
/// let message = ty.decode(&bytes)?;
/// let Some(Value::F64s(covariance)) = message.value("orientation_covariance") else {
///     unreachable!()
/// };
/// assert_eq!(covariance.len(), 9);
/// assert_eq!(covariance.get(4), Some(0.25));
/// assert_eq!(covariance.iter().sum::<f64>(), 0.25);
/// // Owned numbers compare equal to borrowed ones holding the same values.
/// let mut expected = vec![0.0; 9];
/// expected[4] = 0.25;
/// assert_eq!(*covariance, Numbers::from(expected));
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Clone)]
pub struct Numbers<'a, T: Number> {
    repr: Repr<'a, T>,
}

#[derive(Clone)]
enum Repr<'a, T> {
    /// `bytes.len()` is a multiple of the element's size.
    Wire { bytes: &'a [u8], order: Endianness },
    /// A box, not a `Vec`: with the wire's slice, two words, so a `Value`
    /// stays small.
    Owned(Box<[T]>),
}

impl<'a, T: Number> Numbers<'a, T> {
    /// The numbers whose encoding in `order` is `bytes`, borrowed; `None` if
    /// the length of `bytes` is not a whole number of elements.
    pub fn from_wire(bytes: &'a [u8], order: Endianness) -> Option<Self> {
        bytes.len().is_multiple_of(size_of::<T>()).then_some(Self {
            repr: Repr::Wire { bytes, order },
        })
    }

    /// The numbers whose encoding in `order` is `bytes`, whose length the
    /// caller made a whole number of elements.
    #[inline(always)]
    pub(crate) fn on_wire(bytes: &'a [u8], order: Endianness) -> Self {
        debug_assert!(bytes.len().is_multiple_of(size_of::<T>()));
        Self {
            repr: Repr::Wire { bytes, order },
        }
    }

    /// How many numbers there are.
    #[inline]
    pub fn len(&self) -> usize {
        match &self.repr {
            Repr::Wire { bytes, .. } => bytes.len() / size_of::<T>(),
            Repr::Owned(items) => items.len(),
        }
    }

    /// Whether there are none.
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Number `i`.
    #[inline]
    pub fn get(&self, i: usize) -> Option<T> {
        match &self.repr {
            Repr::Wire { bytes, order } => {
                let start = i.checked_mul(size_of::<T>())?;
                let chunk = bytes.get(start..start.checked_add(size_of::<T>())?)?;
                Some(read(chunk, *order))
            }
            Repr::Owned(items) => items.get(i).copied(),
        }
    }

    /// The numbers, in order.
    #[inline]
    pub fn iter(&self) -> Iter<'_, T> {
        Iter {
            inner: match &self.repr {
                Repr::Wire { bytes, order } => IterRepr::Wire {
                    chunks: bytes.chunks_exact(size_of::<T>()),
                    order: *order,
                },
                Repr::Owned(items) => IterRepr::Owned(items.iter()),
            },
        }
    }

    /// The numbers as a slice, if they are one in memory: owned, or on the
    /// wire in the host's byte order at an address aligned for `T`.
    #[inline]
    pub fn as_slice(&self) -> Option<&[T]> {
        match &self.repr {
            Repr::Wire { bytes, order } if *order == HOST => bytemuck::try_cast_slice(bytes).ok(),
            Repr::Wire { .. } => None,
            Repr::Owned(items) => Some(items),
        }
    }

    /// The numbers as a slice: borrowed where [`as_slice`](Self::as_slice)
    /// can, copied otherwise.
    pub fn to_cow(&self) -> Cow<'_, [T]> {
        match self.as_slice() {
            Some(items) => Cow::Borrowed(items),
            None => Cow::Owned(self.to_vec()),
        }
    }

    /// The numbers, copied into a `Vec`.
    pub fn to_vec(&self) -> Vec<T> {
        match &self.repr {
            Repr::Owned(items) => items.to_vec(),
            Repr::Wire { .. } => self.iter().collect(),
        }
    }

    /// The numbers as a `Vec`, copied unless owned already.
    pub fn into_vec(self) -> Vec<T> {
        match self.repr {
            Repr::Owned(items) => items.into_vec(),
            Repr::Wire { .. } => self.iter().collect(),
        }
    }

    /// The wire bytes and their byte order, if the numbers are borrowed
    /// from a payload: what to hand to something that reads the encoding
    /// itself (a numpy array of a dtype with that byte order).
    pub fn wire(&self) -> Option<(&'a [u8], Endianness)> {
        match self.repr {
            Repr::Wire { bytes, order } => Some((bytes, order)),
            Repr::Owned(_) => None,
        }
    }

    /// The numbers with nothing borrowed.
    pub fn into_owned(self) -> Numbers<'static, T> {
        Numbers {
            repr: match self.repr {
                Repr::Owned(items) => Repr::Owned(items),
                Repr::Wire { .. } => Repr::Owned(self.iter().collect()),
            },
        }
    }

    /// Read `n` numbers at the reader, borrowing their bytes, as the
    /// generated code reads an array of numbers in the host's order; in
    /// the other order from input in segments, element by element (copied),
    /// as the generated code does.
    #[inline]
    pub(crate) fn decode<B: ByteOrder>(r: &mut Reader<'a, B>, n: usize) -> Result<Self, DecodeError>
    where
        T: CdrDecode<'a>,
    {
        if n == 0 {
            // As the generated code: an empty array is not aligned.
            return Ok(Self::default());
        }
        if !B::NATIVE && !r.is_contiguous() {
            return T::decode_vec(r, n).map(Self::from);
        }
        let bytes = r.read_aligned_bytes(size_of::<T>(), n.saturating_mul(size_of::<T>()))?;
        Ok(Self::on_wire(bytes, B::ENDIANNESS))
    }

    /// The bytes of [`encode`](Self::encode) from `start`: none when empty,
    /// as the generated code writes an empty array.
    #[inline]
    pub(crate) fn encoded_end(&self, start: usize) -> usize {
        match self.len() {
            0 => start,
            n => align_up(start, size_of::<T>()) + n * size_of::<T>(),
        }
    }

    /// Write the numbers (no count): in one copy when their bytes are in the
    /// writer's order already.
    #[inline]
    pub(crate) fn encode<B: ByteOrder>(&self, w: &mut Writer<'_, B>) -> Result<(), EncodeError>
    where
        T: CdrEncode,
    {
        match &self.repr {
            Repr::Wire { bytes, order } if *order == B::ENDIANNESS => {
                if bytes.is_empty() {
                    return Ok(());
                }
                w.write_aligned(size_of::<T>(), bytes)
            }
            Repr::Wire { .. } => self.iter().try_for_each(|x| x.encode(w)),
            Repr::Owned(items) => T::encode_slice(items, w),
        }
    }
}

/// One number from its `size_of::<T>()` wire bytes in `order`.
#[inline(always)]
fn read<T: Number>(chunk: &[u8], order: Endianness) -> T {
    // Every caller passes a chunk of exactly `size_of::<T>()` bytes.
    let host: T = bytemuck::pod_read_unaligned(chunk);
    if order == HOST {
        host
    } else {
        host.swapped()
    }
}

impl<T: Number> Default for Numbers<'_, T> {
    fn default() -> Self {
        Self {
            repr: Repr::Owned(Box::default()),
        }
    }
}

impl<T: Number> From<Vec<T>> for Numbers<'_, T> {
    fn from(items: Vec<T>) -> Self {
        Self {
            repr: Repr::Owned(items.into_boxed_slice()),
        }
    }
}

/// Borrowed, as the host lays them out.
impl<'a, T: Number> From<&'a [T]> for Numbers<'a, T> {
    fn from(items: &'a [T]) -> Self {
        Self {
            repr: Repr::Wire {
                bytes: bytemuck::cast_slice(items),
                order: HOST,
            },
        }
    }
}

impl<T: Number, const N: usize> From<[T; N]> for Numbers<'_, T> {
    fn from(items: [T; N]) -> Self {
        Self {
            repr: Repr::Owned(Box::new(items)),
        }
    }
}

impl<'a, T: Number> From<Cow<'a, [T]>> for Numbers<'a, T> {
    fn from(items: Cow<'a, [T]>) -> Self {
        match items {
            Cow::Borrowed(items) => Self::from(items),
            Cow::Owned(items) => Self::from(items),
        }
    }
}

impl<T: Number> FromIterator<T> for Numbers<'_, T> {
    fn from_iter<I: IntoIterator<Item = T>>(iter: I) -> Self {
        Self {
            repr: Repr::Owned(iter.into_iter().collect()),
        }
    }
}

/// Equal when they hold equal numbers in the same order, however each is
/// stored.
impl<T: Number> PartialEq for Numbers<'_, T> {
    fn eq(&self, other: &Self) -> bool {
        match (self.as_slice(), other.as_slice()) {
            (Some(a), Some(b)) => a == b,
            _ => self.len() == other.len() && self.iter().eq(other.iter()),
        }
    }
}

impl<T: Number> PartialEq<[T]> for Numbers<'_, T> {
    fn eq(&self, other: &[T]) -> bool {
        self.len() == other.len() && self.iter().eq(other.iter().copied())
    }
}

impl<T: Number> fmt::Debug for Numbers<'_, T> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_list().entries(self.iter()).finish()
    }
}

impl<'n, T: Number> IntoIterator for &'n Numbers<'_, T> {
    type Item = T;
    type IntoIter = Iter<'n, T>;

    fn into_iter(self) -> Iter<'n, T> {
        self.iter()
    }
}

/// The numbers of a [`Numbers`], by value.
#[derive(Clone)]
pub struct Iter<'n, T> {
    inner: IterRepr<'n, T>,
}

#[derive(Clone)]
enum IterRepr<'n, T> {
    Wire {
        chunks: std::slice::ChunksExact<'n, u8>,
        order: Endianness,
    },
    Owned(std::slice::Iter<'n, T>),
}

impl<T: Number> Iterator for Iter<'_, T> {
    type Item = T;

    #[inline]
    fn next(&mut self) -> Option<T> {
        match &mut self.inner {
            IterRepr::Wire { chunks, order } => chunks.next().map(|chunk| read(chunk, *order)),
            IterRepr::Owned(items) => items.next().copied(),
        }
    }

    #[inline]
    fn size_hint(&self) -> (usize, Option<usize>) {
        match &self.inner {
            IterRepr::Wire { chunks, .. } => chunks.size_hint(),
            IterRepr::Owned(items) => items.size_hint(),
        }
    }
}

impl<T: Number> DoubleEndedIterator for Iter<'_, T> {
    #[inline]
    fn next_back(&mut self) -> Option<T> {
        match &mut self.inner {
            IterRepr::Wire { chunks, order } => chunks.next_back().map(|chunk| read(chunk, *order)),
            IterRepr::Owned(items) => items.next_back().copied(),
        }
    }
}

impl<T: Number> ExactSizeIterator for Iter<'_, T> {}

impl<T: Number> std::iter::FusedIterator for Iter<'_, T> {}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::endian::{BigEndian, LittleEndian};

    #[test]
    fn wire_numbers_read_in_either_order_at_any_alignment() {
        let values = [1.5f64, -2.25, 1e300];
        let mut le = vec![0u8; 1];
        let mut be = vec![0u8; 1];
        for v in values {
            le.extend_from_slice(&v.to_le_bytes());
            be.extend_from_slice(&v.to_be_bytes());
        }
        // One byte in: misaligned for f64 wherever the Vec lies.
        let le = Numbers::<f64>::from_wire(&le[1..], Endianness::Little).unwrap();
        let be = Numbers::<f64>::from_wire(&be[1..], Endianness::Big).unwrap();
        for n in [&le, &be] {
            assert_eq!(n.len(), 3);
            assert_eq!(n.to_vec(), values);
            assert_eq!(n.iter().rev().collect::<Vec<_>>(), [1e300, -2.25, 1.5]);
            assert_eq!(n.get(1), Some(-2.25));
            assert_eq!(n.get(3), None);
            assert_eq!(n.get(usize::MAX), None);
            assert_eq!(*n, Numbers::from(values.to_vec()));
            assert_eq!(n.to_cow().as_ref(), values);
        }
        assert_eq!(le, be);
        assert!(Numbers::<u32>::from_wire(&[0; 7], Endianness::Little).is_none());
    }

    #[test]
    fn borrowed_host_numbers_are_a_slice() {
        let values = [7u32, 8, 9];
        let n = Numbers::from(&values[..]);
        assert_eq!(n.as_slice(), Some(&values[..]));
        assert!(matches!(n.to_cow(), Cow::Borrowed(_)));
        assert_eq!(n.into_owned().into_vec(), values);
    }

    #[test]
    fn decoded_numbers_encode_to_the_same_bytes_in_either_order() {
        // A count-less array of three u16 after one byte: padded to 2.
        let body = [9u8, 0, 1, 2, 3, 4, 5, 6];
        let mut r = Reader::<LittleEndian>::new(&body);
        let _ = u8::decode(&mut r).unwrap();
        let n = Numbers::<u16>::decode(&mut r, 3).unwrap();
        assert_eq!(n.to_vec(), [0x0201, 0x0403, 0x0605]);
        assert!(n.wire().is_some(), "borrowed, not copied");
        assert_eq!(n.encoded_end(1), 8);

        let mut out = [0u8; 8];
        let mut w = Writer::<LittleEndian>::new(&mut out);
        9u8.encode(&mut w).unwrap();
        n.encode(&mut w).unwrap();
        assert_eq!(out, body);

        let mut swapped = [0u8; 8];
        let mut w = Writer::<BigEndian>::new(&mut swapped);
        9u8.encode(&mut w).unwrap();
        n.encode(&mut w).unwrap();
        assert_eq!(swapped, [9, 0, 2, 1, 4, 3, 6, 5]);

        // Too few bytes: the reader's own error, nothing borrowed.
        let mut r = Reader::<LittleEndian>::new(&body);
        assert!(Numbers::<u64>::decode(&mut r, 2).is_err());
    }
}
