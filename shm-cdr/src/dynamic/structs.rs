//! What a run-time type is made of: its message types (structs), their
//! fields and each field's element, and how a view checks each field. The
//! type ([`DynamicType`](super::DynamicType)), its plans, its values and its
//! defaults all build on these.

use crate::describe::{Container, DescribedField};

/// What one element of a field is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Element {
    /// `bool`.
    Bool,
    /// `byte` (IDL `octet`).
    Byte,
    /// IDL `char` (8 bits).
    Char,
    /// `int8`.
    I8,
    /// `uint8` (and .msg `char`).
    U8,
    /// `int16`.
    I16,
    /// `uint16`.
    U16,
    /// `int32`.
    I32,
    /// `uint32`.
    U32,
    /// `int64`.
    I64,
    /// `uint64`.
    U64,
    /// `float32`.
    F32,
    /// `float64`.
    F64,
    /// `string`, or `string<=N` with a bound in bytes.
    String(Option<usize>),
    /// `wstring`, or `wstring<=N` with a bound in UTF-16 code units.
    WString(Option<usize>),
    /// A nested message: an index into
    /// [`DynamicType::structs`](super::DynamicType::structs).
    Message(usize),
}

impl Element {
    /// Whether it is a number or a byte: any element but a bool (whose byte
    /// must be 0 or 1), a string or a message. An array of these is bytes
    /// that any bit pattern makes valid.
    pub fn is_number(self) -> bool {
        !matches!(
            self,
            Self::Bool | Self::String(_) | Self::WString(_) | Self::Message(_)
        )
    }

    /// The bytes one number or bool takes; `None` for strings and messages.
    pub(crate) fn fixed_size(self) -> Option<usize> {
        match self {
            Self::Bool | Self::Byte | Self::Char | Self::I8 | Self::U8 => Some(1),
            Self::I16 | Self::U16 => Some(2),
            Self::I32 | Self::U32 | Self::F32 => Some(4),
            Self::I64 | Self::U64 | Self::F64 => Some(8),
            Self::String(_) | Self::WString(_) | Self::Message(_) => None,
        }
    }

    /// The fewest bytes one element takes on the wire (for length checks).
    pub(crate) fn min_wire_size(self, structs: &[StructDef]) -> usize {
        match self {
            Self::Bool | Self::Byte | Self::Char | Self::I8 | Self::U8 => 1,
            Self::I16 | Self::U16 => 2,
            Self::I32 | Self::U32 | Self::F32 | Self::String(_) | Self::WString(_) => 4,
            Self::I64 | Self::U64 | Self::F64 => 8,
            Self::Message(i) => structs.get(i).map_or(1, |s| s.min_wire_size),
        }
    }
}

/// One field of a message type.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct FieldDef {
    /// The field's name.
    pub name: String,
    /// Its element.
    pub element: Element,
    /// Single, array or sequence.
    pub container: Container,
    /// The default value as the description gives it (Python's `str()`), or
    /// empty.
    pub default_value: String,
    /// The description's `type_id`, `capacity`, `string_capacity` and nested
    /// type name, kept for the hash.
    pub(crate) described: (u8, u64, u64, String),
}

impl FieldDef {
    /// The field as its type description states it.
    pub(crate) fn described(&self) -> DescribedField<'_> {
        DescribedField {
            name: &self.name,
            type_id: self.described.0,
            capacity: self.described.1,
            string_capacity: self.described.2,
            nested_type_name: &self.described.3,
            default_value: &self.default_value,
        }
    }
}

/// One message type.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct StructDef {
    /// `pkg/msg/Name`.
    pub name: String,
    /// Its fields, in order.
    pub fields: Vec<FieldDef>,
    /// The fewest bytes a value takes on the wire (at least 1).
    pub(crate) min_wire_size: usize,
}

impl StructDef {
    /// The index of the field called `name`.
    pub fn field_index(&self, name: &str) -> Option<usize> {
        self.fields.iter().position(|f| f.name == name)
    }
}

/// How a view checks one field: the field's element and container folded
/// into one choice, sizes worked out when the type is built.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Check {
    /// One number of this many bytes, aligned to its size.
    Number(usize),
    /// One `bool`.
    Bool,
    /// One `string` (with its bound).
    String(Option<usize>),
    /// One `wstring` (with its bound).
    WString(Option<usize>),
    /// One nested message: its struct and how many fields it has.
    Message { index: usize, width: usize },
    /// An array or sequence; `min` is the fewest bytes one element takes.
    Many {
        element: Element,
        container: Container,
        min: usize,
    },
}
