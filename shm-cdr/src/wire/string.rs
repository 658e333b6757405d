//! `string`: a `u32` length that counts the terminating NUL, the UTF-8 bytes, NUL.

use std::borrow::Cow;
use std::mem::MaybeUninit;

use crate::bounded::BoundedString;
use crate::decode::{CdrDecode, Reader};
use crate::describe::{FieldType, RosElement, RosType, TypeId};
use crate::encode::{zero_padding, CdrEncode, Writer};
use crate::endian::ByteOrder;
use crate::error::{DecodeError, DecodeErrorKind, EncodeError, EncodeErrorKind};
use crate::layout::{align_up, as_uninit};
use crate::loan::{Carver, InPlace, InPlaceElement, LoanError, StrSlot};

#[inline(always)]
pub(crate) fn string_end(start: usize, len: usize) -> usize {
    align_up(start, 4) + 4 + len + 1
}

/// The position after a run of strings starting at `start`.
///
/// A string's prefix is 4-aligned, so where it ends modulo 4 depends only on its
/// own length: every string but the last spans exactly `4 + align_up(len + 1, 4)`
/// bytes from its prefix to the next one's, wherever the run started. The sum
/// then has no dependency from one string to the next (the obvious fold threads
/// the position through every element) and the compiler vectorizes it.
#[inline]
pub(crate) fn strings_end<S: AsRef<str>>(start: usize, items: &[S]) -> usize {
    let Some((last, init)) = items.split_last() else {
        return start;
    };
    let spans: usize = init
        .iter()
        .map(|s| 4 + align_up(s.as_ref().len() + 1, 4))
        .sum();
    string_end(align_up(start, 4) + spans, last.as_ref().len())
}

/// Copy `src` into `dst` (same length). Strings in messages are mostly short
/// (frame ids, joint names): up to 16 bytes this is two overlapping fixed-size
/// moves instead of a call into `memcpy`.
#[inline(always)]
fn copy_short(dst: &mut [MaybeUninit<u8>], src: &[u8]) {
    let src = as_uninit(src);
    let n = src.len();
    match n {
        0 => {}
        1..=3 => {
            dst[0] = src[0];
            dst[n / 2] = src[n / 2];
            dst[n - 1] = src[n - 1];
        }
        4..=7 => {
            dst[..4].copy_from_slice(&src[..4]);
            dst[n - 4..n].copy_from_slice(&src[n - 4..n]);
        }
        8..=16 => {
            dst[..8].copy_from_slice(&src[..8]);
            dst[n - 8..n].copy_from_slice(&src[n - 8..n]);
        }
        _ => dst[..n].copy_from_slice(src),
    }
}

/// Write one string (prefix, contents, NUL) into `out`, which is exactly
/// `4 + len + 1` bytes. Every byte of `out` is written, on error too (zeroed):
/// a caller's own `encode` may swallow the error, and the writer's invariant
/// must hold regardless.
#[inline(always)]
fn put_string<B: ByteOrder>(out: &mut [MaybeUninit<u8>], s: &str) -> Result<(), EncodeError> {
    let len = s.len();
    let with_nul = match u32::try_from(len + 1) {
        // The length check covers `out` too: every caller sized it from `s`.
        Ok(with_nul) if out.len() == 4 + len + 1 => with_nul,
        _ => {
            out.fill(MaybeUninit::new(0));
            return Err(EncodeError::new(EncodeErrorKind::LengthOverflow { len }));
        }
    };
    let (prefix, rest) = out.split_at_mut(4);
    let prefix_bytes = if B::LITTLE {
        with_nul.to_le_bytes()
    } else {
        with_nul.to_be_bytes()
    };
    prefix.copy_from_slice(&prefix_bytes.map(MaybeUninit::new));
    let (contents, nul) = rest.split_at_mut(len);
    copy_short(contents, s.as_bytes());
    nul[0] = MaybeUninit::new(0);
    Ok(())
}

#[inline]
pub(crate) fn write_string<B: ByteOrder>(
    w: &mut Writer<'_, B>,
    s: &str,
) -> Result<(), EncodeError> {
    // One bounds check for prefix, contents and NUL together.
    put_string::<B>(w.aligned_slot_uninit(4, 4 + s.len() + 1)?, s)
}

