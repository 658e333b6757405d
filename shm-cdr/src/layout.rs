//! Compile-time layout facts used to size values exactly in O(1).
//!
//! CDR aligns every primitive to its size relative to the start of the stream, so
//! the size of a value can depend on where it starts. All alignments divide 8, so
//! it depends only on the start position modulo 8: a type whose encoding never
//! depends on its value is described by the 8 end positions for the 8 possible
//! start phases.

use std::mem::MaybeUninit;

/// Round `pos` up to a multiple of `align` (a power of two).
#[inline(always)]
pub const fn align_up(pos: usize, align: usize) -> usize {
    (pos + (align - 1)) & !(align - 1)
}

/// The layout of a type whose encoded size does not depend on its value (only on
/// the start position modulo 8): numbers, `bool`, fixed arrays of them and structs
/// made only of those.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FixedLayout {
    /// `ends[p]` is the position after the value when it starts at position `p`.
    ends: [usize; 8],
    /// `steady[p]`: when a run of values starts at phase `p`, every value after the
    /// first takes exactly this many bytes (0 if the sizes keep varying). Computed at
    /// compile time so that sizing a sequence is one multiplication.
    steady: [usize; 8],
}

impl FixedLayout {
    const fn from_ends(ends: [usize; 8]) -> Self {
        let mut layout = Self {
            ends,
            steady: [0; 8],
        };
        let mut p = 0;
        while p < 8 {
            // After the first value the run is at phase `q`; it is steady if every
            // phase reachable by whole strides yields the same size.
            let q = layout.end(p) % 8;
            let stride = layout.size_at(q);
            let mut r = q;
            let mut uniform = true;
            let mut k = 0;
            while k < 8 {
                if layout.size_at(r) != stride {
                    uniform = false;
                }
                r = (r + stride) % 8;
                k += 1;
            }
            if uniform {
                layout.steady[p] = stride;
            }
            p += 1;
        }
        layout
    }

    /// The layout of a primitive of `size` bytes (aligned to its size).
    pub const fn primitive(size: usize) -> Self {
        let mut ends = [0; 8];
        let mut p = 0;
        while p < 8 {
            ends[p] = align_up(p, size) + size;
            p += 1;
        }
        Self::from_ends(ends)
    }

    /// The end position of a value that starts at `start`.
    #[inline(always)]
    pub const fn end(&self, start: usize) -> usize {
        let phase = start % 8;
        (start - phase).saturating_add(self.ends[phase])
    }

    /// The encoded size of a value that starts at `start` (padding included).
    pub const fn size_at(&self, start: usize) -> usize {
        self.end(start) - start
    }

    /// The layout of this value followed directly by a value of layout `next` (the
    /// next field of a struct).
    pub const fn then(self, next: Self) -> Self {
        let mut ends = [0; 8];
        let mut p = 0;
        while p < 8 {
            ends[p] = next.end(self.ends[p]);
            p += 1;
        }
        Self::from_ends(ends)
    }

    /// The layout of `n` consecutive values of this layout (a fixed array).
    pub const fn repeat(self, n: usize) -> Self {
        let mut ends = [0; 8];
        let mut p = 0;
        while p < 8 {
            ends[p] = self.repeat_end(p, n);
            p += 1;
        }
        Self::from_ends(ends)
    }

    /// The end position of `n` consecutive values starting at `start`, in O(1).
    ///
    /// The start phase of each element is a function of the previous one on 8
    /// states, so after at most 8 elements the phases cycle with a period of at
    /// most 8; whole cycles are skipped arithmetically. Saturates instead of
    /// overflowing (a length that large cannot be encoded anyway).
    pub const fn repeat_end(&self, start: usize, n: usize) -> usize {
        if n == 0 {
            return start;
        }
        let steady = self.steady[start % 8];
        if steady != 0 {
            return self
                .end(start)
                .saturating_add((n - 1).saturating_mul(steady));
        }
        let mut pos = start;
        let mut done = 0;
        while done < n && done < 8 {
            pos = self.end(pos);
            done += 1;
        }
        if done == n {
            return pos;
        }
        // `pos` is on the cycle now: measure its length and stride.
        let mut cycle_len = 0;
        let mut p = pos;
        loop {
            p = self.end(p);
            cycle_len += 1;
            if p % 8 == pos % 8 {
                break;
            }
        }
        let stride = p - pos;
        let left = n - done;
        pos = pos.saturating_add((left / cycle_len).saturating_mul(stride));
        let mut i = 0;
        while i < left % cycle_len {
            pos = self.end(pos);
            i += 1;
        }
        pos
    }

