//! ROS 2 CDR for hand-written Rust structs: exact sizes, byte-exact wire format,
//! borrowed decoding, and no panics on hostile input.
//!
//! ```
//! use shm_cdr::RosMessage;
//!
//! #[derive(RosMessage, Debug, PartialEq)]
//! #[ros(type_name = "my_pkg/msg/Reading")]
//! struct Reading {
//!     id: u8,
//!     value: f64,
//!     label: String,
//! }
//!
//! let msg = Reading { id: 7, value: 1.5, label: "a".into() };
//! let bytes = shm_cdr::to_vec(&msg)?;
//! assert_eq!(bytes.len(), shm_cdr::encoded_size(&msg)); // exact, always
//! assert_eq!(&bytes[..4], [0x00, 0x01, 0x00, 0x00]); // little-endian CDR
//! assert_eq!(shm_cdr::from_bytes::<Reading>(&bytes)?, msg);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! The wire format is ROS 2's classic CDR (XCDR1) as rmw_fastrtps and rmw_zenoh_cpp
//! write it: a 4-byte encapsulation header, then every primitive aligned to its size
//! counted from the byte after the header. Every padding byte is written as zero.
#![warn(missing_docs)]
#![deny(unsafe_code)]
// docs.rs builds with `--cfg docsrs`: every item behind a cargo feature is
// marked with the feature it needs.
#![cfg_attr(docsrs, feature(doc_cfg))]

use std::marker::PhantomData;

mod bounded;
mod decode;
pub mod describe;
#[cfg(feature = "type_description_interfaces")]
mod description_msg;
#[cfg(feature = "derive")]
pub mod distro_msgs;
#[cfg(feature = "derive")]
mod distro_sources;
pub mod dynamic;
mod encode;
mod endian;
mod error;
pub mod interface;
pub mod layout;
pub mod loan;
mod message;
pub mod msgs;
pub mod prelude;
// `for_each_interface!`: every generated standard type, for tools and tests
// that handle them all (shm-codegen/generate-standard-set.sh writes it).
#[cfg(feature = "all_interfaces")]
mod registry;
pub mod splice;
#[cfg(any(feature = "proptest", feature = "arbitrary"))]
mod strategies;
pub mod testing;
pub mod text_limits;
mod wire;

pub use bounded::{BoundedString, BoundedVec, BoundedWString, WString};
pub use decode::{CdrDecode, DecodeOwned, Reader, MAX_SEGMENTS};
pub use describe::{RosElement, RosType};
pub use encode::{CdrEncode, Writer};
pub use endian::{BigEndian, ByteOrder, Endianness, LittleEndian};
pub use error::{DecodeError, DecodeErrorKind, EncodeError, EncodeErrorKind};
pub use interface::{RosAction, RosService};
pub use message::{BorrowedForm, RosMessage};

/// `#[derive(RosMessage)]`: see the [crate documentation](crate).
#[cfg(feature = "derive")]
pub use shm_derive::RosMessage;

/// Re-exports for derived code; not a public API.
#[doc(hidden)]
pub mod __private {
    pub use std::sync::OnceLock;

    /// Fails to compile, at the field's type, unless it is a ROS 2 field type.
    pub fn assert_field_type<T: ?Sized + crate::RosType + crate::CdrEncode>() {}

    /// Fails to compile, at the attribute, unless the field is `u8`/`i8`-based.
    pub fn assert_octet_type<T: ?Sized + crate::describe::OctetType>() {}
}

/// Length of the encapsulation header that starts every message.
pub const HEADER_LEN: usize = decode::HEADER_LEN;

/// The exact number of bytes [`to_vec`] produces for `msg`, header included.
#[inline]
pub fn encoded_size<T: CdrEncode + ?Sized>(msg: &T) -> usize {
    HEADER_LEN + msg.encoded_end(0)
}

