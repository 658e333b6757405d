//! Type descriptions and the REP 2011 `RIHS01` type hash.
//!
//! The model of a description is `shm_interface`'s, re-exported here: every
//! field type knows its [`FieldType`] at compile time ([`RosType`]); derived
//! messages list their [`Field`]s and register the messages they reference.
//! The hash is computed as rosidl's `calculate_type_hash` does: the JSON of
//! the type and of every referenced type (sorted by name), separators `", "`
//! and `": "`, SHA-256.

pub use shm_interface::{
    msg_text, rihs01_of_json, split_type_id, type_description_json, type_id, write_individual_json,
    Container, ContainerKind, DescribedField, Field, FieldType, FullDescription, TypeDescription,
    TypeId, TypeRegistry, TypeSource,
};

/// A Rust type usable as the type of a message field.
#[diagnostic::on_unimplemented(
    message = "`{Self}` is not a ROS 2 field type",
    label = "not a ROS 2 field type",
    note = "use bool, u8..u64, i8..i64, f32, f64, String, BoundedString<N>, WString, Vec<T>, BoundedVec<T, N>, [T; N], bytes::Bytes, &str, &[u8], Cow<str>, Cow<[T]>, or a struct with #[derive(RosMessage)]"
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

/// The description as `type_description_interfaces/msg/TypeDescription`: what
/// a node's `~/get_type_description` answers with.
#[cfg(feature = "type_description_interfaces")]
impl From<&FullDescription> for crate::msgs::type_description_interfaces::msg::TypeDescription {
    fn from(full: &FullDescription) -> Self {
        use crate::msgs::type_description_interfaces::msg as td;
        let individual = |description: &TypeDescription| td::IndividualTypeDescription {
            type_name: description.type_name.into(),
            fields: description
                .fields
                .iter()
                .map(|field| {
                    let t = &field.field_type;
                    td::Field {
                        name: field.name.to_owned(),
                        r#type: td::FieldType {
                            type_id: t.type_id(),
                            capacity: t.capacity() as u64,
                            string_capacity: t.string_capacity as u64,
                            nested_type_name: t.nested_type_name.into(),
                        },
                        default_value: field.default_value.to_owned(),
                    }
                })
                .collect(),
        };
        td::TypeDescription {
            type_description: individual(&full.own),
            referenced_type_descriptions: full.referenced.iter().map(individual).collect(),
        }
    }
}

/// The hashed JSON text of message type `T` (for debugging a hash mismatch against
/// rosidl's `.json` type description files).
pub fn message_description_json<T: crate::RosMessage + ?Sized>() -> String {
    FullDescription::collect(T::type_description(), T::register_types).hashed_json()
}

/// Compute the `RIHS01` hash of message type `T` (derived code caches it).
pub fn compute_type_hash<T: crate::RosMessage + ?Sized>() -> String {
    rihs01_of_json(&message_description_json::<T>())
}
