//! A message type as REP 2011's type description states it: its fields,
//! each field's type, the types it references, and where it was defined.
//! These are the forms a compiled type holds as constants
//! (`#[derive(RosMessage)]` and generated code write them).

use std::borrow::Cow;
use std::collections::BTreeMap;

use crate::described::DescribedField;

/// The member rosidl gives a message without fields, so that every type
/// has one: `uint8 structure_needs_at_least_one_member`.
pub const PLACEHOLDER_MEMBER: &str = "structure_needs_at_least_one_member";
pub use crate::type_id::{Container, TypeId};

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

    /// The numeric `type_id` ([`crate::type_id`]): the element kind plus 48
    /// for arrays, 96 for bounded and 144 for unbounded sequences.
    pub const fn type_id(&self) -> u8 {
        crate::type_id(self.element, self.container.kind())
    }

    /// The array size or sequence bound, else 0.
    pub const fn capacity(&self) -> usize {
        self.container.capacity()
    }
}

/// One named field of a message.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub struct Field {
    /// The ROS field name.
    pub name: &'static str,
    /// Its type.
    pub field_type: FieldType,
    /// The default value the interface file gives the field, as rosidl writes it
    /// in a type description (Python's `str()` of the value: `1.0`, `True`,
    /// `(0, 127, -128)`, `('', 'max value')`, a string unquoted), or empty. It is
    /// not part of the type hash.
    pub default_value: &'static str,
}

impl Field {
    /// A field with no default value.
    pub const fn new(name: &'static str, field_type: FieldType) -> Self {
        Self {
            name,
            field_type,
            default_value: "",
        }
    }

    /// The same field with a default value, written as rosidl writes it (see
    /// [`default_value`](Self::default_value)).
    pub const fn with_default_value(self, default_value: &'static str) -> Self {
        Self {
            default_value,
            ..self
        }
    }
}

/// Where a type was defined: the interface file's text, as rosidl reports it in
/// `type_description_interfaces/TypeSource`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub struct TypeSource {
    /// `msg`, `srv`, `action`, `idl`, `implicit` (a type rosidl derives from a
    /// `.srv` or `.action` file, with no text of its own), or empty when the type
    /// was declared in Rust and has no file.
    pub encoding: &'static str,
    /// The file's text, its lines joined by `\n` with no newline at the end.
    pub raw_file_contents: &'static str,
}

impl TypeSource {
    /// No interface file: a type declared in Rust (`#[derive(RosMessage)]`).
    /// [`TypeDescription::source_text`] writes a `.msg` text for it.
    pub const NONE: Self = Self {
        encoding: "",
        raw_file_contents: "",
    };

    /// A type rosidl derives from a `.srv` or `.action` file (`…_Request`,
    /// `…_Goal`, `…_SendGoal`, …).
    pub const IMPLICIT: Self = Self {
        encoding: "implicit",
        raw_file_contents: "",
    };

    /// A file of the given encoding (`msg`, `srv`, `action`, `idl`) and text.
    pub const fn file(encoding: &'static str, raw_file_contents: &'static str) -> Self {
        Self {
            encoding,
            raw_file_contents,
        }
    }
}

/// A message type: its name and fields, as they enter the type hash, and where
/// it was defined.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub struct TypeDescription {
    /// `pkg/msg/Name`.
    pub type_name: &'static str,
    /// The fields in declaration order (an empty message lists rosidl's
    /// `structure_needs_at_least_one_member: uint8`).
    pub fields: &'static [Field],
    /// The interface file it came from (not part of the type hash).
    pub source: TypeSource,
}

impl TypeDescription {
    /// A description of `type_name` with these fields and source.
    pub const fn new(
        type_name: &'static str,
        fields: &'static [Field],
        source: TypeSource,
    ) -> Self {
        Self {
            type_name,
            fields,
            source,
        }
    }

    /// The source's encoding and text as a type-description service reports them.
    /// A type declared in Rust has no file: it gets `msg` and a `.msg` text written
    /// from its fields, which describes the same type.
    pub fn source_text(&self) -> (&'static str, Cow<'static, str>) {
        if self.source.encoding.is_empty() {
            (
                "msg",
                Cow::Owned(crate::msg_text(self.fields.iter().map(DescribedField::of))),
            )
        } else {
            (
                self.source.encoding,
                Cow::Borrowed(self.source.raw_file_contents),
            )
        }
    }
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

impl<'a> DescribedField<'a> {
    /// A compiled type's field as its description states it.
    pub fn of(field: &'a Field) -> Self {
        let t = &field.field_type;
        Self {
            name: field.name,
            type_id: t.type_id(),
            capacity: t.capacity() as u64,
            string_capacity: t.string_capacity as u64,
            nested_type_name: t.nested_type_name,
            default_value: field.default_value,
        }
    }
}

/// A type with every type it references, sorted by name: what a
/// `type_description_interfaces/TypeDescription` message carries.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct FullDescription {
    /// The type itself.
    pub own: TypeDescription,
    /// Every type it references, directly or not, each once, sorted by name.
    pub referenced: Vec<TypeDescription>,
}

impl FullDescription {
    /// The description of `own` with the types `register` adds (a type's
    /// `register_types`).
    pub fn collect(own: TypeDescription, register: impl FnOnce(&mut TypeRegistry)) -> Self {
        let mut registry = TypeRegistry::default();
        register(&mut registry);
        let referenced = registry
            .iter()
            .filter(|d| d.type_name != own.type_name)
            .copied()
            .collect();
        Self { own, referenced }
    }

    /// The text rosidl hashes (no default values).
    pub fn hashed_json(&self) -> String {
        self.json_with(false)
    }

    /// The JSON rosidl installs as `type_description_msg` in its `.json` files,
    /// default values included.
    pub fn json(&self) -> String {
        self.json_with(true)
    }

    fn json_with(&self, defaults: bool) -> String {
        crate::json::description_json(
            std::iter::once(&self.own)
                .chain(&self.referenced)
                .map(|d| (d.type_name, d.fields.iter().map(DescribedField::of))),
            defaults,
        )
    }

    /// The `RIHS01` hash.
    pub fn type_hash(&self) -> String {
        crate::rihs01_of_json(&self.hashed_json())
    }

    /// The sources a type-description service reports, as rosidl orders them:
    /// the type's own, then each referenced type's; each as (type name,
    /// encoding, text) from [`TypeDescription::source_text`].
    pub fn sources(
        &self,
    ) -> impl Iterator<Item = (&'static str, &'static str, Cow<'static, str>)> + '_ {
        std::iter::once(&self.own).chain(&self.referenced).map(|d| {
            let (encoding, text) = d.source_text();
            (d.type_name, encoding, text)
        })
    }
}

/// The exact text rosidl hashes for a type: its description and the
/// descriptions of the types it references (sorted by name).
pub fn type_description_json<'a>(
    description: &'a TypeDescription,
    referenced: impl IntoIterator<Item = &'a TypeDescription>,
) -> String {
    crate::json::description_json(
        std::iter::once(description)
            .chain(referenced)
            .map(|d| (d.type_name, d.fields.iter().map(DescribedField::of))),
        false,
    )
}