/// Encode `msg` as little-endian CDR into the start of `buf`, returning the number
/// of bytes written (always [`encoded_size`]). Never writes outside `buf`; a buffer
/// that is too small is an [`EncodeErrorKind::BufferTooSmall`] error.
#[inline]
pub fn encode_into<T: CdrEncode + ?Sized>(msg: &T, buf: &mut [u8]) -> Result<usize, EncodeError> {
    // Straight to the little-endian body: no run-time byte-order dispatch on the
    // path every publisher takes.
    encode_body::<T, LittleEndian>(msg, buf).map_err(|e| with_needed(e, msg, buf.len()))
}

/// [`encode_into`] in the given byte order.
#[inline]
pub fn encode_into_with<T: CdrEncode + ?Sized>(
    msg: &T,
    buf: &mut [u8],
    endianness: Endianness,
) -> Result<usize, EncodeError> {
    let result = match endianness {
        Endianness::Little => encode_body::<T, LittleEndian>(msg, buf),
        Endianness::Big => encode_body::<T, BigEndian>(msg, buf),
    };
    result.map_err(|e| with_needed(e, msg, buf.len()))
}

/// A too-small buffer is detected deep in the writer, which does not know the
/// message's size; fill it in here.
#[cold]
fn with_needed<T: CdrEncode + ?Sized>(
    mut e: EncodeError,
    msg: &T,
    available: usize,
) -> EncodeError {
    if let EncodeErrorKind::BufferTooSmall { .. } = e.kind() {
        e.set_kind(EncodeErrorKind::BufferTooSmall {
            needed: encoded_size(msg),
            available,
        });
    }
    e
}

/// The encapsulation header's bytes of `buf`, and the body after them.
#[inline(always)]
fn split_header(buf: &mut [u8]) -> Result<(&mut [u8; HEADER_LEN], &mut [u8]), EncodeError> {
    let available = buf.len();
    buf.split_first_chunk_mut::<HEADER_LEN>().ok_or_else(|| {
        EncodeError::new(EncodeErrorKind::BufferTooSmall {
            needed: HEADER_LEN,
            available,
        })
    })
}

#[inline(always)]
fn encode_body<T: CdrEncode + ?Sized, B: ByteOrder>(
    msg: &T,
    buf: &mut [u8],
) -> Result<usize, EncodeError> {
    let (header, body) = split_header(buf)?;
    *header = B::ENDIANNESS.header();
    let mut w = Writer::<B>::new(body);
    msg.encode(&mut w)?;
    Ok(HEADER_LEN + w.position())
}

/// `to_vec` without zero-filling first: the message is written once, straight
/// into the `Vec`'s uninitialized capacity.
#[inline(always)]
fn encode_to_vec<T: CdrEncode + ?Sized, B: ByteOrder>(msg: &T) -> Result<Vec<u8>, EncodeError> {
    let size = encoded_size(msg);
    let mut out = Vec::with_capacity(size);
    out.extend_from_slice(&B::ENDIANNESS.header());
    let written = {
        let body = out
            .spare_capacity_mut()
            .get_mut(..size - HEADER_LEN)
            .unwrap_or_default();
        let mut w = encode::Writer::<B>::over_uninit(body);
        msg.encode(&mut w).map_err(|e| with_needed(e, msg, size))?;
        w.position()
    };
    debug_assert_eq!(
        HEADER_LEN + written,
        size,
        "encoded_end disagrees with encode"
    );
    // SAFETY: the writer initialized the first `written` bytes of the spare
    // capacity (its invariant: everything before its position), which starts
    // right after the header's `HEADER_LEN` initialized bytes, and `written` is at
    // most the `size - HEADER_LEN` bytes it was given, within the capacity.
    #[allow(unsafe_code)]
    unsafe {
        out.set_len(HEADER_LEN + written);
    }
    Ok(out)
}