/// A sequence of strings: one bounds check for the whole run, then each string
/// written in place.
#[inline]
pub(crate) fn write_strings<B: ByteOrder, S: AsRef<str>>(
    w: &mut Writer<'_, B>,
    items: &[S],
) -> Result<(), EncodeError> {
    let start = w.position();
    let end = strings_end(start, items);
    let region = w.aligned_slot_uninit(1, end - start)?;
    let mut at = 0;
    let outcome = 'write: {
        for s in items {
            let s = s.as_ref();
            let pad = (start + at).wrapping_neg() % 4;
            let total = pad + 4 + s.len() + 1;
            let Some(slot) = region.get_mut(at..at + total) else {
                // Unreachable: `end` summed exactly these lengths. Report, don't panic.
                break 'write Err(EncodeError::new(EncodeErrorKind::LengthOverflow {
                    len: s.len(),
                }));
            };
            let (padding, out) = slot.split_at_mut(pad);
            zero_padding(padding);
            if let Err(e) = put_string::<B>(out, s) {
                break 'write Err(e);
            }
            at += total;
        }
        if at != region.len() {
            // Unreachable, as above.
            break 'write Err(EncodeError::new(EncodeErrorKind::LengthOverflow {
                len: at,
            }));
        }
        Ok(())
    };
    if outcome.is_err() {
        // The position is already past the region, and a caller's own `encode`
        // may swallow the error: the writer's invariant needs every byte written.
        if let Some(rest) = region.get_mut(at..) {
            rest.fill(MaybeUninit::new(0));
        }
    }
    outcome
}

/// The bytes of a string before its NUL, borrowed from the input and not yet
/// checked as UTF-8, with the body position of the first. A length of 0 (no
/// NUL at all) is read as the empty string, as Fast-CDR does.
#[inline]
fn read_str_bytes<'de, B: ByteOrder>(
    r: &mut Reader<'de, B>,
) -> Result<(&'de [u8], usize), DecodeError> {
    let with_nul = r.read_count(1)?;
    let at = r.position();
    let bytes = r.read_bytes(with_nul)?;
    let Some((&last, contents)) = bytes.split_last() else {
        return Ok((&[], at));
    };
    if last != 0 {
        return Err(r.error_at(
            at + with_nul - 1,
            DecodeErrorKind::MissingNul { found: last },
        ));
    }
    Ok((contents, at))
}

fn invalid_utf8<B: ByteOrder>(r: &Reader<'_, B>, at: usize, e: std::str::Utf8Error) -> DecodeError {
    r.error_at(
        at + e.valid_up_to(),
        DecodeErrorKind::InvalidUtf8 {
            valid_up_to: e.valid_up_to(),
        },
    )
}

/// Read a string borrowed from the input, checked as UTF-8 where it lies. Not
/// from [shared](Reader::shared) input: another process could rewrite the bytes
/// after the check, and the `&str` would no longer be UTF-8.
#[inline]
fn read_str<'de, B: ByteOrder>(r: &mut Reader<'de, B>) -> Result<&'de str, DecodeError> {
    let at = r.position();
    if r.is_shared() {
        return Err(r.error_at(at, DecodeErrorKind::SharedBorrow));
    }
    let (contents, at) = read_str_bytes(r)?;
    utf8(contents).map_err(|e| invalid_utf8(r, at, e))
}

/// A string's bytes (see [`read_str_bytes`]), refused if longer than `bound`.
#[inline]
fn read_bounded_bytes<'de, B: ByteOrder>(
    r: &mut Reader<'de, B>,
    bound: Option<usize>,
) -> Result<(&'de [u8], usize), DecodeError> {
    let start = r.position();
    let (contents, at) = read_str_bytes(r)?;
    if let Some(bound) = bound.filter(|&bound| contents.len() > bound) {
        return Err(r.error_at(
            start,
            DecodeErrorKind::BoundExceeded {
                len: contents.len(),
                bound,
            },
        ));
    }
    Ok((contents, at))
}

/// Read a string into a new `String` of exactly its length. From
/// [shared](Reader::shared) input the bytes are copied first and checked as
/// UTF-8 in the copy, so what is checked is what is kept, even when another
/// process rewrites the input meanwhile.
#[inline]
fn read_string<B: ByteOrder>(
    r: &mut Reader<'_, B>,
    bound: Option<usize>,
) -> Result<String, DecodeError> {
    let (contents, at) = read_bounded_bytes(r, bound)?;
    if !r.is_shared() {
        // Input nobody else writes: checked where it lies, then copied.
        return match utf8(contents) {
            Ok(text) => Ok(text.to_owned()),
            Err(e) => Err(invalid_utf8(r, at, e)),
        };
    }
    checked_copy(r, at, contents.to_vec())
}

