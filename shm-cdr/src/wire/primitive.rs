//! Numbers and `bool`: aligned to their own size. Numbers are [plain], so
//! sequences of them take the one-copy path of `CdrEncode::encode_slice` /
//! `CdrDecode::decode_vec` in host byte order; fixed arrays decode onto the stack.
//!
//! [plain]: crate::layout::PlainLayout

use std::borrow::Cow;

use crate::decode::{CdrDecode, Reader};
use crate::describe::{FieldType, RosElement, RosType, TypeId};
use crate::encode::{CdrEncode, Writer};
use crate::endian::ByteOrder;
use crate::error::{DecodeError, DecodeErrorKind, EncodeError};
use crate::layout::{align_up, zeroed_bools, FixedLayout, PlainLayout};
use crate::loan::{self, Carver, InPlace, InPlaceElement, LoanBool, LoanError, Uninit};

macro_rules! number {
    ($($ty:ty => $size:literal, $type_id:ident $(, $borrow:ident)?;)*) => {$(
        impl CdrEncode for $ty {
            const FIXED_LAYOUT: Option<FixedLayout> = Some(FixedLayout::primitive($size));

            // SAFETY: a number is its own `$size` bytes in host order with no padding,
            // aligned to its size on the wire, and every bit pattern is a valid value.
            #[allow(unsafe_code)]
            const PLAIN: Option<PlainLayout<Self>> = Some(unsafe { PlainLayout::new_unchecked($size, $size) });

            #[inline(always)]
            fn encoded_end(&self, start: usize) -> usize {
                align_up(start, $size) + $size
            }

            #[inline(always)]
            fn encode<B: ByteOrder>(&self, w: &mut Writer<'_, B>) -> Result<(), EncodeError> {
                w.write_primitive(if B::LITTLE { self.to_le_bytes() } else { self.to_be_bytes() })
            }
        }

        impl<'de> CdrDecode<'de> for $ty {
            const MIN_WIRE_SIZE: usize = $size;

            const PLAIN: Option<PlainLayout<Self>> = <$ty as CdrEncode>::PLAIN;

            #[inline(always)]
            fn decode<B: ByteOrder>(r: &mut Reader<'de, B>) -> Result<Self, DecodeError> {
                let bytes = r.read_primitive::<$size>()?;
                Ok(if B::LITTLE { <$ty>::from_le_bytes(bytes) } else { <$ty>::from_be_bytes(bytes) })
            }

            #[inline]
            fn decode_array<B: ByteOrder, const N: usize>(r: &mut Reader<'de, B>) -> Result<[Self; N], DecodeError> {
                let mut out = [<$ty>::default(); N];
                if N > 0 {
                    let bytes = r.read_aligned_bytes($size, std::mem::size_of_val(&out))?;
                    copy_from_wire::<B, $ty>(&mut out, bytes);
                }
                Ok(out)
            }

            $(
            #[inline]
            fn decode_cow_slice<B: ByteOrder>(r: &mut Reader<'de, B>, n: usize) -> Result<Cow<'de, [Self]>, DecodeError> {
                // Bytes need no alignment or swapping: lend them from the input.
                let _ = stringify!($borrow);
                r.read_bytes(n).map(Cow::Borrowed)
            }
            )?
        }

        impl RosType for $ty {
            const FIELD_TYPE: FieldType = FieldType::scalar(TypeId::$type_id);
        }
        impl RosElement for $ty {}
    )*};
}

/// Bulk read of numbers: one copy in host order, or a swap per element.
#[inline(always)]
fn copy_from_wire<B: ByteOrder, T: bytemuck::Pod + SwapBytes>(out: &mut [T], bytes: &[u8]) {
    let dst: &mut [u8] = bytemuck::cast_slice_mut(out);
    dst.copy_from_slice(bytes);
    if !B::NATIVE {
        for v in out.iter_mut() {
            *v = v.swap();
        }
    }
}

/// Byte swapping for every number type, floats included.
trait SwapBytes: Sized {
    fn swap(self) -> Self;
}

macro_rules! swap_int {
    ($($ty:ty),*) => {$(
        impl SwapBytes for $ty {
            #[inline(always)]
            fn swap(self) -> Self { self.swap_bytes() }
        }
    )*};
}
swap_int!(u8, i8, u16, i16, u32, i32, u64, i64);

macro_rules! float_swap {
    ($($ty:ty),*) => {$(
        impl SwapBytes for $ty {
            #[inline(always)]
            fn swap(self) -> Self { <$ty>::from_bits(self.to_bits().swap_bytes()) }
        }
    )*};
}

float_swap!(f32, f64);

number! {
    u8 => 1, Uint8, borrow;
    i8 => 1, Int8;
    u16 => 2, Uint16;
    i16 => 2, Int16;
    u32 => 4, Uint32;
    i32 => 4, Int32;
    u64 => 8, Uint64;
    i64 => 8, Int64;
    f32 => 4, Float32;
    f64 => 8, Float64;
}

/// `&[u8]` and `Cow<[u8]>` fields borrow the bytes straight from the input.
impl<'de: 'a, 'a> CdrDecode<'de> for &'a [u8] {
    const MIN_WIRE_SIZE: usize = 4;

    #[inline]
    fn decode<B: ByteOrder>(r: &mut Reader<'de, B>) -> Result<Self, DecodeError> {
        let n = r.read_count(1)?;
        r.read_bytes(n)
    }
}

