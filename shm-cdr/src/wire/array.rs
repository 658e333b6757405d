//! Fixed arrays `[T; N]`: the elements only, no length prefix.

use crate::decode::{CdrDecode, Reader};
use crate::describe::{FieldType, RosElement, RosType, TypeRegistry};
use crate::encode::{CdrEncode, Writer};
use crate::endian::ByteOrder;
use crate::error::{DecodeError, EncodeError};
use crate::layout::{FixedLayout, PlainLayout};
use crate::loan::{Carver, InPlace, InPlaceElement, LoanError};
use crate::splice::{SpliceSink, SpliceSizing};

impl<T: CdrEncode, const N: usize> CdrEncode for [T; N] {
    const FIXED_LAYOUT: Option<FixedLayout> = FixedLayout::of_array(T::FIXED_LAYOUT, N);

    const PLAIN: Option<PlainLayout<Self>> = match T::PLAIN {
        // SAFETY: `[T; N]` is `N` values of `T` back to back with no gap, and
        // `size_of::<T>()` is a multiple of the proof's alignment, so every element
        // starts at a phase where `T`'s own proof holds.
        #[allow(unsafe_code)]
        Some(p) if N > 0 => Some(unsafe { PlainLayout::new_unchecked(p.align(), p.first_align()) }),
        _ => None,
    };

    const SPLICES: bool = T::SPLICES;

    #[inline]
    fn encoded_end(&self, start: usize) -> usize {
        T::slice_encoded_end(self, start)
    }

    #[inline]
    fn spliced_end(&self, start: usize, sizing: &mut SpliceSizing) -> usize {
        if !T::SPLICES {
            return self.encoded_end(start);
        }
        self.iter()
            .fold(start, |pos, item| item.spliced_end(pos, sizing))
    }

    #[inline]
    fn encode_spliced<B: ByteOrder>(
        &self,
        w: &mut Writer<'_, B>,
        sink: &mut dyn SpliceSink,
    ) -> Result<(), EncodeError> {
        if !T::SPLICES {
            return self.encode(w);
        }
        self.iter()
            .try_for_each(|item| item.encode_spliced(w, sink))
    }

    #[inline]
    fn encode<B: ByteOrder>(&self, w: &mut Writer<'_, B>) -> Result<(), EncodeError> {
        T::encode_slice(self, w)
    }
}

impl<'de, T: CdrDecode<'de>, const N: usize> CdrDecode<'de> for [T; N] {
    const MIN_WIRE_SIZE: usize = {
        // ROS has no empty arrays, and an element that takes no bytes would let a
        // length prefix of a sequence of them claim billions of elements for free.
        assert!(N > 0, "a fixed array field needs at least one element");
        T::MIN_WIRE_SIZE * N
    };

    const PLAIN: Option<PlainLayout<Self>> = match T::PLAIN {
        // SAFETY: as for encoding: `N` valid `T`s back to back are a valid array.
        #[allow(unsafe_code)]
        Some(p) if N > 0 => Some(unsafe { PlainLayout::new_unchecked(p.align(), p.first_align()) }),
        _ => None,
    };

    #[inline]
    fn decode<B: ByteOrder>(r: &mut Reader<'de, B>) -> Result<Self, DecodeError> {
        T::decode_array(r)
    }

    #[inline]
    fn decode_into<B: ByteOrder>(&mut self, r: &mut Reader<'de, B>) -> Result<(), DecodeError> {
        if T::PLAIN.is_some() {
            // Plain values own no memory: one bulk copy beats decoding in place.
            *self = T::decode_array(r)?;
            return Ok(());
        }
        self.iter_mut().try_for_each(|item| item.decode_into(r))
    }
}

impl<T: RosElement, const N: usize> RosType for [T; N] {
    const FIELD_TYPE: FieldType = T::FIELD_TYPE.array(N);
    fn register_types(registry: &mut TypeRegistry) {
        T::register_types(registry);
    }
}

/// Arrays in place, as the element type decides (numbers: a zeroed
/// `&mut [T; N]`).
impl<T: InPlaceElement, const N: usize> InPlace for [T; N] {
    type Lens = T::ArrayLens;
    type Mut<'a> = T::ArrayMut<'a, N>;

    fn lens(&self) -> T::ArrayLens {
        T::array_lens(self)
    }

    fn end_in_place(lens: &T::ArrayLens, start: usize) -> Option<usize> {
        T::array_end::<N>(lens, start)
    }

    fn carve<'a>(lens: &T::ArrayLens, c: &mut Carver<'a>) -> Result<T::ArrayMut<'a, N>, LoanError> {
        T::carve_array::<N>(lens, c)
    }

    fn write_in_place(&self, place: T::ArrayMut<'_, N>) -> Result<(), LoanError> {
        T::write_array(self, place)
    }
}