    /// The smallest number of bytes a value of this layout takes, over all phases.
    pub const fn min_size(&self) -> usize {
        let mut min = usize::MAX;
        let mut p = 0;
        while p < 8 {
            let size = self.ends[p] - p;
            if size < min {
                min = size;
            }
            p += 1;
        }
        min
    }

    /// Combine the layouts of a struct's fields, in order. `None` if any field has a
    /// value-dependent size. An empty list describes a struct with no fields, which
    /// CDR encodes as one `u8`.
    pub const fn of_struct(fields: &[Option<FixedLayout>]) -> Option<FixedLayout> {
        if fields.is_empty() {
            return Some(Self::primitive(1));
        }
        let mut acc = Self::from_ends([0, 1, 2, 3, 4, 5, 6, 7]);
        let mut i = 0;
        while i < fields.len() {
            match fields[i] {
                Some(next) => acc = acc.then(next),
                None => return None,
            }
            i += 1;
        }
        Some(acc)
    }

    /// The layout of a fixed array of `n` elements of `element`'s layout.
    pub const fn of_array(element: Option<FixedLayout>, n: usize) -> Option<FixedLayout> {
        match element {
            Some(layout) => Some(layout.repeat(n)),
            None => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn naive_repeat_end(l: &FixedLayout, start: usize, n: usize) -> usize {
        (0..n).fold(start, |pos, _| l.end(pos))
    }

    #[test]
    // Arithmetic only, no unsafe code: Miri would spend a minute on it for
    // nothing. It runs in the ordinary test suite.
    #[cfg_attr(miri, ignore)]
    fn repeat_end_matches_element_by_element_walk() {
        // {u8, f64}, {u32, f64}, {f64, u8}, {u16, u8}, {u8}: every phase, many counts.
        let p = FixedLayout::primitive;
        let shapes = [
            p(1).then(p(8)),
            p(4).then(p(8)),
            p(8).then(p(1)),
            p(2).then(p(1)),
            p(1),
            p(4).then(p(2)).then(p(1)).then(p(8)).then(p(1)),
        ];
        for l in &shapes {
            for start in 0..24 {
                for n in 0..100 {
                    assert_eq!(l.repeat_end(start, n), naive_repeat_end(l, start, n));
                }
            }
        }
    }

    #[test]
    fn struct_with_u8_then_f64_depends_on_phase() {
        let l = FixedLayout::of_struct(&[
            Some(FixedLayout::primitive(1)),
            Some(FixedLayout::primitive(8)),
        ])
        .unwrap();
        assert_eq!(l.size_at(0), 16);
        assert_eq!(l.size_at(1), 15);
        assert_eq!(l.size_at(7), 9);
        assert_eq!(l.min_size(), 9);
    }
}

/// `to_vec` writes into uninitialized capacity through the views above: these
/// run under Miri (see `.ci/run`), which reports any read of a byte the writer
/// left uninitialized.
#[cfg(all(test, feature = "test_msgs"))]
mod uninit_tests {
    use crate::msgs::test_msgs::msg::{BasicTypes, Strings, UnboundedSequences, WStrings};
    use crate::{encode_into_with, to_vec_with, CdrEncode, Endianness, WString};

    /// `to_vec` (fresh memory) against `encode_into` over a buffer full of 0xA5
    /// and one full of 0x00, in both byte orders: the same bytes, every one.
    fn same_as_encode_into<T: CdrEncode>(msg: &T) {
        for order in [Endianness::Little, Endianness::Big] {
            let fresh = to_vec_with(msg, order).unwrap();
            for fill in [0xA5u8, 0x00] {
                let mut buf = vec![fill; fresh.len()];
                let n = encode_into_with(msg, &mut buf, order).unwrap();
                assert_eq!(n, fresh.len());
                assert_eq!(buf, fresh, "{order:?}, buffer of {fill:#x}");
            }
        }
    }

    #[test]
    fn to_vec_writes_every_byte_padding_included() {
        let mut seqs = UnboundedSequences {
            bool_values: vec![true, false, true],
            byte_values: vec![1, 2, 3],
            float64_values: vec![1.5, -2.25],
            int16_values: vec![-7],
            uint64_values: vec![u64::MAX],
            string_values: vec!["a".into(), "".into(), "four".into()],
            basic_types_values: vec![BasicTypes {
                bool_value: true,
                int64_value: -3,
                float32_value: 0.5,
                ..BasicTypes::default()
            }],
            ..UnboundedSequences::default()
        };
        same_as_encode_into(&seqs);
        // A bulk run (plain numbers) behind an odd phase.
        seqs.byte_values = vec![9; 13];
        seqs.float64_values = (0..9).map(f64::from).collect();
        same_as_encode_into(&seqs);
        same_as_encode_into(&UnboundedSequences::default());
        same_as_encode_into(&Strings {
            string_value: "seven".into(),
            ..Strings::default()
        });
        same_as_encode_into(&WStrings {
            wstring_value: WString::from("wide"),
            ..WStrings::default()
        });
    }
}

/// Proof that a `T` in memory is byte for byte its CDR encoding in host byte order,
/// whenever the value starts at a stream position that is a multiple of
/// [`align`](Self::align). Lets sequences and arrays of `T` be copied in bulk.
///
/// # Invariant
/// A `PlainLayout<T>` exists only if:
/// - `T` has no padding and no uninitialized bytes;
/// - every bit pattern is a valid `T` (no `bool`, no references, no enums);
/// - `size_of::<T>()` is a multiple of `align`, and equals the CDR size of a `T`
///   starting at a multiple of `align`;
/// - at such a start, every primitive inside `T` is at the same offset in memory as
///   on the wire.
///
/// It is typed by `T` so that one type's proof cannot be reused for another; it can
/// be created only through the `unsafe` constructors below, and the derive creates it
/// only after checking the above with `offset_of!` and `size_of` at compile time.
pub struct PlainLayout<T: ?Sized> {
    align: usize,
    first_align: usize,
    ty: std::marker::PhantomData<fn() -> *const T>,
}

impl<T: ?Sized> Clone for PlainLayout<T> {
    fn clone(&self) -> Self {
        *self
    }
}
impl<T: ?Sized> Copy for PlainLayout<T> {}

impl<T: ?Sized> std::fmt::Debug for PlainLayout<T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("PlainLayout")
            .field("align", &self.align)
            .field("first_align", &self.first_align)
            .finish()
    }
}