impl RosType for &[u8] {
    const FIELD_TYPE: FieldType = FieldType::scalar(TypeId::Uint8).unbounded_sequence();
}

impl CdrEncode for bool {
    const FIXED_LAYOUT: Option<FixedLayout> = Some(FixedLayout::primitive(1));

    #[inline(always)]
    fn encoded_end(&self, start: usize) -> usize {
        start + 1
    }

    #[inline(always)]
    fn encode<B: ByteOrder>(&self, w: &mut Writer<'_, B>) -> Result<(), EncodeError> {
        w.write_primitive([u8::from(*self)])
    }

    #[inline]
    fn encode_slice<B: ByteOrder>(
        items: &[Self],
        w: &mut Writer<'_, B>,
    ) -> Result<(), EncodeError> {
        let slot = w.aligned_slot(1, items.len())?;
        for (dst, v) in slot.iter_mut().zip(items) {
            *dst = u8::from(*v);
        }
        Ok(())
    }
}

impl<'de> CdrDecode<'de> for bool {
    const MIN_WIRE_SIZE: usize = 1;

    #[inline(always)]
    fn decode<B: ByteOrder>(r: &mut Reader<'de, B>) -> Result<Self, DecodeError> {
        let at = r.position();
        match r.read_primitive::<1>()? {
            [0] => Ok(false),
            [1] => Ok(true),
            [b] => Err(r.error_at(at, DecodeErrorKind::InvalidBool(b))),
        }
    }

    #[inline]
    fn decode_array<B: ByteOrder, const N: usize>(
        r: &mut Reader<'de, B>,
    ) -> Result<[Self; N], DecodeError> {
        let mut out = [false; N];
        for v in &mut out {
            *v = Self::decode(r)?;
        }
        Ok(out)
    }
}

impl RosType for bool {
    const FIELD_TYPE: FieldType = FieldType::scalar(TypeId::Boolean);
}
impl RosElement for bool {}

/// Numbers in place: one is a zeroed `&mut` into the buffer, a run is an
/// [`Uninit`] slice, an array a zeroed `&mut [T; N]`.
macro_rules! number_in_place {
    ($($ty:ty => $size:literal;)*) => {$(
        impl InPlace for $ty {
            type Lens = ();
            type Mut<'a> = &'a mut $ty;

            fn lens(&self) {}

            fn end_in_place((): &(), start: usize) -> Option<usize> {
                align_up(start, $size).checked_add($size)
            }

            fn carve<'a>((): &(), c: &mut Carver<'a>) -> Result<&'a mut $ty, LoanError> {
                loan::carve_plain_one(c, $size)
            }

            fn write_in_place(&self, place: &mut $ty) -> Result<(), LoanError> {
                *place = *self;
                Ok(())
            }
        }

        impl InPlaceElement for $ty {
            type RunLens = usize;
            type RunMut<'a> = Uninit<'a, $ty>;
            type ArrayLens = ();
            type ArrayMut<'a, const N: usize> = &'a mut [$ty; N];

            fn run_lens(items: &[Self]) -> usize {
                items.len()
            }

            fn run_count(lens: &usize) -> usize {
                *lens
            }

            fn run_end(_: &usize, n: usize, start: usize) -> Option<usize> {
                loan::plain_run_end::<$ty>(n, start)
            }

            fn carve_run<'a>(_: &usize, n: usize, c: &mut Carver<'a>) -> Result<Uninit<'a, $ty>, LoanError> {
                // A number is always at a phase where memory and wire agree.
                loan::carve_plain_run(n, c).unwrap_or(Err(LoanError::TooLarge))
            }

            fn write_run(items: &[Self], place: Uninit<'_, $ty>) -> Result<(), LoanError> {
                place.write_slice(items).map(drop)
            }

            fn array_lens<const N: usize>(_: &[Self; N]) {}

            fn array_end<const N: usize>((): &(), start: usize) -> Option<usize> {
                loan::plain_run_end::<$ty>(N, start)
            }

            fn carve_array<'a, const N: usize>((): &(), c: &mut Carver<'a>) -> Result<&'a mut [$ty; N], LoanError> {
                loan::carve_plain_array(c, $size)
            }

            fn write_array<const N: usize>(items: &[Self; N], place: &mut [$ty; N]) -> Result<(), LoanError> {
                *place = *items;
                Ok(())
            }
        }
    )*};
}

