//! Type descriptions and the REP 2011 `RIHS01` type hash.
//!
//! Every field type knows its [`FieldType`] at compile time ([`RosType`]); derived
//! messages list their [`Field`]s and register the messages they reference. The hash
//! is computed as rosidl's `calculate_type_hash` does: the JSON of the type and of
//! every referenced type (sorted by name), separators `", "` and `": "`, SHA-256.

use std::collections::BTreeMap;
use std::fmt::Write as _;

use sha2::{Digest, Sha256};

/// The element kind of a field, as numbered by `type_description_interfaces/FieldType`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[repr(u8)]
#[allow(missing_docs)] // The variant names are the rosidl names.
pub enum TypeId {
    Nested = 1,
    Int8 = 2,
    Uint8 = 3,
    Int16 = 4,
    Uint16 = 5,
    Int32 = 6,
    Uint32 = 7,
    Int64 = 8,
    Uint64 = 9,
    Float32 = 10,
    Float64 = 11,
    /// IDL `char` (not .msg `char`, which is `Uint8`).
    Char = 13,
    WChar = 14,
    Boolean = 15,
    /// .msg `byte`, IDL `octet`.
    Byte = 16,
    String = 17,
    WString = 18,
    BoundedString = 21,
    BoundedWString = 22,
}

/// How a field holds its elements.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Container {
    /// One element.
    Single,
    /// A fixed array of this many elements.
    Array(usize),
    /// A sequence of at most this many elements.
    BoundedSequence(usize),
    /// A sequence of any length.
    Sequence,
}

/// The type of one field, as it enters the type hash.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct FieldType {
    /// The element kind.
    pub element: TypeId,
    /// Single, array or sequence.
    pub container: Container,
    /// The bound of a bounded (w)string element, else 0.
    pub string_capacity: usize,
    /// The `pkg/msg/Name` of a nested message element, else empty.
    pub nested_type_name: &'static str,
}

impl FieldType {
    /// A single element of a primitive or unbounded string kind.
    pub const fn scalar(element: TypeId) -> Self {
        Self {
            element,
            container: Container::Single,
            string_capacity: 0,
            nested_type_name: "",
        }
    }

    /// A single nested message of type `type_name`.
    pub const fn nested(type_name: &'static str) -> Self {
        Self {
            nested_type_name: type_name,
            ..Self::scalar(TypeId::Nested)
        }
    }

    /// A single bounded string or wstring of at most `bound` characters.
    pub const fn bounded_string(element: TypeId, bound: usize) -> Self {
        Self {
            string_capacity: bound,
            ..Self::scalar(element)
        }
    }

    /// A fixed array of `n` of these elements.
    pub const fn array(self, n: usize) -> Self {
        Self {
            container: Container::Array(n),
            ..self
        }
    }

    /// A sequence of at most `bound` of these elements.
    pub const fn bounded_sequence(self, bound: usize) -> Self {
        Self {
            container: Container::BoundedSequence(bound),
            ..self
        }
    }

    /// A sequence of any number of these elements.
    pub const fn unbounded_sequence(self) -> Self {
        Self {
            container: Container::Sequence,
            ..self
        }
    }

    /// The same field with its `u8`/`i8` elements declared as .msg `byte` (IDL
    /// `octet`), for `#[ros(byte)]`.
    pub const fn as_byte(self) -> Self {
        Self {
            element: TypeId::Byte,
            ..self
        }
    }

    /// The same field with its `u8`/`i8` elements declared as .msg `char`, which
    /// rosidl maps to `uint8`, for `#[ros(char)]`.
    pub const fn as_char(self) -> Self {
        Self {
            element: TypeId::Uint8,
            ..self
        }
    }

    /// The numeric `type_id`: the element kind plus 48 for arrays, 96 for bounded
    /// and 144 for unbounded sequences.
    pub const fn type_id(&self) -> u8 {
        let offset = match self.container {
            Container::Single => 0,
            Container::Array(_) => 48,
            Container::BoundedSequence(_) => 96,
            Container::Sequence => 144,
        };
        self.element as u8 + offset
    }