/// `bytes`, a copy of the contents of the string read at `at`, checked as
/// UTF-8: what is checked is what is kept.
#[inline]
#[allow(unsafe_code)]
fn checked_copy<B: ByteOrder>(
    r: &Reader<'_, B>,
    at: usize,
    bytes: Vec<u8>,
) -> Result<String, DecodeError> {
    match utf8(&bytes) {
        // SAFETY: `bytes` was just checked as UTF-8, and nothing else can
        // write it: it is this function's own allocation.
        Ok(_) => Ok(unsafe { String::from_utf8_unchecked(bytes) }),
        Err(e) => Err(invalid_utf8(r, at, e)),
    }
}

/// Read a string into `out`, reusing its memory; from shared input, copied
/// before it is checked, as [`read_string`] does.
#[inline]
fn read_string_into<B: ByteOrder>(
    r: &mut Reader<'_, B>,
    bound: Option<usize>,
    out: &mut String,
) -> Result<(), DecodeError> {
    let (contents, at) = read_bounded_bytes(r, bound)?;
    if !r.is_shared() {
        let text = utf8(contents).map_err(|e| invalid_utf8(r, at, e))?;
        out.clear();
        out.push_str(text);
        return Ok(());
    }
    let mut bytes = std::mem::take(out).into_bytes();
    bytes.clear();
    bytes.extend_from_slice(contents);
    *out = checked_copy(r, at, bytes)?;
    Ok(())
}

/// `str::from_utf8` with an ASCII fast path: names and frame ids are ASCII, and
/// for short strings the general validator's setup dominates (measured: 1 000
/// short strings decode in 9.1 µs with `from_utf8` alone; see `peer-bench`).
#[inline(always)]
#[allow(unsafe_code)]
fn utf8(bytes: &[u8]) -> Result<&str, std::str::Utf8Error> {
    if bytes.is_ascii() {
        // SAFETY: every byte is below 0x80, and a sequence of such bytes is valid
        // UTF-8 (each is a one-byte code point).
        Ok(unsafe { std::str::from_utf8_unchecked(bytes) })
    } else {
        std::str::from_utf8(bytes)
    }
}

macro_rules! unbounded_string_encode {
    ($ty:ty) => {
        unbounded_string_encode!($ty, {});
    };
    // Sized string types also write sequences of themselves as one run.
    ($ty:ty, runs) => {
        unbounded_string_encode!($ty, {
            #[inline]
            fn slice_encoded_end(items: &[Self], start: usize) -> usize {
                strings_end(start, items)
            }

            #[inline]
            fn encode_slice<B: ByteOrder>(
                items: &[Self],
                w: &mut Writer<'_, B>,
            ) -> Result<(), EncodeError> {
                write_strings(w, items)
            }
        });
    };
    ($ty:ty, { $($slice:tt)* }) => {
        impl CdrEncode for $ty {
            #[inline]
            fn encoded_end(&self, start: usize) -> usize {
                string_end(start, self.len())
            }

            #[inline]
            fn encode<B: ByteOrder>(&self, w: &mut Writer<'_, B>) -> Result<(), EncodeError> {
                write_string(w, self)
            }

            $($slice)*
        }
    };
}
// `str` is unsized (no slices of it); `&str` goes through the blanket `&T` impl.
unbounded_string_encode!(str);
unbounded_string_encode!(String, runs);
unbounded_string_encode!(Cow<'_, str>, runs);

impl<'de> CdrDecode<'de> for String {
    const MIN_WIRE_SIZE: usize = 4;

    #[inline]
    fn decode<B: ByteOrder>(r: &mut Reader<'de, B>) -> Result<Self, DecodeError> {
        read_string(r, None)
    }

    #[inline]
    fn decode_into<B: ByteOrder>(&mut self, r: &mut Reader<'de, B>) -> Result<(), DecodeError> {
        read_string_into(r, None, self)
    }
}

impl<'de: 'a, 'a> CdrDecode<'de> for &'a str {
    const MIN_WIRE_SIZE: usize = 4;

    #[inline]
    fn decode<B: ByteOrder>(r: &mut Reader<'de, B>) -> Result<Self, DecodeError> {
        read_str(r)
    }
}

