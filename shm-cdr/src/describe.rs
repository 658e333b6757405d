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
    pub fn source_text(&self) -> (&'static str, std::borrow::Cow<'static, str>) {
        if self.source.encoding.is_empty() {
            (
                "msg",
                std::borrow::Cow::Owned(msg_text(self.fields.iter().map(DescribedField::of))),
            )
        } else {
            (
                self.source.encoding,
                std::borrow::Cow::Borrowed(self.source.raw_file_contents),
            )
        }
    }
}

/// `.msg` text declaring `fields`, one per line: a description written back
/// as the file it could come from (without the comments and constants a
/// description does not carry).
pub(crate) fn msg_text<'a>(fields: impl Iterator<Item = DescribedField<'a>>) -> String {
    let mut out = String::new();
    for (i, field) in fields.enumerate() {
        if i > 0 {
            out.push('\n');
        }
        // type_id is the element's id plus 48 per container kind.
        let base = (field.type_id.max(1) - 1) % 48 + 1;
        let container = (field.type_id.max(1) - 1) / 48;
        let element = match base {
            b if b == TypeId::Nested as u8 => {
                // `pkg/msg/Name` is written `pkg/Name` in .msg files.
                let mut parts = field.nested_type_name.split('/');
                match (parts.next(), parts.next(), parts.next()) {
                    (Some(pkg), Some(_), Some(name)) => format!("{pkg}/{name}"),
                    _ => field.nested_type_name.to_owned(),
                }
            }
            b if b == TypeId::BoundedString as u8 => format!("string<={}", field.string_capacity),
            b if b == TypeId::BoundedWString as u8 => {
                format!("wstring<={}", field.string_capacity)
            }
            other => msg_primitive_name(other).to_owned(),
        };
        out.push_str(&element);
        match container {
            0 => {}
            1 => {
                let _ = write!(out, "[{}]", field.capacity);
            }
            2 => {
                let _ = write!(out, "[<={}]", field.capacity);
            }
            _ => out.push_str("[]"),
        }
        out.push(' ');
        out.push_str(field.name);
        if !field.default_value.is_empty() {
            out.push(' ');
            let is_text = matches!(base, 17 | 18 | 21 | 22);
            out.push_str(&msg_default(field.default_value, is_text, container == 0));
        }
    }
    out
}

/// The `.msg` name of a primitive element id.
fn msg_primitive_name(id: u8) -> &'static str {
    match id {
        2 => "int8",
        3 => "uint8",
        4 => "int16",
        5 => "uint16",
        6 => "int32",
        7 => "uint32",
        8 => "int64",
        9 => "uint64",
        10 => "float32",
        11 => "float64",
        13 => "char",
        14 => "wchar",
        15 => "bool",
        16 => "byte",
        17 | 21 => "string",
        18 | 22 => "wstring",
        _ => "",
    }
}

