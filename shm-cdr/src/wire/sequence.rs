//! Sequences: a `u32` element count, then the elements. An empty sequence writes
//! only its count (no alignment for absent elements).

use std::borrow::Cow;

use crate::bounded::BoundedVec;
use crate::decode::{extend_decoded, CdrDecode, Reader};
use crate::describe::{FieldType, RosElement, RosType, TypeRegistry};
use crate::encode::{CdrEncode, Writer};
use crate::endian::ByteOrder;
use crate::error::{DecodeError, DecodeErrorKind, EncodeError, EncodeErrorKind};
use crate::layout::{align_up, FixedLayout};
use crate::loan::{Carver, InPlace, InPlaceElement, LoanError};
use crate::splice::{SpliceSink, SpliceSizing};

#[inline(always)]
fn sequence_end<T: CdrEncode>(items: &[T], start: usize) -> usize {
    T::slice_encoded_end(items, align_up(start, 4) + 4)
}

/// A sequence's splicing methods: element by element when its elements may
/// splice (see [`CdrEncode::SPLICES`]).
macro_rules! spliced_as_sequence {
    () => {
        const SPLICES: bool = T::SPLICES;

        #[inline]
        fn spliced_end(&self, start: usize, sizing: &mut SpliceSizing) -> usize {
            spliced_sequence_end(self, start, sizing)
        }

        #[inline]
        fn encode_spliced<B: ByteOrder>(
            &self,
            w: &mut Writer<'_, B>,
            sink: &mut dyn SpliceSink,
        ) -> Result<(), EncodeError> {
            write_spliced_sequence(self, w, sink)
        }
    };
}

/// [`sequence_end`] for a splicing write: element by element only when the
/// elements may splice.
#[inline]
fn spliced_sequence_end<T: CdrEncode>(
    items: &[T],
    start: usize,
    sizing: &mut SpliceSizing,
) -> usize {
    if !T::SPLICES {
        return sequence_end(items, start);
    }
    let data = align_up(start, 4) + 4;
    items
        .iter()
        .fold(data, |pos, item| item.spliced_end(pos, sizing))
}

/// [`write_sequence`] for a splicing write.
#[inline]
fn write_spliced_sequence<T: CdrEncode, B: ByteOrder>(
    items: &[T],
    w: &mut Writer<'_, B>,
    sink: &mut dyn SpliceSink,
) -> Result<(), EncodeError> {
    if !T::SPLICES {
        return write_sequence(items, w);
    }
    w.write_len(items.len())?;
    items
        .iter()
        .try_for_each(|item| item.encode_spliced(w, sink))
}

/// Replace the contents of `out` with `n` values read from `r`, decoding into the
/// elements it already has (keeping what they own) before appending the rest.
#[inline]
fn decode_vec_into<'de, T: CdrDecode<'de>, B: ByteOrder>(
    r: &mut Reader<'de, B>,
    n: usize,
    out: &mut Vec<T>,
) -> Result<(), DecodeError> {
    if T::PLAIN.is_some() {
        // Plain values own no memory: one bulk copy beats decoding in place.
        out.clear();
    } else {
        out.truncate(n);
        for item in out.iter_mut() {
            item.decode_into(r)?;
        }
    }
    let rest = n - out.len();
    extend_decoded(r, rest, out)
}

#[inline(always)]
fn write_sequence<T: CdrEncode, B: ByteOrder>(
    items: &[T],
    w: &mut Writer<'_, B>,
) -> Result<(), EncodeError> {
    w.write_len(items.len())?;
    T::encode_slice(items, w)
}

/// A sequence (`T[]`).
impl<T: CdrEncode> CdrEncode for [T] {
    spliced_as_sequence!();

    #[inline]
    fn encoded_end(&self, start: usize) -> usize {
        sequence_end(self, start)
    }

    #[inline]
    fn encode<B: ByteOrder>(&self, w: &mut Writer<'_, B>) -> Result<(), EncodeError> {
        write_sequence(self, w)
    }
}

impl<T: CdrEncode> CdrEncode for Vec<T> {
    spliced_as_sequence!();

    #[inline]
    fn encoded_end(&self, start: usize) -> usize {
        sequence_end(self, start)
    }

