//! `bytes::Bytes`: a `uint8[]` sequence.

use bytes::Bytes;

use crate::decode::{CdrDecode, Reader};
use crate::describe::{FieldType, RosType, TypeId};
use crate::encode::{CdrEncode, Writer};
use crate::endian::ByteOrder;
use crate::error::{DecodeError, EncodeError};
use crate::loan::{Carver, InPlace, LoanError, Uninit};

impl CdrEncode for Bytes {
    #[inline]
    fn encoded_end(&self, start: usize) -> usize {
        self.as_ref().encoded_end(start)
    }

    #[inline]
    fn encode<B: ByteOrder>(&self, w: &mut Writer<'_, B>) -> Result<(), EncodeError> {
        self.as_ref().encode(w)
    }
}

/// Copies the bytes out of the input (borrow with `&[u8]` or `Cow<[u8]>` instead to
/// avoid the copy).
impl<'de> CdrDecode<'de> for Bytes {
    const MIN_WIRE_SIZE: usize = 4;

    #[inline]
    fn decode<B: ByteOrder>(r: &mut Reader<'de, B>) -> Result<Self, DecodeError> {
        <&[u8]>::decode(r).map(Bytes::copy_from_slice)
    }
}

impl RosType for Bytes {
    const FIELD_TYPE: FieldType = FieldType::scalar(TypeId::Uint8).unbounded_sequence();
}

/// In place, a `uint8[]` run like `Vec<u8>`.
impl InPlace for Bytes {
    type Lens = usize;
    type Mut<'a> = Uninit<'a, u8>;

    fn lens(&self) -> usize {
        self.len()
    }

    fn end_in_place(lens: &usize, start: usize) -> Option<usize> {
        <Vec<u8> as InPlace>::end_in_place(lens, start)
    }

    fn carve<'a>(lens: &usize, c: &mut Carver<'a>) -> Result<Uninit<'a, u8>, LoanError> {
        <Vec<u8> as InPlace>::carve(lens, c)
    }

    fn write_in_place(&self, place: Uninit<'_, u8>) -> Result<(), LoanError> {
        place.write_slice(self).map(drop)
    }
}