/// A description's default value written back as `.msg` syntax: Python's tuple
/// `(a, b)` becomes `[a, b]`, `True` becomes `true`, a string is quoted.
fn msg_default(text: &str, is_text: bool, single: bool) -> String {
    let scalar = |s: &str| match s {
        "True" => "true".to_owned(),
        "False" => "false".to_owned(),
        other => other.to_owned(),
    };
    if single && is_text {
        let mut quoted = String::with_capacity(text.len() + 2);
        quoted.push('"');
        for c in text.chars() {
            if c == '"' || c == '\\' {
                quoted.push('\\');
            }
            quoted.push(c);
        }
        quoted.push('"');
        return quoted;
    }
    if single {
        return scalar(text);
    }
    // Python's repr of a tuple; its strings are already quoted.
    let inner = text
        .strip_prefix('(')
        .and_then(|t| t.strip_suffix(')'))
        .unwrap_or(text);
    let inner = inner.strip_suffix(',').unwrap_or(inner);
    if is_text {
        format!("[{inner}]")
    } else {
        let items: Vec<String> = inner
            .split(',')
            .map(str::trim)
            .filter(|s| !s.is_empty())
            .map(scalar)
            .collect();
        format!("[{}]", items.join(", "))
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

/// One field as a type description states it, whoever holds the description.
pub(crate) struct DescribedField<'a> {
    pub(crate) name: &'a str,
    pub(crate) type_id: u8,
    pub(crate) capacity: u64,
    pub(crate) string_capacity: u64,
    pub(crate) nested_type_name: &'a str,
    pub(crate) default_value: &'a str,
}

impl<'a> DescribedField<'a> {
    fn of(field: &'a Field) -> Self {
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

fn write_type_description(out: &mut String, description: &TypeDescription, defaults: bool) {
    write_individual_json(
        out,
        description.type_name,
        description.fields.iter().map(DescribedField::of),
        defaults,
    );
}

/// One `IndividualTypeDescription` as rosidl writes it for the hash (or, with
/// `defaults`, with default values).
pub(crate) fn write_individual_json<'a>(
    out: &mut String,
    type_name: &str,
    fields: impl Iterator<Item = DescribedField<'a>>,
    defaults: bool,
) {
    out.push_str("{\"type_name\": ");
    write_json_string(out, type_name);
    out.push_str(", \"fields\": [");
    for (i, field) in fields.enumerate() {
        if i > 0 {
            out.push_str(", ");
        }
        out.push_str("{\"name\": ");
        write_json_string(out, field.name);
        let _ = write!(
            out,
            ", \"type\": {{\"type_id\": {}, \"capacity\": {}, \"string_capacity\": {}, \"nested_type_name\": ",
            field.type_id, field.capacity, field.string_capacity,
        );
        write_json_string(out, field.nested_type_name);
        out.push('}');
        if defaults {
            out.push_str(", \"default_value\": ");
            write_json_string(out, field.default_value);
        }
        out.push('}');
    }
    out.push_str("]}");
}

fn write_json_string(out: &mut String, text: &str) {
    out.push('"');
    for c in text.chars() {
        match c {
            '"' => out.push_str("\\\""),
            '\\' => out.push_str("\\\\"),
            '\n' => out.push_str("\\n"),
            '\r' => out.push_str("\\r"),
            '\t' => out.push_str("\\t"),
            c if u32::from(c) < 0x20 => {
                let _ = write!(out, "\\u{:04x}", u32::from(c));
            }
            c => out.push(c),
        }
    }
    out.push('"');
}

/// The exact text rosidl hashes for a type: its description and the descriptions of
/// the types it references.
pub fn type_description_json<'a>(
    description: &TypeDescription,
    referenced: impl IntoIterator<Item = &'a TypeDescription>,
) -> String {
    description_json(description, referenced, false)
}

fn description_json<'a>(
    description: &TypeDescription,
    referenced: impl IntoIterator<Item = &'a TypeDescription>,
    defaults: bool,
) -> String {
    let mut out = String::with_capacity(1024);
    out.push_str("{\"type_description\": ");
    write_type_description(&mut out, description, defaults);
    out.push_str(", \"referenced_type_descriptions\": [");
    for (i, referenced) in referenced.into_iter().enumerate() {
        if i > 0 {
            out.push_str(", ");
        }
        write_type_description(&mut out, referenced, defaults);
    }
    out.push_str("]}");
    out
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
    /// The description as `type_description_interfaces/msg/TypeDescription`:
    /// what a node's `~/get_type_description` answers with.
    #[cfg(feature = "type_description_interfaces")]
    pub fn to_msg(&self) -> crate::msgs::type_description_interfaces::msg::TypeDescription {
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
            type_description: individual(&self.own),
            referenced_type_descriptions: self.referenced.iter().map(individual).collect(),
        }
    }

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

    /// The description of message type `T`.
    pub fn of_message<T: crate::RosMessage + ?Sized>() -> Self {
        Self::collect(T::type_description(), T::register_types)
    }

    /// The text rosidl hashes (no default values).
    pub fn hashed_json(&self) -> String {
        description_json(&self.own, &self.referenced, false)
    }

    /// The JSON rosidl installs as `type_description_msg` in its `.json` files,
    /// default values included.
    pub fn json(&self) -> String {
        description_json(&self.own, &self.referenced, true)
    }

    /// The `RIHS01` hash.
    pub fn type_hash(&self) -> String {
        rihs01_of_json(&self.hashed_json())
    }

    /// The sources a type-description service reports, as rosidl orders them:
    /// the type's own, then each referenced type's; each as (type name,
    /// encoding, text) from [`TypeDescription::source_text`].
    pub fn sources(
        &self,
    ) -> impl Iterator<Item = (&'static str, &'static str, std::borrow::Cow<'static, str>)> + '_
    {
        std::iter::once(&self.own).chain(&self.referenced).map(|d| {
            let (encoding, text) = d.source_text();
            (d.type_name, encoding, text)
        })
    }
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
    FullDescription::of_message::<T>().hashed_json()
}

/// Compute the `RIHS01` hash of message type `T` (derived code caches it).
pub fn compute_type_hash<T: crate::RosMessage + ?Sized>() -> String {
    rihs01_of_json(&message_description_json::<T>())
}
