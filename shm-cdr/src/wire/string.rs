//! `string`: a `u32` length that counts the terminating NUL, the UTF-8 bytes, NUL.

use std::borrow::Cow;

use crate::bounded::BoundedString;
use crate::decode::{CdrDecode, Reader};
use crate::describe::{FieldType, RosElement, RosType, TypeId};
use crate::encode::{CdrEncode, Writer};
use crate::endian::ByteOrder;
use crate::error::{DecodeError, DecodeErrorKind, EncodeError, EncodeErrorKind};
use crate::layout::align_up;

#[inline(always)]
fn string_end(start: usize, len: usize) -> usize {
    align_up(start, 4) + 4 + len + 1
}

#[inline]
fn write_string<B: ByteOrder>(w: &mut Writer<'_, B>, s: &str) -> Result<(), EncodeError> {
    let len = s.len();
    let with_nul = u32::try_from(len + 1)
        .map_err(|_| EncodeError::new(EncodeErrorKind::LengthOverflow { len }))?;
    // One bounds check for prefix, contents and NUL together.
    let slot = w.aligned_slot(4, 4 + len + 1)?;
    let (prefix, rest) = slot.split_at_mut(4);
    prefix.copy_from_slice(&if B::LITTLE {
        with_nul.to_le_bytes()
    } else {
        with_nul.to_be_bytes()
    });
    let (contents, nul) = rest.split_at_mut(len);
    contents.copy_from_slice(s.as_bytes());
    nul.fill(0);
    Ok(())
}

/// Read a string borrowed from the input. A length of 0 (no NUL at all) is read as
/// the empty string, as Fast-CDR does.
#[inline]
fn read_str<'de, B: ByteOrder>(r: &mut Reader<'de, B>) -> Result<&'de str, DecodeError> {
    let with_nul = r.read_count(1)?;
    let at = r.position();
    let bytes = r.read_bytes(with_nul)?;
    let Some((&last, contents)) = bytes.split_last() else {
        return Ok("");
    };
    if last != 0 {
        return Err(r.error_at(
            at + with_nul - 1,
            DecodeErrorKind::MissingNul { found: last },
        ));
    }
    std::str::from_utf8(contents).map_err(|e| {
        r.error_at(
            at + e.valid_up_to(),
            DecodeErrorKind::InvalidUtf8 {
                valid_up_to: e.valid_up_to(),
            },
        )
    })
}

macro_rules! unbounded_string_encode {
    ($($ty:ty),*) => {$(
        impl CdrEncode for $ty {
            #[inline]
            fn encoded_end(&self, start: usize) -> usize {
                string_end(start, self.len())
            }

            #[inline]
            fn encode<B: ByteOrder>(&self, w: &mut Writer<'_, B>) -> Result<(), EncodeError> {
                write_string(w, self)
            }
        }
    )*};
}
unbounded_string_encode!(str, String, Cow<'_, str>);

impl<'de> CdrDecode<'de> for String {
    const MIN_WIRE_SIZE: usize = 4;

    #[inline]
    fn decode<B: ByteOrder>(r: &mut Reader<'de, B>) -> Result<Self, DecodeError> {
        read_str(r).map(str::to_owned)
    }
}

impl<'de: 'a, 'a> CdrDecode<'de> for &'a str {
    const MIN_WIRE_SIZE: usize = 4;

    #[inline]
    fn decode<B: ByteOrder>(r: &mut Reader<'de, B>) -> Result<Self, DecodeError> {
        read_str(r)
    }
}

impl<'de: 'a, 'a> CdrDecode<'de> for Cow<'a, str> {
    const MIN_WIRE_SIZE: usize = 4;

    #[inline]
    fn decode<B: ByteOrder>(r: &mut Reader<'de, B>) -> Result<Self, DecodeError> {
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
        let at = r.position();
        let s = read_str(r)?;
        if s.len() > N {
            return Err(r.error_at(
                at,
                DecodeErrorKind::BoundExceeded {
                    len: s.len(),
                    bound: N,
                },
            ));
        }
        Ok(Self(s.to_owned()))
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