/// Borrowed from ordinary input; copied (then checked) from
/// [shared](Reader::shared) input, which another process may rewrite.
impl<'de: 'a, 'a> CdrDecode<'de> for Cow<'a, str> {
    const MIN_WIRE_SIZE: usize = 4;

    #[inline]
    fn decode<B: ByteOrder>(r: &mut Reader<'de, B>) -> Result<Self, DecodeError> {
        if r.is_shared() {
            return read_string(r, None).map(Cow::Owned);
        }
        read_str(r).map(Cow::Borrowed)
    }
}

impl<const N: usize> CdrEncode for BoundedString<N> {
    #[inline]
    fn encoded_end(&self, start: usize) -> usize {
        string_end(start, self.len())
    }

    #[inline]
    fn encode<B: ByteOrder>(&self, w: &mut Writer<'_, B>) -> Result<(), EncodeError> {
        if self.len() > N {
            return Err(EncodeError::new(EncodeErrorKind::BoundExceeded {
                len: self.len(),
                bound: N,
            }));
        }
        write_string(w, self)
    }
}

impl<'de, const N: usize> CdrDecode<'de> for BoundedString<N> {
    const MIN_WIRE_SIZE: usize = 4;

    #[inline]
    fn decode<B: ByteOrder>(r: &mut Reader<'de, B>) -> Result<Self, DecodeError> {
        read_string(r, Some(N)).map(Self)
    }

    #[inline]
    fn decode_into<B: ByteOrder>(&mut self, r: &mut Reader<'de, B>) -> Result<(), DecodeError> {
        read_string_into(r, Some(N), &mut self.0)
    }
}

macro_rules! string_type {
    ($($ty:ty),*) => {$(
        impl RosType for $ty {
            const FIELD_TYPE: FieldType = FieldType::scalar(TypeId::String);
        }
        impl RosElement for $ty {}
    )*};
}
string_type!(String, str, &str, Cow<'_, str>);

impl<const N: usize> RosType for BoundedString<N> {
    const FIELD_TYPE: FieldType = FieldType::bounded_string(TypeId::BoundedString, N);
}
impl<const N: usize> RosElement for BoundedString<N> {}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::endian::LittleEndian;

    /// Every short-copy length class, in sequences that start at every phase,
    /// against the obvious byte-by-byte encoding.
    #[test]
    fn string_runs_match_the_plain_encoding_at_every_length_and_phase() {
        let strings: Vec<String> = (0..40)
            .map(|n| "é".repeat(n % 3) + &"x".repeat(n))
            .collect();
        for phase in 0..4 {
            let mut expected = vec![0u8; phase];
            for s in &strings {
                expected.resize(expected.len().next_multiple_of(4), 0);
                expected.extend_from_slice(&(s.len() as u32 + 1).to_le_bytes());
                expected.extend_from_slice(s.as_bytes());
                expected.push(0);
            }
            // Garbage where padding goes: it must come out zeroed.
            let mut buf = vec![0xAA; expected.len()];
            let mut w = Writer::<LittleEndian>::new(&mut buf);
            w.write_bytes(&vec![0; phase]).unwrap();
            String::encode_slice(&strings, &mut w).unwrap();
            assert_eq!(w.position(), expected.len());
            assert_eq!(buf, expected, "phase {phase}");

            let mut r = Reader::<LittleEndian>::new(&buf);
            r.read_bytes(phase).unwrap();
            let back = <&str>::decode_vec(&mut r, strings.len()).unwrap();
            assert_eq!(back, strings);
        }
    }

    proptest::proptest! {
        /// The closed form agrees with threading the position through each string.
        #[test]
        fn string_run_end_matches_the_fold(
            start in 0usize..64,
            lens in proptest::collection::vec(0usize..40, 0..24),
        ) {
            let strings: Vec<String> = lens.iter().map(|&n| "s".repeat(n)).collect();
            let folded = strings.iter().fold(start, |pos, s| string_end(pos, s.len()));
            proptest::prop_assert_eq!(strings_end(start, &strings), folded);
            proptest::prop_assert_eq!(String::slice_encoded_end(&strings, start), folded);
        }
    }
}

/// The end of a string of `len` bytes starting at `start`: count, bytes, NUL.
fn string_end_in_place(len: usize, start: usize) -> Option<usize> {
    align_up(start, 4).checked_add(5)?.checked_add(len)
}