    #[inline]
    fn encode<B: ByteOrder>(&self, w: &mut Writer<'_, B>) -> Result<(), EncodeError> {
        write_sequence(self, w)
    }
}

impl<'de, T: CdrDecode<'de>> CdrDecode<'de> for Vec<T> {
    const MIN_WIRE_SIZE: usize = 4;

    #[inline]
    fn decode<B: ByteOrder>(r: &mut Reader<'de, B>) -> Result<Self, DecodeError> {
        let n = r.read_count(T::MIN_WIRE_SIZE)?;
        T::decode_vec(r, n)
    }

    #[inline]
    fn decode_into<B: ByteOrder>(&mut self, r: &mut Reader<'de, B>) -> Result<(), DecodeError> {
        let n = r.read_count(T::MIN_WIRE_SIZE)?;
        decode_vec_into(r, n, self)
    }
}

impl<T: CdrEncode + Clone> CdrEncode for Cow<'_, [T]> {
    spliced_as_sequence!();

    #[inline]
    fn encoded_end(&self, start: usize) -> usize {
        sequence_end(self, start)
    }

    #[inline]
    fn encode<B: ByteOrder>(&self, w: &mut Writer<'_, B>) -> Result<(), EncodeError> {
        write_sequence(self, w)
    }
}

/// Borrows for `u8` elements, copies otherwise.
impl<'de: 'a, 'a, T: CdrDecode<'de> + Clone + 'de> CdrDecode<'de> for Cow<'a, [T]> {
    const MIN_WIRE_SIZE: usize = 4;

    #[inline]
    fn decode<B: ByteOrder>(r: &mut Reader<'de, B>) -> Result<Self, DecodeError> {
        let n = r.read_count(T::MIN_WIRE_SIZE)?;
        T::decode_cow_slice(r, n)
    }
}

impl<T: CdrEncode, const N: usize> CdrEncode for BoundedVec<T, N> {
    const SPLICES: bool = T::SPLICES;

    #[inline]
    fn spliced_end(&self, start: usize, sizing: &mut SpliceSizing) -> usize {
        spliced_sequence_end(self, start, sizing)
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
        if self.len() > N {
            return Err(EncodeError::new(EncodeErrorKind::BoundExceeded {
                len: self.len(),
                bound: N,
            }));
        }
        write_spliced_sequence(self, w, sink)
    }

    #[inline]
    fn encoded_end(&self, start: usize) -> usize {
        sequence_end(self, start)
    }

    #[inline]
    fn encode<B: ByteOrder>(&self, w: &mut Writer<'_, B>) -> Result<(), EncodeError> {
        if self.len() > N {
            return Err(EncodeError::new(EncodeErrorKind::BoundExceeded {
                len: self.len(),
                bound: N,
            }));
        }
        write_sequence(self, w)
    }
}

impl<'de, T: CdrDecode<'de>, const N: usize> CdrDecode<'de> for BoundedVec<T, N> {
    const MIN_WIRE_SIZE: usize = 4;

    #[inline]
    fn decode<B: ByteOrder>(r: &mut Reader<'de, B>) -> Result<Self, DecodeError> {
        let n = read_bounded_count::<T, B, N>(r)?;
        T::decode_vec(r, n).map(Self)
    }

    #[inline]
    fn decode_into<B: ByteOrder>(&mut self, r: &mut Reader<'de, B>) -> Result<(), DecodeError> {
        let n = read_bounded_count::<T, B, N>(r)?;
        decode_vec_into(r, n, &mut self.0)
    }
}

/// The element count of a `T[<=N]`, checked against the bound and the input.
#[inline]
fn read_bounded_count<'de, T: CdrDecode<'de>, B: ByteOrder, const N: usize>(
    r: &mut Reader<'de, B>,
) -> Result<usize, DecodeError> {
    let at = r.position();
    let n = r.read_count(T::MIN_WIRE_SIZE)?;
    if n > N {
        return Err(r.error_at(at, DecodeErrorKind::BoundExceeded { len: n, bound: N }));
    }
    Ok(n)
}

