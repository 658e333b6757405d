//! The [`RosMessage`] trait: a ROS 2 message type with its names and type hash.

use crate::decode::HEADER_LEN;
use crate::encode::CdrEncode;
use shm_interface::{
    rihs01_of_json, Field, FieldType, FullDescription, TypeDescription, TypeRegistry, TypeSource,
};

/// A ROS 2 message type. Implement it with `#[derive(RosMessage)]`, which also
/// implements [`CdrEncode`], [`CdrDecode`](crate::CdrDecode) and
/// [`RosType`](crate::RosType).
///
/// ```
/// use shm_cdr::RosMessage;
///
/// #[derive(RosMessage)]
/// #[ros(type_name = "geometry_msgs/msg/Vector3")]
/// struct Vector3 {
///     x: f64,
///     y: f64,
///     z: f64,
/// }
///
/// assert_eq!(Vector3::DDS_TYPE_NAME, "geometry_msgs::msg::dds_::Vector3_");
/// assert_eq!(Vector3::ENCODED_SIZE, Some(28)); // fixed: header and three float64
/// // The hash rosidl computes for geometry_msgs/msg/Vector3.
/// assert_eq!(
///     Vector3::type_hash(),
///     "RIHS01_cc12fe83e4c02719f1ce8070bfd14aecd40f75a96696a67a2a1f37f7dbb0765d"
/// );
/// ```
pub trait RosMessage: CdrEncode + RosElement {
    /// The ROS 2 type name, e.g. `"sensor_msgs/msg/PointCloud2"`.
    const TYPE_NAME: &'static str;

    /// The DDS type name, e.g. `"sensor_msgs::msg::dds_::PointCloud2_"` (what
    /// rmw_zenoh_cpp puts in key expressions).
    const DDS_TYPE_NAME: &'static str;

    /// The fields in declaration order, as they enter the type hash.
    const FIELDS: &'static [Field];

    /// The exact encoded size, header included, when it does not depend on the value
    /// (e.g. `geometry_msgs/msg/Pose`: 60 bytes); `None` otherwise.
    const ENCODED_SIZE: Option<usize> = match <Self as CdrEncode>::FIXED_LAYOUT {
        Some(layout) => Some(HEADER_LEN + layout.end(0)),
        None => None,
    };

    /// The REP 2011 type hash, `RIHS01_` and 64 hex digits, equal to rosidl's.
    fn type_hash() -> &'static str;

    /// The `.msg` file the type was generated from, or
    /// [`TypeSource::IMPLICIT`] for a type rosidl derives from a `.srv` or
    /// `.action` file; [`TypeSource::NONE`] for a type declared in Rust. Set with
    /// `#[ros(source = "…")]`.
    const SOURCE: TypeSource = TypeSource::NONE;

    /// This type's own description (referenced types excluded).
    fn type_description() -> TypeDescription {
        TypeDescription::new(Self::TYPE_NAME, Self::FIELDS, Self::SOURCE)
    }

    /// This type's description with every type it references, as a
    /// type-description service reply carries it.
    fn full_description() -> FullDescription
    where
        Self: Sized,
    {
        FullDescription::collect(Self::type_description(), Self::register_types)
    }
}

/// A message type's borrowing form: the type a reader decodes without copying
/// strings and byte sequences out of the input. Generated types implement it
/// (`Header`'s is `HeaderRef<'a>`; a type with nothing to borrow names itself),
/// which lets generated code borrow through message types of other crates.
///
/// Invariant: `Ref<'a>` has the same type name, fields, type hash and bytes on
/// the wire as `Self`.
pub trait BorrowedForm: RosMessage {
    /// The borrowing form.
    type Ref<'a>: RosMessage + crate::CdrDecode<'a> + Clone + core::fmt::Debug + PartialEq + Default;
}

/// A Rust type usable as the type of a message field.
#[diagnostic::on_unimplemented(
    message = "`{Self}` is not a ROS 2 field type",
    label = "not a ROS 2 field type",
    note = "use bool, u8..u64, i8..i64, f32, f64, String, BoundedString<N>, WString, Vec<T>, BoundedVec<T, N>, [T; N], bytes::Bytes, compact_str::CompactString, &str, &[u8], Cow<str>, Cow<[T]>, or a struct with #[derive(RosMessage)]"
)]
pub trait RosType {
    /// How the field appears in the type description.
    const FIELD_TYPE: FieldType;

    /// Register the descriptions of every message type reachable from this type.
    fn register_types(_registry: &mut TypeRegistry) {}
}

/// A [`RosType`] that may be the element of a sequence or array: everything but
/// sequences and arrays themselves (ROS 2 has no nested sequences).
#[diagnostic::on_unimplemented(
    message = "`{Self}` cannot be the element of a ROS 2 sequence or array",
    label = "not a ROS 2 sequence element",
    note = "ROS 2 has no sequences of sequences or arrays of arrays: wrap the inner one in a struct with #[derive(RosMessage)]"
)]
pub trait RosElement: RosType {}

/// Field types that `#[ros(byte)]` and `#[ros(char)]` may annotate: `u8`/`i8` and
/// sequences and arrays of them.
#[diagnostic::on_unimplemented(
    message = "#[ros(byte)] and #[ros(char)] apply only to u8 or i8 fields, or sequences and arrays of them, not `{Self}`",
    label = "not u8 or i8",
    note = "remove the attribute, or change the field to u8, i8, Vec<u8>, [u8; N] or BoundedVec<u8, N>"
)]
pub trait OctetType {}

macro_rules! octet_types {
    ($($elem:ty),*) => {$(
        impl OctetType for $elem {}
        impl OctetType for Vec<$elem> {}
        impl OctetType for [$elem] {}
        impl OctetType for &[$elem] {}
        impl OctetType for std::borrow::Cow<'_, [$elem]> {}
        impl<const N: usize> OctetType for [$elem; N] {}
        impl<const N: usize> OctetType for crate::BoundedVec<$elem, N> {}
    )*};
}
octet_types!(u8, i8);
#[cfg(feature = "bytes")]
impl OctetType for bytes::Bytes {}

/// The hashed JSON text of message type `T` (for debugging a hash mismatch against
/// rosidl's `.json` type description files).
pub fn message_description_json<T: RosMessage + ?Sized>() -> String {
    FullDescription::collect(T::type_description(), T::register_types).hashed_json()
}

/// Compute the `RIHS01` hash of message type `T` (derived code caches it).
pub fn compute_type_hash<T: RosMessage + ?Sized>() -> String {
    rihs01_of_json(&message_description_json::<T>())
}