number_in_place! {
    u8 => 1;
    i8 => 1;
    u16 => 2;
    i16 => 2;
    u32 => 4;
    i32 => 4;
    u64 => 8;
    i64 => 8;
    f32 => 4;
    f64 => 8;
}

impl InPlace for bool {
    type Lens = ();
    type Mut<'a> = &'a mut LoanBool;

    fn lens(&self) {}

    fn end_in_place((): &(), start: usize) -> Option<usize> {
        start.checked_add(1)
    }

    fn carve<'a>((): &(), c: &mut Carver<'a>) -> Result<&'a mut LoanBool, LoanError> {
        match zeroed_bools(c.take(1, 1)?) {
            [one] => Ok(one),
            _ => Err(LoanError::TooLarge),
        }
    }

    fn write_in_place(&self, place: &mut LoanBool) -> Result<(), LoanError> {
        place.set(*self);
        Ok(())
    }
}

/// `bool`s are not plain (only 0 and 1 are valid), so runs of them are zeroed
/// (`false`) rather than left unwritten, and handed out as [`LoanBool`]s: a
/// loaned buffer may lie in shared memory, where another process could write
/// a byte that is no `bool`.
impl InPlaceElement for bool {
    type RunLens = usize;
    type RunMut<'a> = &'a mut [LoanBool];
    type ArrayLens = ();
    type ArrayMut<'a, const N: usize> = &'a mut [LoanBool; N];

    fn run_lens(items: &[Self]) -> usize {
        items.len()
    }

    fn run_count(lens: &usize) -> usize {
        *lens
    }

    fn run_end(_: &usize, n: usize, start: usize) -> Option<usize> {
        start.checked_add(n)
    }

    fn carve_run<'a>(
        _: &usize,
        n: usize,
        c: &mut Carver<'a>,
    ) -> Result<&'a mut [LoanBool], LoanError> {
        Ok(zeroed_bools(c.take(1, n)?))
    }

    fn write_run(items: &[Self], place: &mut [LoanBool]) -> Result<(), LoanError> {
        if items.len() != place.len() {
            return Err(LoanError::LengthMismatch {
                field: "",
                at: 0,
                expected: place.len(),
                got: items.len(),
            });
        }
        for (slot, &value) in place.iter_mut().zip(items) {
            slot.set(value);
        }
        Ok(())
    }

    fn array_lens<const N: usize>(_: &[Self; N]) {}

    fn array_end<const N: usize>((): &(), start: usize) -> Option<usize> {
        start.checked_add(N)
    }

    fn carve_array<'a, const N: usize>(
        (): &(),
        c: &mut Carver<'a>,
    ) -> Result<&'a mut [LoanBool; N], LoanError> {
        <&mut [LoanBool; N]>::try_from(zeroed_bools(c.take(1, N)?)).map_err(|_| LoanError::TooLarge)
    }

    fn write_array<const N: usize>(
        items: &[Self; N],
        place: &mut [LoanBool; N],
    ) -> Result<(), LoanError> {
        for (slot, &value) in place.iter_mut().zip(items) {
            slot.set(value);
        }
        Ok(())
    }
}
