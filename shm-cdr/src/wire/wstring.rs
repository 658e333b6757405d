//! `wstring`: a `u32` count of UTF-16 code units, each widened to a `u32`, no
//! terminator (rosidl_typesupport_fastrtps).

use crate::bounded::{BoundedWString, WString};
use crate::decode::{CdrDecode, Reader};
use crate::describe::{FieldType, RosElement, RosType, TypeId};
use crate::encode::{CdrEncode, Writer};
use crate::endian::ByteOrder;
use crate::error::{DecodeError, DecodeErrorKind, EncodeError, EncodeErrorKind};
use crate::layout::align_up;
use crate::loan::{Carver, InPlace, InPlaceElement, LoanError, WStrSlot};

pub(crate) fn utf16_len(s: &str) -> usize {
    s.chars().map(char::len_utf16).sum()
}

pub(crate) fn wstring_end(start: usize, s: &str) -> usize {
    align_up(start, 4) + 4 + 4 * utf16_len(s)
}

pub(crate) fn write_wstring<B: ByteOrder>(
    w: &mut Writer<'_, B>,
    s: &str,
    bound: Option<usize>,
) -> Result<(), EncodeError> {
    let units = utf16_len(s);
    if let Some(bound) = bound.filter(|&bound| units > bound) {
        return Err(EncodeError::new(EncodeErrorKind::BoundExceeded {
            len: units,
            bound,
        }));
    }
    w.write_len(units)?;
    // The count left the writer 4-aligned, so the units follow with no padding.
    let slot = w.aligned_slot(4, units * 4)?;
    for (dst, unit) in slot.chunks_exact_mut(4).zip(s.encode_utf16()) {
        let unit = u32::from(unit);
        dst.copy_from_slice(&if B::LITTLE {
            unit.to_le_bytes()
        } else {
            unit.to_be_bytes()
        });
    }
    Ok(())
}

pub(crate) fn read_wstring<B: ByteOrder>(
    r: &mut Reader<'_, B>,
    bound: Option<usize>,
) -> Result<String, DecodeError> {
    let at = r.position();
    let units = r.read_count(4)?;
    if let Some(bound) = bound.filter(|&bound| units > bound) {
        return Err(r.error_at(at, DecodeErrorKind::BoundExceeded { len: units, bound }));
    }
    let start = r.position();
    let bytes = r.read_aligned_bytes(4, units * 4)?;
    let mut wide = Vec::with_capacity(units);
    for (i, chunk) in bytes.chunks_exact(4).enumerate() {
        let mut raw = [0u8; 4];
        raw.copy_from_slice(chunk);
        let unit = if B::LITTLE {
            u32::from_le_bytes(raw)
        } else {
            u32::from_be_bytes(raw)
        };
        let narrow = u16::try_from(unit)
            .map_err(|_| r.error_at(start + 4 * i, DecodeErrorKind::InvalidUtf16 { unit }))?;
        wide.push(narrow);
    }
    let mut out = String::with_capacity(units);
    for (i, c) in char::decode_utf16(wide.iter().copied()).enumerate() {
        match c {
            Ok(c) => out.push(c),
            Err(e) => {
                return Err(r.error_at(
                    start + 4 * i,
                    DecodeErrorKind::InvalidUtf16 {
                        unit: u32::from(e.unpaired_surrogate()),
                    },
                ))
            }
        }
    }
    Ok(out)
}

impl CdrEncode for WString {
    fn encoded_end(&self, start: usize) -> usize {
        wstring_end(start, self)
    }

    fn encode<B: ByteOrder>(&self, w: &mut Writer<'_, B>) -> Result<(), EncodeError> {
        write_wstring(w, self, None)
    }
}

impl<'de> CdrDecode<'de> for WString {
    const MIN_WIRE_SIZE: usize = 4;

    fn decode<B: ByteOrder>(r: &mut Reader<'de, B>) -> Result<Self, DecodeError> {
        read_wstring(r, None).map(Self)
    }
}

impl<const N: usize> CdrEncode for BoundedWString<N> {
    fn encoded_end(&self, start: usize) -> usize {
        wstring_end(start, self)
    }

    fn encode<B: ByteOrder>(&self, w: &mut Writer<'_, B>) -> Result<(), EncodeError> {
        write_wstring(w, self, Some(N))
    }
}

impl<'de, const N: usize> CdrDecode<'de> for BoundedWString<N> {
    const MIN_WIRE_SIZE: usize = 4;

    fn decode<B: ByteOrder>(r: &mut Reader<'de, B>) -> Result<Self, DecodeError> {
        read_wstring(r, Some(N)).map(Self)
    }
}

impl RosType for WString {
    const FIELD_TYPE: FieldType = FieldType::scalar(TypeId::WString);
}
impl RosElement for WString {}

impl<const N: usize> RosType for BoundedWString<N> {
    const FIELD_TYPE: FieldType = FieldType::bounded_string(TypeId::BoundedWString, N);
}
impl<const N: usize> RosElement for BoundedWString<N> {}

/// The end of a wstring of `units` UTF-16 code units starting at `start`.
fn wstring_end_in_place(units: usize, start: usize) -> Option<usize> {
    align_up(start, 4)
        .checked_add(4)?
        .checked_add(units.checked_mul(4)?)
}

fn carve_wstring<'a>(
    units: usize,
    bound: Option<usize>,
    c: &mut Carver<'a>,
) -> Result<WStrSlot<'a>, LoanError> {
    if let Some(bound) = bound.filter(|&bound| units > bound) {
        return Err(LoanError::BoundExceeded { len: units, bound });
    }
    c.count(units)?;
    let at = c.offset();
    let slot = c.take(4, units.checked_mul(4).ok_or(LoanError::TooLarge)?)?;
    Ok(WStrSlot::new(slot, at, c.current_field(), c.written()))
}

text_in_place!([] WString, slot: WStrSlot, len: |s: &Self| utf16_len(s), end: wstring_end_in_place, carve: carve_wstring, min: 4, bound: None);
text_in_place!([const N: usize] BoundedWString<N>, slot: WStrSlot, len: |s: &Self| utf16_len(s), end: wstring_end_in_place, carve: carve_wstring, min: 4, bound: Some(N));