/// One field of a struct, for [`PlainLayout::of_struct`].
#[derive(Debug)]
pub struct PlainField {
    /// `offset_of!` the field.
    pub offset: usize,
    /// `size_of` the field's type.
    pub size: usize,
    /// The field type's proof, erased to its numbers.
    pub plain: Option<(usize, usize)>,
}

impl<T: ?Sized> PlainLayout<T> {
    /// # Safety
    /// `T` must satisfy the type's invariant for `align`, where `first_align` is the
    /// alignment of its first primitive.
    #[allow(unsafe_code)]
    pub const unsafe fn new_unchecked(align: usize, first_align: usize) -> Self {
        Self {
            align,
            first_align,
            ty: std::marker::PhantomData,
        }
    }

    /// The largest CDR alignment of any primitive inside `T`.
    pub const fn align(&self) -> usize {
        self.align
    }

    /// The CDR alignment of the first primitive of `T` (where a sequence element
    /// starts).
    pub const fn first_align(&self) -> usize {
        self.first_align
    }

    /// Whether a run of `T` whose first element is written at stream position
    /// `pos` is, from its first aligned byte on, exactly the memory image of the
    /// run: the element starts at a multiple of its largest alignment, so every
    /// field's CDR alignment matches its offset in memory.
    #[inline(always)]
    pub const fn bulk_at(&self, pos: usize) -> bool {
        align_up(pos, self.first_align).is_multiple_of(self.align)
    }

    /// The numbers of this proof, to pass to [`PlainLayout::of_struct`].
    pub const fn erase(this: Option<Self>) -> Option<(usize, usize)> {
        match this {
            Some(p) => Some((p.align, p.first_align)),
            None => None,
        }
    }