/// Encode `msg` as little-endian CDR into a new `Vec` of exactly
/// [`encoded_size`] bytes.
///
/// ```
/// use shm_cdr::msgs::geometry_msgs::Point;
///
/// let bytes = shm_cdr::to_vec(&Point { x: 1.0, y: 2.0, z: 3.0 })?;
/// assert_eq!(bytes.len(), 4 + 3 * 8); // the encapsulation header, three float64
/// assert_eq!(&bytes[..4], [0x00, 0x01, 0x00, 0x00]); // CDR, little endian
/// assert_eq!(&bytes[4..12], 1.0f64.to_le_bytes());
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[inline]
pub fn to_vec<T: CdrEncode + ?Sized>(msg: &T) -> Result<Vec<u8>, EncodeError> {
    encode_to_vec::<T, LittleEndian>(msg)
}

/// [`to_vec`] in the given byte order.
pub fn to_vec_with<T: CdrEncode + ?Sized>(
    msg: &T,
    endianness: Endianness,
) -> Result<Vec<u8>, EncodeError> {
    match endianness {
        Endianness::Little => encode_to_vec::<T, LittleEndian>(msg),
        Endianness::Big => encode_to_vec::<T, BigEndian>(msg),
    }
}

/// Read the encapsulation header: the byte order of the message that follows.
/// The two option bytes are ignored.
pub fn read_header(bytes: &[u8]) -> Result<Endianness, DecodeError> {
    match bytes {
        [0x00, 0x01, _, _, ..] => Ok(Endianness::Little),
        [0x00, 0x00, _, _, ..] => Ok(Endianness::Big),
        [a, b, _, _, ..] => Err(DecodeError::new(
            DecodeErrorKind::UnknownEncapsulation([*a, *b]),
            0,
        )),
        _ => Err(DecodeError::new(
            DecodeErrorKind::UnexpectedEof {
                needed: HEADER_LEN,
                remaining: bytes.len(),
            },
            0,
        )),
    }
}

/// Decode a message from CDR in either byte order. `T` may borrow from `bytes`
/// (`&str`, `&[u8]`, `Cow` fields).
///
/// Bytes after the end of the message are ignored, as rclpy and Fast-CDR ignore
/// them: real ROS 2 sends them (rmw_fastrtps' `serialize_message` returns its size
/// *estimate*, up to 8 bytes past the message; rmw_zenoh_cpp's shared-memory
/// payloads are rounded up to 4 bytes). [`take_from_bytes`] says how many there
/// were; [`from_bytes_strict`] refuses more than 3.
///
/// ```
/// use shm_cdr::msgs::std_msgs::String as RosString;
/// use shm_cdr::RosMessage;
///
/// #[derive(RosMessage)]
/// #[ros(type_name = "std_msgs/msg/String")]
/// struct StringRef<'a> {
///     data: &'a str, // borrowed from the bytes
/// }
///
/// let bytes = shm_cdr::to_vec(&RosString { data: "hello".into() })?;
/// let owned: RosString = shm_cdr::from_bytes(&bytes)?;
/// let view: StringRef = shm_cdr::from_bytes(&bytes)?;
/// assert_eq!((owned.data.as_str(), view.data), ("hello", "hello"));
///
/// // Truncated input is an error that says where, never a panic.
/// let err = shm_cdr::from_bytes::<RosString>(&bytes[..7]).unwrap_err();
/// println!("{err}");
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[inline]
pub fn from_bytes<'de, T: CdrDecode<'de>>(bytes: &'de [u8]) -> Result<T, DecodeError> {
    read_message(bytes, NewValue(PhantomData), AfterEnd::Ignore, false).map(|(value, _)| value)
}

/// [`from_bytes`] for input in memory that other processes may write while
/// the value lives, such as a shared-memory segment (see
/// [`Reader::shared`]): strings are copied and checked in the copy (a
/// `Cow<str>` field is read owned; a `&str` field is a
/// [`DecodeErrorKind::SharedBorrow`] error), byte and number slices borrow.
/// No rewrite of the input can then make a decoded value invalid.
#[inline]
pub fn from_shared_bytes<'de, T: CdrDecode<'de>>(bytes: &'de [u8]) -> Result<T, DecodeError> {
    read_message(bytes, NewValue(PhantomData), AfterEnd::Ignore, true).map(|(value, _)| value)
}

