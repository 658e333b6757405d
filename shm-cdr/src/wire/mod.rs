//! [`CdrEncode`](crate::CdrEncode) / [`CdrDecode`](crate::CdrDecode) /
//! [`RosType`](crate::RosType) for every supported field type, one module per
//! wire kind.

/// `InPlace` and `InPlaceElement` for a string type (`string`, `wstring` and
/// their bounded and borrowed forms): one slot of the stated length; runs and
/// arrays of them one slot each, with lengths `Vec<usize>` (for an array, empty
/// means `N` empty strings). `$len` gives a value's length, `$end` the end of one
/// of a given length, `$carve` lays one out, `$min` is the fewest bytes one takes.
macro_rules! text_in_place {
    ([$($g:tt)*] $ty:ty, slot: $slot:ident, len: $len:expr, end: $end:path, carve: $carve:path, min: $min:expr, bound: $bound:expr) => {
        impl<$($g)*> InPlace for $ty {
            type Lens = usize;
            type Mut<'a> = $slot<'a>;

            fn lens(&self) -> usize {
                $len(self)
            }

            fn end_in_place(lens: &usize, start: usize) -> Option<usize> {
                $end(*lens, start)
            }

            fn carve<'a>(lens: &usize, c: &mut Carver<'a>) -> Result<$slot<'a>, LoanError> {
                $carve(*lens, $bound, c)
            }

            fn write_in_place(&self, place: $slot<'_>) -> Result<(), LoanError> {
                place.write(self)
            }
        }

        impl<$($g)*> InPlaceElement for $ty {
            type RunLens = Vec<usize>;
            type RunMut<'a> = Vec<$slot<'a>>;
            type ArrayLens = Vec<usize>;
            type ArrayMut<'a, const M: usize> = Vec<$slot<'a>>;

            fn run_lens(items: &[Self]) -> Vec<usize> {
                items.iter().map($len).collect()
            }

            fn run_count(lens: &Vec<usize>) -> usize {
                lens.len()
            }

            fn run_end(lens: &Vec<usize>, n: usize, start: usize) -> Option<usize> {
                (0..n).try_fold(start, |pos, i| $end(lens.get(i).copied().unwrap_or(0), pos))
            }

            fn carve_run<'a>(lens: &Vec<usize>, n: usize, c: &mut Carver<'a>) -> Result<Vec<$slot<'a>>, LoanError> {
                if !lens.is_empty() && lens.len() != n {
                    return Err(LoanError::ArrayLength { len: lens.len(), expected: n });
                }
                // Each takes at least `$min` bytes of the buffer: bound the allocation.
                let mut slots = Vec::with_capacity(n.min(c.remaining() / $min));
                for i in 0..n {
                    slots.push($carve(lens.get(i).copied().unwrap_or(0), $bound, c)?);
                }
                Ok(slots)
            }

            fn write_run(items: &[Self], place: Vec<$slot<'_>>) -> Result<(), LoanError> {
                if items.len() != place.len() {
                    return Err(LoanError::ArrayLength { len: items.len(), expected: place.len() });
                }
                items.iter().zip(place).try_for_each(|(s, place)| place.write(s))
            }

            fn array_lens<const M: usize>(items: &[Self; M]) -> Vec<usize> {
                Self::run_lens(items)
            }

            fn array_end<const M: usize>(lens: &Vec<usize>, start: usize) -> Option<usize> {
                Self::run_end(lens, M, start)
            }

            fn carve_array<'a, const M: usize>(lens: &Vec<usize>, c: &mut Carver<'a>) -> Result<Vec<$slot<'a>>, LoanError> {
                Self::carve_run(lens, M, c)
            }

            fn write_array<const M: usize>(items: &[Self; M], place: Vec<$slot<'_>>) -> Result<(), LoanError> {
                Self::write_run(items, place)
            }
        }
    };
}

mod array;
#[cfg(feature = "bytes")]
mod bytes;
mod primitive;
mod sequence;
pub(crate) mod string;
pub(crate) mod wstring;