    /// The proof for a struct, if its fields are all plain, packed with no padding
    /// in CDR order at the offsets CDR gives them, and its size is a multiple of its
    /// alignment. `None` otherwise (the struct is then encoded field by field).
    ///
    /// # Safety
    /// `fields` must list every field of `T` in declaration order, with `offset_of!`
    /// and `size_of` taken from `T` itself, and each `plain` taken from that field
    /// type's own `PlainLayout`; `size` must be `size_of::<T>()`.
    #[allow(unsafe_code)]
    pub const unsafe fn of_struct(fields: &[PlainField], size: usize) -> Option<Self> {
        if fields.is_empty() {
            // An empty struct is one byte on the wire but none in memory.
            return None;
        }
        let mut pos = 0;
        let mut align = 1;
        let mut first_align = 1;
        let mut i = 0;
        while i < fields.len() {
            let field = &fields[i];
            let Some((field_align, field_first)) = field.plain else {
                return None;
            };
            // Packed (no gap, so no padding byte), at its declared offset, and at a
            // phase where the field's own proof holds.
            if field.offset != pos || pos % field_align != 0 || align_up(pos, field_first) != pos {
                return None;
            }
            if i == 0 {
                first_align = field_first;
            }
            if field_align > align {
                align = field_align;
            }
            pos += field.size;
            i += 1;
        }
        if pos != size || !size.is_multiple_of(align) {
            return None;
        }
        // SAFETY: every field is plain (its own proof), they tile `0..size` with no
        // gap in declaration order at CDR's offsets for a start that is a multiple of
        // `align` (each field's offset is a multiple of its own `align`, which divides
        // ours), and `size` is a multiple of `align`; the caller vouches that the
        // fields are all of `T`'s fields with their real offsets and sizes.
        Some(unsafe { Self::new_unchecked(align, first_align) })
    }
}

/// `bytes` as possibly uninitialized bytes, for a writer that may also be given
/// fresh memory (`to_vec` writes into a `Vec`'s spare capacity).
///
/// # Safety
/// Nothing uninitialized may be stored through the result (no
/// `MaybeUninit::uninit()`, no copy from uninitialized memory): `bytes` must
/// still be entirely initialized when the borrow ends.
#[allow(unsafe_code)]
pub(crate) unsafe fn uninit_view(bytes: &mut [u8]) -> &mut [MaybeUninit<u8>] {
    // SAFETY: `MaybeUninit<u8>` has the size, alignment and layout of `u8`, so the
    // cast keeps the length and every element in place; the unique borrow passes
    // to the result; the caller stores only initialized bytes, so `bytes` is valid
    // `[u8]` again when the borrow ends.
    unsafe { &mut *(bytes as *mut [u8] as *mut [MaybeUninit<u8>]) }
}

/// Initialized bytes as `MaybeUninit` ones, to copy from.
#[allow(unsafe_code)]
pub(crate) fn as_uninit(bytes: &[u8]) -> &[MaybeUninit<u8>] {
    // SAFETY: same layout as above; through a shared borrow nothing can be stored,
    // so viewing initialized bytes as `MaybeUninit` cannot de-initialize them.
    unsafe { &*(bytes as *const [u8] as *const [MaybeUninit<u8>]) }
}

/// Copy `src` into `slot` (same length), returning the slot as initialized bytes.
#[allow(unsafe_code)]
pub(crate) fn write_bytes_into<'a>(slot: &'a mut [MaybeUninit<u8>], src: &[u8]) -> &'a mut [u8] {
    slot.copy_from_slice(as_uninit(src));
    // SAFETY: `copy_from_slice` (which panics on a length mismatch before writing)
    // initialized every byte of `slot` from initialized bytes; the unique borrow
    // passes to the result.
    unsafe { &mut *(slot as *mut [MaybeUninit<u8>] as *mut [u8]) }
}

/// Zero `slot`, returning it as initialized bytes.
#[allow(unsafe_code)]
pub(crate) fn zeroed_bytes(slot: &mut [MaybeUninit<u8>]) -> &mut [u8] {
    slot.fill(MaybeUninit::new(0));
    // SAFETY: every byte of `slot` was just set to 0; same layout as above; the
    // unique borrow passes to the result.
    unsafe { &mut *(slot as *mut [MaybeUninit<u8>] as *mut [u8]) }
}

/// The bytes of `items`, which are their CDR encoding (see [`PlainLayout`]).
#[allow(unsafe_code)]
pub(crate) fn plain_bytes<T>(_proof: PlainLayout<T>, items: &[T]) -> &[u8] {
    // SAFETY: the proof guarantees `T` has no padding or uninitialized bytes, so all
    // `size_of_val(items)` bytes behind the valid slice pointer are initialized; `u8`
    // needs no alignment; the returned borrow keeps `items` borrowed immutably.
    unsafe { std::slice::from_raw_parts(items.as_ptr().cast::<u8>(), std::mem::size_of_val(items)) }
}