/// [`from_shared_bytes`] into an existing value (see [`from_bytes_into`]).
#[inline]
pub fn from_shared_bytes_into<'de, T: CdrDecode<'de>>(
    bytes: &'de [u8],
    out: &mut T,
) -> Result<(), DecodeError> {
    read_message(bytes, IntoValue(out), AfterEnd::Ignore, true).map(|_| ())
}

/// [`from_bytes`], also returning the bytes that follow the end of the message
/// (padding, a size estimate's slack, or whatever the sender appended).
#[inline]
pub fn take_from_bytes<'de, T: CdrDecode<'de>>(
    bytes: &'de [u8],
) -> Result<(T, &'de [u8]), DecodeError> {
    let (value, trailing) = read_message(bytes, NewValue(PhantomData), AfterEnd::Ignore, false)?;
    Ok((value, &bytes[bytes.len() - trailing..]))
}

/// [`from_bytes`] for input that must hold exactly one message: at most 3 bytes of
/// padding may follow it (what some DDS transports append); more is a
/// [`DecodeErrorKind::TrailingBytes`] error.
#[inline]
pub fn from_bytes_strict<'de, T: CdrDecode<'de>>(bytes: &'de [u8]) -> Result<T, DecodeError> {
    read_message(bytes, NewValue(PhantomData), AfterEnd::AtMostPadding, false)
        .map(|(value, _)| value)
}

/// [`from_bytes`] into an existing value, reusing the memory it owns (see
/// [`CdrDecode::decode_into`]): decoding every message into the same value
/// allocates only when one outgrows it. On error `out` is valid but unspecified.
#[inline]
pub fn from_bytes_into<'de, T: CdrDecode<'de>>(
    bytes: &'de [u8],
    out: &mut T,
) -> Result<(), DecodeError> {
    read_message(bytes, IntoValue(out), AfterEnd::Ignore, false).map(|_| ())
}