/// A reference encodes as what it points to (`&str`, `&[u8]`, `&Msg`).
impl<T: CdrEncode + ?Sized> CdrEncode for &T {
    const FIXED_LAYOUT: Option<FixedLayout> = T::FIXED_LAYOUT;
    const SPLICES: bool = T::SPLICES;

    #[inline(always)]
    fn spliced_end(&self, start: usize, sizing: &mut SpliceSizing) -> usize {
        (**self).spliced_end(start, sizing)
    }

    #[inline(always)]
    fn encode_spliced<B: ByteOrder>(
        &self,
        w: &mut Writer<'_, B>,
        sink: &mut dyn SpliceSink,
    ) -> Result<(), EncodeError> {
        (**self).encode_spliced(w, sink)
    }

    #[inline(always)]
    fn encoded_end(&self, start: usize) -> usize {
        (**self).encoded_end(start)
    }

    #[inline(always)]
    fn encode<B: ByteOrder>(&self, w: &mut Writer<'_, B>) -> Result<(), EncodeError> {
        (**self).encode(w)
    }
}

macro_rules! unbounded_sequence_type {
    ($($ty:ty),*) => {$(
        impl<T: RosElement> RosType for $ty {
            const FIELD_TYPE: FieldType = T::FIELD_TYPE.unbounded_sequence();
            fn register_types(registry: &mut TypeRegistry) {
                T::register_types(registry);
            }
        }
    )*};
}
unbounded_sequence_type!(Vec<T>, [T]);

impl<T: RosElement + Clone> RosType for Cow<'_, [T]> {
    const FIELD_TYPE: FieldType = T::FIELD_TYPE.unbounded_sequence();
    fn register_types(registry: &mut TypeRegistry) {
        T::register_types(registry);
    }
}

impl<T: RosElement, const N: usize> RosType for BoundedVec<T, N> {
    const FIELD_TYPE: FieldType = T::FIELD_TYPE.bounded_sequence(N);
    fn register_types(registry: &mut TypeRegistry) {
        T::register_types(registry);
    }
}

/// The end of a sequence of `lens` starting at `start`: count, then the run.
#[inline]
fn sequence_end_in_place<T: InPlaceElement>(lens: &T::RunLens, start: usize) -> Option<usize> {
    T::run_end(lens, T::run_count(lens), align_up(start, 4).checked_add(4)?)
}

/// Lay out a sequence: its count written, its run carved by the element type.
#[inline]
fn carve_sequence<'a, T: InPlaceElement>(
    lens: &T::RunLens,
    bound: Option<usize>,
    c: &mut Carver<'a>,
) -> Result<T::RunMut<'a>, LoanError> {
    let n = T::run_count(lens);
    if let Some(bound) = bound.filter(|&bound| n > bound) {
        return Err(LoanError::BoundExceeded { len: n, bound });
    }
    c.count(n)?;
    T::carve_run(lens, n, c)
}

/// Sequences in place: the count is written at once, the elements are laid out
/// as the element type decides (numbers: one [`Uninit`](crate::loan::Uninit)).
macro_rules! sequence_in_place {
    ([$($g:tt)*] $ty:ty, $bound:expr) => {
        impl<$($g)*> InPlace for $ty {
            type Lens = T::RunLens;
            type Mut<'a> = T::RunMut<'a>;

            fn lens(&self) -> T::RunLens {
                T::run_lens(self)
            }

            fn end_in_place(lens: &T::RunLens, start: usize) -> Option<usize> {
                sequence_end_in_place::<T>(lens, start)
            }

            fn carve<'a>(lens: &T::RunLens, c: &mut Carver<'a>) -> Result<T::RunMut<'a>, LoanError> {
                carve_sequence::<T>(lens, $bound, c)
            }

            fn write_in_place(&self, place: T::RunMut<'_>) -> Result<(), LoanError> {
                T::write_run(self, place)
            }
        }
    };
}

sequence_in_place!([T: InPlaceElement] Vec<T>, None);
sequence_in_place!([T: InPlaceElement + Clone] Cow<'_, [T]>, None);
sequence_in_place!([T: InPlaceElement, const N: usize] BoundedVec<T, N>, Some(N));