    /// The array size or sequence bound, else 0.
    pub const fn capacity(&self) -> usize {
        match self.container {
            Container::Array(n) | Container::BoundedSequence(n) => n,
            Container::Single | Container::Sequence => 0,
        }
    }
}

/// One named field of a message.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Field {
    /// The ROS field name.
    pub name: &'static str,
    /// Its type.
    pub field_type: FieldType,
}

/// A message type: its name and fields, as they enter the type hash.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct TypeDescription {
    /// `pkg/msg/Name`.
    pub type_name: &'static str,
    /// The fields in declaration order (an empty message lists rosidl's
    /// `structure_needs_at_least_one_member: uint8`).
    pub fields: &'static [Field],
}

/// The message types a type references, each once, sorted by name.
#[derive(Debug, Clone, Default)]
pub struct TypeRegistry {
    types: BTreeMap<&'static str, TypeDescription>,
}

impl TypeRegistry {
    /// Add a description; returns `false` if that type was already present (so
    /// recursion stops).
    pub fn insert(&mut self, description: TypeDescription) -> bool {
        self.types
            .insert(description.type_name, description)
            .is_none()
    }

    /// The registered descriptions, sorted by type name.
    pub fn iter(&self) -> impl Iterator<Item = &TypeDescription> {
        self.types.values()
    }
}

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

fn write_type_description(out: &mut String, description: &TypeDescription) {
    // Names are validated ASCII identifiers, so no JSON escaping is ever needed.
    let _ = write!(
        out,
        "{{\"type_name\": \"{}\", \"fields\": [",
        description.type_name
    );
    for (i, field) in description.fields.iter().enumerate() {
        if i > 0 {
            out.push_str(", ");
        }
        let t = &field.field_type;
        let _ = write!(
            out,
            "{{\"name\": \"{}\", \"type\": {{\"type_id\": {}, \"capacity\": {}, \"string_capacity\": {}, \"nested_type_name\": \"{}\"}}}}",
            field.name,
            t.type_id(),
            t.capacity(),
            t.string_capacity,
            t.nested_type_name
        );
    }
    out.push_str("]}");
}

/// The exact text rosidl hashes for a type: its description and the descriptions of
/// the types it references.
pub fn type_description_json<'a>(
    description: &TypeDescription,
    referenced: impl IntoIterator<Item = &'a TypeDescription>,
) -> String {
    let mut out = String::with_capacity(1024);
    out.push_str("{\"type_description\": ");
    write_type_description(&mut out, description);
    out.push_str(", \"referenced_type_descriptions\": [");
    for (i, referenced) in referenced.into_iter().enumerate() {
        if i > 0 {
            out.push_str(", ");
        }
        write_type_description(&mut out, referenced);
    }
    out.push_str("]}");
    out
}

/// `RIHS01_` followed by the lowercase hex SHA-256 of `json`.
pub fn rihs01_of_json(json: &str) -> String {
    let digest = Sha256::digest(json.as_bytes());
    let mut out = String::with_capacity(7 + 64);
    out.push_str("RIHS01_");
    for byte in digest {
        let _ = write!(out, "{byte:02x}");
    }
    out
}

/// The hashed JSON text of message type `T` (for debugging a hash mismatch against
/// rosidl's `.json` type description files).
pub fn message_description_json<T: crate::RosMessage + ?Sized>() -> String {
    let mut registry = TypeRegistry::default();
    T::register_types(&mut registry);
    let own = T::type_description();
    type_description_json(
        &own,
        registry.iter().filter(|d| d.type_name != own.type_name),
    )
}

/// Compute the `RIHS01` hash of message type `T` (derived code caches it).
pub fn compute_type_hash<T: crate::RosMessage + ?Sized>() -> String {
    rihs01_of_json(&message_description_json::<T>())
}
