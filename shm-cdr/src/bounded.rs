//! Field types whose ROS meaning is not expressed by a std type: bounded strings and
//! sequences (the bound is part of the type and of its type hash) and wide strings.
//!
//! The wrappers deref to the std type they hold, so they are used like it; the bound
//! is enforced where the value meets the wire: encoding a value over the bound fails
//! with [`EncodeErrorKind::BoundExceeded`](crate::EncodeErrorKind::BoundExceeded),
//! and decoding one fails with
//! [`DecodeErrorKind::BoundExceeded`](crate::DecodeErrorKind::BoundExceeded).

use std::fmt;
use std::ops::{Deref, DerefMut};

macro_rules! wrapper {
    ($(#[$doc:meta])* $name:ident [$($generics:tt)*] [$($args:tt)*] => $inner:ty) => {
        $(#[$doc])*
        #[derive(Clone, Default, PartialEq, Eq, Hash, PartialOrd, Ord)]
        #[repr(transparent)]
        pub struct $name<$($generics)*>(pub $inner);

        impl<$($generics)*> $name<$($args)*> {
            /// Unwrap the std value.
            pub fn into_inner(self) -> $inner {
                self.0
            }
        }

        impl<$($generics)*> Deref for $name<$($args)*> {
            type Target = $inner;
            fn deref(&self) -> &$inner {
                &self.0
            }
        }

        impl<$($generics)*> DerefMut for $name<$($args)*> {
            fn deref_mut(&mut self) -> &mut $inner {
                &mut self.0
            }
        }

        impl<$($generics)*> From<$inner> for $name<$($args)*> {
            fn from(value: $inner) -> Self {
                Self(value)
            }
        }

        impl<$($generics)*> fmt::Debug for $name<$($args)*> where $inner: fmt::Debug {
            fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                self.0.fmt(f)
            }
        }
    };
}

wrapper! {
    /// A `string<=N>`: at most `N` bytes of UTF-8 (the NUL is not counted).
    BoundedString[const N: usize][N] => String
}

wrapper! {
    /// A `sequence<T, N>` (`T[<=N]` in .msg): at most `N` elements.
    ///
    /// ```
    /// use shm_cdr::{BoundedVec, EncodeErrorKind, RosMessage};
    ///
    /// #[derive(RosMessage, Debug, PartialEq)]
    /// #[ros(type_name = "fleet_msgs/msg/Route")]
    /// struct Route {
    ///     waypoints: BoundedVec<f64, 4>, // float64[<=4] waypoints
    /// }
    ///
    /// let mut route = Route { waypoints: vec![1.0, 2.0].into() };
    /// route.waypoints.push(3.0); // used as the Vec it holds
    /// let bytes = shm_cdr::to_vec(&route)?;
    /// assert_eq!(shm_cdr::from_bytes::<Route>(&bytes)?, route);
    ///
    /// route.waypoints.extend([4.0, 5.0]); // one more than the bound
    /// let err = shm_cdr::to_vec(&route).unwrap_err();
    /// assert!(matches!(err.kind(), EncodeErrorKind::BoundExceeded { len: 5, bound: 4 }));
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    BoundedVec[T, const N: usize][T, N] => Vec<T>
}

wrapper! {
    /// A `wstring`: on the wire, a `u32` count of UTF-16 code units, each widened
    /// to a `u32`, with no terminator (the rosidl_typesupport_fastrtps convention).
    WString[][] => String
}

wrapper! {
    /// A `wstring<=N>`: at most `N` UTF-16 code units.
    BoundedWString[const N: usize][N] => String
}

impl<const N: usize> From<&str> for BoundedString<N> {
    fn from(value: &str) -> Self {
        Self(value.to_owned())
    }
}

impl From<&str> for WString {
    fn from(value: &str) -> Self {
        Self(value.to_owned())
    }
}

impl<const N: usize> From<&str> for BoundedWString<N> {
    fn from(value: &str) -> Self {
        Self(value.to_owned())
    }
}

impl<T, const N: usize> FromIterator<T> for BoundedVec<T, N> {
    fn from_iter<I: IntoIterator<Item = T>>(iter: I) -> Self {
        Self(iter.into_iter().collect())
    }
}

impl<T, const N: usize> BoundedVec<T, N> {
    /// The bound `N`.
    pub const BOUND: usize = N;
}

impl<const N: usize> BoundedString<N> {
    /// The bound `N` in bytes.
    pub const BOUND: usize = N;
}

impl<const N: usize> BoundedWString<N> {
    /// The bound `N` in UTF-16 code units.
    pub const BOUND: usize = N;
}