/// Decode a message that arrived as consecutive fragments (e.g. a Zenoh payload
/// with a spliced shared-memory block), borrowing from each fragment. A value that
/// straddles two fragments gives [`DecodeErrorKind::Fragmented`]: decode a
/// contiguous copy with [`from_bytes`] then. The header must be in the first
/// fragment; at most [`MAX_SEGMENTS`] fragments.
pub fn from_segments<'de, T: CdrDecode<'de>>(segments: &[&'de [u8]]) -> Result<T, DecodeError> {
    read_segments(segments, NewValue(PhantomData), false)
}

/// [`from_segments`] into an existing value, reusing the memory it owns (see
/// [`from_bytes_into`]).
pub fn from_segments_into<'de, T: CdrDecode<'de>>(
    segments: &[&'de [u8]],
    out: &mut T,
) -> Result<(), DecodeError> {
    read_segments(segments, IntoValue(out), false)
}

/// [`from_segments`] for fragments of which any may lie in memory other
/// processes write (see [`from_shared_bytes`]).
pub fn from_shared_segments<'de, T: CdrDecode<'de>>(
    segments: &[&'de [u8]],
) -> Result<T, DecodeError> {
    read_segments(segments, NewValue(PhantomData), true)
}

/// [`from_shared_segments`] into an existing value (see [`from_bytes_into`]).
pub fn from_shared_segments_into<'de, T: CdrDecode<'de>>(
    segments: &[&'de [u8]],
    out: &mut T,
) -> Result<(), DecodeError> {
    read_segments(segments, IntoValue(out), true)
}

/// What follows the end of a message may be.
#[derive(Clone, Copy)]
enum AfterEnd {
    /// Anything: it is ignored.
    Ignore,
    /// At most 3 bytes of padding.
    AtMostPadding,
}

/// What to do with a message body once its byte order is known: make a new value
/// or decode into an existing one. Lets the entry points share the header and
/// trailing-bytes handling.
trait ReadBody<'de> {
    type Output;
    fn read<B: ByteOrder>(self, r: &mut Reader<'de, B>) -> Result<Self::Output, DecodeError>;
}

struct NewValue<T>(PhantomData<T>);

impl<'de, T: CdrDecode<'de>> ReadBody<'de> for NewValue<T> {
    type Output = T;
    #[inline(always)]
    fn read<B: ByteOrder>(self, r: &mut Reader<'de, B>) -> Result<T, DecodeError> {
        T::decode(r)
    }
}

struct IntoValue<'a, T>(&'a mut T);

impl<'de, T: CdrDecode<'de>> ReadBody<'de> for IntoValue<'_, T> {
    type Output = ();
    #[inline(always)]
    fn read<B: ByteOrder>(self, r: &mut Reader<'de, B>) -> Result<(), DecodeError> {
        self.0.decode_into(r)
    }
}

#[inline(always)]
fn read_message<'de, R: ReadBody<'de>>(
    bytes: &'de [u8],
    body: R,
    after_end: AfterEnd,
    shared: bool,
) -> Result<(R::Output, usize), DecodeError> {
    fn reader<B: ByteOrder>(rest: &[u8], shared: bool) -> Reader<'_, B> {
        let reader = Reader::new(rest);
        if shared {
            reader.shared()
        } else {
            reader
        }
    }
    match bytes {
        // The common case first, without a call: little-endian plain CDR.
        [0x00, 0x01, _, _, rest @ ..] => {
            finish(&mut reader::<LittleEndian>(rest, shared), body, after_end)
        }
        [0x00, 0x00, _, _, rest @ ..] => {
            finish(&mut reader::<BigEndian>(rest, shared), body, after_end)
        }
        _ => Err(read_header(bytes).err().unwrap_or_else(|| {
            DecodeError::new(DecodeErrorKind::UnknownEncapsulation([0xff, 0xff]), 0)
        })),
    }
}

fn read_segments<'de, R: ReadBody<'de>>(
    segments: &[&'de [u8]],
    body: R,
    shared: bool,
) -> Result<R::Output, DecodeError> {
    let first = segments.first().copied().unwrap_or_default();
    let endianness = read_header(first)?;
    let mut rest = [&[][..]; MAX_SEGMENTS];
    if segments.len() > MAX_SEGMENTS {
        return Err(DecodeError::new(DecodeErrorKind::Fragmented { len: 0 }, 0));
    }
    rest[0] = &first[HEADER_LEN..];
    rest[1..segments.len()].copy_from_slice(&segments[1..]);
    let rest = &rest[..segments.len()];
    let fragmented = || DecodeError::new(DecodeErrorKind::Fragmented { len: 0 }, 0);
    fn reader<'de, B: ByteOrder>(rest: &[&'de [u8]], shared: bool) -> Option<Reader<'de, B>> {
        let reader = Reader::from_segments(rest)?;
        Some(if shared { reader.shared() } else { reader })
    }
    match endianness {
        Endianness::Little => finish(
            &mut reader::<LittleEndian>(rest, shared).ok_or_else(fragmented)?,
            body,
            AfterEnd::Ignore,
        )
        .map(|(value, _)| value),
        Endianness::Big => finish(
            &mut reader::<BigEndian>(rest, shared).ok_or_else(fragmented)?,
            body,
            AfterEnd::Ignore,
        )
        .map(|(value, _)| value),
    }
}

/// Read the body, then check what follows it; returns the value and the number of
/// bytes after it.
#[inline(always)]
fn finish<'de, B: ByteOrder, R: ReadBody<'de>>(
    r: &mut Reader<'de, B>,
    body: R,
    after_end: AfterEnd,
) -> Result<(R::Output, usize), DecodeError> {
    let value = body.read(r)?;
    let trailing = r.remaining();
    if trailing > 3 && matches!(after_end, AfterEnd::AtMostPadding) {
        return Err(r.error_at(
            r.position(),
            DecodeErrorKind::TrailingBytes { count: trailing },
        ));
    }
    Ok((value, trailing))
}
