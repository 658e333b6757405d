//! Random values of the wrapper types for property tests (`proptest` feature) and
//! fuzzing (`arbitrary` feature), always within their bounds.

use crate::bounded::{BoundedString, BoundedVec, BoundedWString, WString};

/// The longest prefix of `s` that is at most `max` bytes, cut at a char boundary.
fn truncate_bytes(mut s: String, max: usize) -> String {
    let mut end = max.min(s.len());
    while !s.is_char_boundary(end) {
        end -= 1;
    }
    s.truncate(end);
    s
}

/// The longest prefix of `s` that is at most `max` UTF-16 code units.
fn truncate_utf16(s: String, max: usize) -> String {
    let mut units = 0;
    s.chars()
        .take_while(|c| {
            units += c.len_utf16();
            units <= max
        })
        .collect()
}

#[cfg(feature = "proptest")]
mod proptest_impls {
    use super::*;
    use proptest::prelude::*;

    impl<const N: usize> Arbitrary for BoundedString<N> {
        type Parameters = ();
        type Strategy = BoxedStrategy<Self>;
        fn arbitrary_with((): ()) -> Self::Strategy {
            any::<String>()
                .prop_map(|s| Self(truncate_bytes(s, N)))
                .boxed()
        }
    }

    impl<const N: usize> Arbitrary for BoundedWString<N> {
        type Parameters = ();
        type Strategy = BoxedStrategy<Self>;
        fn arbitrary_with((): ()) -> Self::Strategy {
            any::<String>()
                .prop_map(|s| Self(truncate_utf16(s, N)))
                .boxed()
        }
    }

    impl Arbitrary for WString {
        type Parameters = ();
        type Strategy = BoxedStrategy<Self>;
        fn arbitrary_with((): ()) -> Self::Strategy {
            any::<String>().prop_map(Self).boxed()
        }
    }

    impl<T: Arbitrary + 'static, const N: usize> Arbitrary for BoundedVec<T, N> {
        type Parameters = ();
        type Strategy = BoxedStrategy<Self>;
        fn arbitrary_with((): ()) -> Self::Strategy {
            proptest::collection::vec(any::<T>(), 0..=N)
                .prop_map(Self)
                .boxed()
        }
    }
}

#[cfg(feature = "arbitrary")]
mod arbitrary_impls {
    use super::*;
    use arbitrary::{Arbitrary, Result, Unstructured};

    impl<'a, const N: usize> Arbitrary<'a> for BoundedString<N> {
        fn arbitrary(u: &mut Unstructured<'a>) -> Result<Self> {
            Ok(Self(truncate_bytes(String::arbitrary(u)?, N)))
        }
    }

    impl<'a, const N: usize> Arbitrary<'a> for BoundedWString<N> {
        fn arbitrary(u: &mut Unstructured<'a>) -> Result<Self> {
            Ok(Self(truncate_utf16(String::arbitrary(u)?, N)))
        }
    }

    impl<'a> Arbitrary<'a> for WString {
        fn arbitrary(u: &mut Unstructured<'a>) -> Result<Self> {
            String::arbitrary(u).map(Self)
        }
    }

    impl<'a, T: Arbitrary<'a>, const N: usize> Arbitrary<'a> for BoundedVec<T, N> {
        fn arbitrary(u: &mut Unstructured<'a>) -> Result<Self> {
            let len = u.int_in_range(0..=N)?;
            (0..len)
                .map(|_| T::arbitrary(u))
                .collect::<Result<Vec<T>>>()
                .map(Self)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn truncation_respects_boundaries() {
        assert_eq!(truncate_bytes("héllo".into(), 2), "h");
        assert_eq!(truncate_bytes("héllo".into(), 3), "hé");
        assert_eq!(truncate_utf16("a𝄞b".into(), 2), "a");
        assert_eq!(truncate_utf16("a𝄞b".into(), 3), "a𝄞");
    }
}