/// Lay out a string of `len` bytes: its count and NUL written, its bytes left for
/// the [`StrSlot`].
fn carve_string<'a>(
    len: usize,
    bound: Option<usize>,
    c: &mut Carver<'a>,
) -> Result<StrSlot<'a>, LoanError> {
    if let Some(bound) = bound.filter(|&bound| len > bound) {
        return Err(LoanError::BoundExceeded { len, bound });
    }
    c.count(len.checked_add(1).ok_or(LoanError::TooLarge)?)?;
    let at = c.offset();
    let slot = c.take(1, len + 1)?;
    let (bytes, nul) = slot.split_at_mut(len);
    nul.fill(0);
    Ok(StrSlot::new(bytes, at, c.current_field(), c.written()))
}

text_in_place!([] String, slot: StrSlot, len: |s: &Self| s.len(), end: string_end_in_place, carve: carve_string, min: 5, bound: None);
text_in_place!(['c] Cow<'c, str>, slot: StrSlot, len: |s: &Self| s.len(), end: string_end_in_place, carve: carve_string, min: 5, bound: None);
text_in_place!([const N: usize] BoundedString<N>, slot: StrSlot, len: |s: &Self| s.len(), end: string_end_in_place, carve: carve_string, min: 5, bound: Some(N));

/// `compact_str::CompactString`: a `string` whose text of up to
/// [`MAX_INLINE`](compact::MAX_INLINE) bytes lives in the value itself, so an
/// owned decode of a short string allocates nothing.
#[cfg(feature = "compact_str")]
mod compact {
    use compact_str::CompactString;

    use super::*;

    /// The longest text a `CompactString` holds without allocating.
    pub(super) const MAX_INLINE: usize = std::mem::size_of::<CompactString>();

    unbounded_string_encode!(CompactString, runs);
    string_type!(CompactString);
    text_in_place!([] CompactString, slot: StrSlot, len: |s: &Self| s.len(), end: string_end_in_place, carve: carve_string, min: 5, bound: None);

    /// A string's checked text: where it was checked, or a copy too long to
    /// make on the stack.
    enum Text<'t> {
        Checked(&'t str),
        Copied(String),
    }

    impl Text<'_> {
        #[inline(always)]
        fn into_compact(self) -> CompactString {
            match self {
                Text::Checked(text) => CompactString::new(text),
                Text::Copied(text) => CompactString::from(text),
            }
        }
    }

    /// Read a string and hand its checked text to `keep`. Input that another
    /// process may rewrite ([shared](Reader::shared)) is copied before it is
    /// checked as UTF-8, so what is checked is what is kept.
    #[inline(always)]
    fn read_text<B: ByteOrder, T>(
        r: &mut Reader<'_, B>,
        keep: impl FnOnce(Text<'_>) -> T,
    ) -> Result<T, DecodeError> {
        let (contents, at) = read_str_bytes(r)?;
        if !r.is_shared() {
            return match utf8(contents) {
                Ok(text) => Ok(keep(Text::Checked(text))),
                Err(e) => Err(invalid_utf8(r, at, e)),
            };
        }
        let mut inline = [0u8; MAX_INLINE];
        match inline.get_mut(..contents.len()) {
            Some(copy) => {
                copy.copy_from_slice(contents);
                match utf8(copy) {
                    Ok(text) => Ok(keep(Text::Checked(text))),
                    Err(e) => Err(invalid_utf8(r, at, e)),
                }
            }
            None => checked_copy(r, at, contents.to_vec()).map(|text| keep(Text::Copied(text))),
        }
    }

    impl<'de> CdrDecode<'de> for CompactString {
        const MIN_WIRE_SIZE: usize = 4;

        #[inline]
        fn decode<B: ByteOrder>(r: &mut Reader<'de, B>) -> Result<Self, DecodeError> {
            read_text(r, |text| text.into_compact())
        }

        #[inline]
        fn decode_into<B: ByteOrder>(&mut self, r: &mut Reader<'de, B>) -> Result<(), DecodeError> {
            // Into the memory this value already has, when it has any.
            read_text(r, |text| match text {
                // Inline: nothing to reuse, and building it anew is cheapest.
                Text::Checked(text) if text.len() <= MAX_INLINE => {
                    *self = CompactString::new(text);
                }
                Text::Checked(text) => {
                    self.clear();
                    self.push_str(text);
                }
                Text::Copied(text) => *self = CompactString::from(text),
            })
        }
    }
}