/// Append `n` values of `T` read from their CDR bytes (see [`PlainLayout`]) to
/// `out`. `None` (and `out` unchanged) if `bytes` is not exactly `n` values long.
#[allow(unsafe_code)]
pub(crate) fn plain_extend<T>(
    _proof: PlainLayout<T>,
    out: &mut Vec<T>,
    bytes: &[u8],
    n: usize,
) -> Option<()> {
    if Some(bytes.len()) != n.checked_mul(std::mem::size_of::<T>()) {
        return None;
    }
    out.reserve(n);
    let len = out.len();
    // SAFETY: after `reserve`, `out` owns room for at least `len + n` values, and the
    // `n` slots after the first `len` are spare capacity that cannot overlap `bytes`
    // (a borrowed slice `out` does not own). Exactly `n * size_of::<T>()` bytes are
    // copied into them, and the proof guarantees every bit pattern is a valid `T`,
    // so the first `len + n` elements are initialized before `set_len`. Byte copies
    // need no alignment of the source.
    unsafe {
        std::ptr::copy_nonoverlapping(
            bytes.as_ptr(),
            out.as_mut_ptr().add(len).cast::<u8>(),
            bytes.len(),
        );
        out.set_len(len + n);
    }
    Some(())
}

/// `bytes` as the `T`s whose CDR encoding they are (see [`PlainLayout`]), borrowed
/// in place. `None` if `bytes` is not a whole number of `T`s or is not aligned for
/// `T` in memory (then the caller copies).
#[allow(unsafe_code)]
pub(crate) fn plain_slice<T>(_proof: PlainLayout<T>, bytes: &[u8]) -> Option<&[T]> {
    if bytes.is_empty() {
        // No element to align (an empty sequence has no padding before it).
        return Some(&[]);
    }
    let size = std::mem::size_of::<T>();
    if size == 0
        || !bytes.len().is_multiple_of(size)
        || !(bytes.as_ptr() as usize).is_multiple_of(std::mem::align_of::<T>())
    {
        return None;
    }
    // SAFETY: the pointer is aligned for `T` (checked) and non-null (from a slice);
    // the `bytes.len() / size` values span exactly `bytes`, which are initialized
    // and borrowed immutably for the returned lifetime; the proof guarantees every
    // bit pattern is a valid `T` with no padding, so any initialized bytes are
    // valid `T`s.
    Some(unsafe { std::slice::from_raw_parts(bytes.as_ptr().cast::<T>(), bytes.len() / size) })
}

/// [`plain_slice`] for writing: the `T`s lying in `bytes`, mutably.
#[allow(unsafe_code)]
pub(crate) fn plain_slice_mut<T>(_proof: PlainLayout<T>, bytes: &mut [u8]) -> Option<&mut [T]> {
    if bytes.is_empty() {
        return Some(<&mut [T]>::default());
    }
    let size = std::mem::size_of::<T>();
    if size == 0
        || !bytes.len().is_multiple_of(size)
        || !(bytes.as_ptr() as usize).is_multiple_of(std::mem::align_of::<T>())
    {
        return None;
    }
    // SAFETY: as in `plain_slice`; in addition the borrow of `bytes` is unique, so
    // the returned slice is the only access to that memory, and any `T` written
    // through it leaves bytes that are valid `u8`s (no padding, per the proof).
    Some(unsafe {
        std::slice::from_raw_parts_mut(bytes.as_mut_ptr().cast::<T>(), bytes.len() / size)
    })
}

/// `bytes`, zeroed, as [`LoanBool`](crate::loan::LoanBool)s (all `false`).
#[allow(unsafe_code)]
pub(crate) fn zeroed_bools(bytes: &mut [u8]) -> &mut [crate::loan::LoanBool] {
    bytes.fill(0);
    // SAFETY: `LoanBool` is `repr(transparent)` over a `u8`, so it has the size
    // and alignment of `u8` and every byte is a valid one; the unique borrow of
    // `bytes` passes to the result.
    unsafe {
        std::slice::from_raw_parts_mut(
            bytes.as_mut_ptr().cast::<crate::loan::LoanBool>(),
            bytes.len(),
        )
    }
}

/// The bytes of `items`, mutably (see [`PlainLayout`]).
#[allow(unsafe_code)]
pub(crate) fn plain_bytes_mut<T>(_proof: PlainLayout<T>, items: &mut [T]) -> &mut [u8] {
    // SAFETY: as in `plain_bytes`; in addition the borrow of `items` is unique and
    // passes to the result, and the proof guarantees every bit pattern is a valid
    // `T`, so any bytes written through it leave valid `T`s.
    unsafe {
        std::slice::from_raw_parts_mut(
            items.as_mut_ptr().cast::<u8>(),
            std::mem::size_of_val(items),
        )
    }
}
