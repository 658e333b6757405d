//! Values of run-time types: a message is its type and one [`Value`] per field.

use std::borrow::Cow;
use std::fmt;

use super::model::{DynamicType, Element, StructDef};
use crate::describe::Container;

/// The value of one field. Strings, byte and number arrays borrow from the
/// input they were decoded from where the generated types borrow (`'a`).
#[derive(Debug, Clone, PartialEq)]
#[allow(missing_docs)] // The variants are the ROS types they name.
pub enum Value<'a> {
    Bool(bool),
    /// `byte`, `char` and `uint8`.
    U8(u8),
    I8(i8),
    I16(i16),
    U16(u16),
    I32(i32),
    U32(u32),
    I64(i64),
    U64(u64),
    F32(f32),
    F64(f64),
    String(Cow<'a, str>),
    WString(String),
    Message(Message<'a>),
    Bools(Vec<bool>),
    /// Arrays and sequences of `byte`, `char` and `uint8`.
    U8s(Cow<'a, [u8]>),
    I8s(Cow<'a, [i8]>),
    I16s(Cow<'a, [i16]>),
    U16s(Cow<'a, [u16]>),
    I32s(Cow<'a, [i32]>),
    U32s(Cow<'a, [u32]>),
    I64s(Cow<'a, [i64]>),
    U64s(Cow<'a, [u64]>),
    F32s(Cow<'a, [f32]>),
    F64s(Cow<'a, [f64]>),
    Strings(Vec<Cow<'a, str>>),
    WStrings(Vec<String>),
    Messages(Vec<Message<'a>>),
}

impl Value<'_> {
    /// The number of elements of an array or sequence value; `None` for a
    /// single one.
    pub fn len(&self) -> Option<usize> {
        Some(match self {
            Self::Bools(v) => v.len(),
            Self::U8s(v) => v.len(),
            Self::I8s(v) => v.len(),
            Self::I16s(v) => v.len(),
            Self::U16s(v) => v.len(),
            Self::I32s(v) => v.len(),
            Self::U32s(v) => v.len(),
            Self::I64s(v) => v.len(),
            Self::U64s(v) => v.len(),
            Self::F32s(v) => v.len(),
            Self::F64s(v) => v.len(),
            Self::Strings(v) => v.len(),
            Self::WStrings(v) => v.len(),
            Self::Messages(v) => v.len(),
            _ => return None,
        })
    }

    /// What kind of value this is, for messages (`int32`, `string[]`, …).
    pub fn kind_name(&self) -> &'static str {
        match self {
            Self::Bool(_) => "bool",
            Self::U8(_) => "uint8",
            Self::I8(_) => "int8",
            Self::I16(_) => "int16",
            Self::U16(_) => "uint16",
            Self::I32(_) => "int32",
            Self::U32(_) => "uint32",
            Self::I64(_) => "int64",
            Self::U64(_) => "uint64",
            Self::F32(_) => "float32",
            Self::F64(_) => "float64",
            Self::String(_) => "string",
            Self::WString(_) => "wstring",
            Self::Message(_) => "message",
            Self::Bools(_) => "bool[]",
            Self::U8s(_) => "uint8[]",
            Self::I8s(_) => "int8[]",
            Self::I16s(_) => "int16[]",
            Self::U16s(_) => "uint16[]",
            Self::I32s(_) => "int32[]",
            Self::U32s(_) => "uint32[]",
            Self::I64s(_) => "int64[]",
            Self::U64s(_) => "uint64[]",
            Self::F32s(_) => "float32[]",
            Self::F64s(_) => "float64[]",
            Self::Strings(_) => "string[]",
            Self::WStrings(_) => "wstring[]",
            Self::Messages(_) => "message[]",
        }
    }

    /// Whether an array or sequence value is empty (`false` for a single one).
    pub fn is_empty(&self) -> bool {
        self.len() == Some(0)
    }

    /// The value with everything it borrows copied.
    pub fn into_owned(self) -> Value<'static> {
        match self {
            Self::Bool(v) => Value::Bool(v),
            Self::U8(v) => Value::U8(v),
            Self::I8(v) => Value::I8(v),
            Self::I16(v) => Value::I16(v),
            Self::U16(v) => Value::U16(v),
            Self::I32(v) => Value::I32(v),
            Self::U32(v) => Value::U32(v),
            Self::I64(v) => Value::I64(v),
            Self::U64(v) => Value::U64(v),
            Self::F32(v) => Value::F32(v),
            Self::F64(v) => Value::F64(v),
            Self::String(v) => Value::String(Cow::Owned(v.into_owned())),
            Self::WString(v) => Value::WString(v),
            Self::Message(v) => Value::Message(v.into_owned()),
            Self::Bools(v) => Value::Bools(v),
            Self::U8s(v) => Value::U8s(Cow::Owned(v.into_owned())),
            Self::I8s(v) => Value::I8s(Cow::Owned(v.into_owned())),
            Self::I16s(v) => Value::I16s(Cow::Owned(v.into_owned())),
            Self::U16s(v) => Value::U16s(Cow::Owned(v.into_owned())),
            Self::I32s(v) => Value::I32s(Cow::Owned(v.into_owned())),
            Self::U32s(v) => Value::U32s(Cow::Owned(v.into_owned())),
            Self::I64s(v) => Value::I64s(Cow::Owned(v.into_owned())),
            Self::U64s(v) => Value::U64s(Cow::Owned(v.into_owned())),
            Self::F32s(v) => Value::F32s(Cow::Owned(v.into_owned())),
            Self::F64s(v) => Value::F64s(Cow::Owned(v.into_owned())),
            Self::Strings(v) => {
                Value::Strings(v.into_iter().map(|s| Cow::Owned(s.into_owned())).collect())
            }
            Self::WStrings(v) => Value::WStrings(v),
            Self::Messages(v) => Value::Messages(v.into_iter().map(Message::into_owned).collect()),
        }
    }
}

/// A message of a [`DynamicType`]: one value per field, each of its field's
/// kind. Made by [`DynamicType::decode`] or [`DynamicType::default_message`]
/// and changed with [`set`](Self::set), which keeps every value of its
/// field's kind; it encodes with [`crate::to_vec`] and the rest of the
/// encoding API, sized exactly.
#[derive(Clone, PartialEq)]
pub struct Message<'a> {
    pub(crate) ty: DynamicType,
    /// Which of the type's structs this is.
    pub(crate) index: usize,
    pub(crate) values: Vec<Value<'a>>,
    /// The fields decoded cut short for printing
    /// ([`DynamicType::decode_truncated`]), with how many elements each
    /// holds on the wire: `(field index, length)`.
    pub(crate) cut: Vec<(usize, usize)>,
}

impl fmt::Debug for Message<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let def = self.def();
        let mut s = f.debug_struct(&def.name);
        for (field, value) in def.fields.iter().zip(&self.values) {
            s.field(&field.name, value);
        }
        s.finish()
    }
}

/// Why [`Message::set`] refused a value.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ValueError {
    /// The message type.
    pub type_name: String,
    /// The field.
    pub field: String,
    /// What is wrong.
    pub reason: String,
}

impl fmt::Display for ValueError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}.{}: {}", self.type_name, self.field, self.reason)
    }
}

impl std::error::Error for ValueError {}

impl<'a> Message<'a> {
    /// The message's type (a nested message's own type, for a field's value).
    pub fn type_name(&self) -> &str {
        &self.def().name
    }

    pub(crate) fn def(&self) -> &StructDef {
        &self.ty.inner.structs[self.index]
    }

    /// Whether this is a message of type `ty` itself (not one of the types
    /// it nests).
    pub fn is_of(&self, ty: &DynamicType) -> bool {
        self.index == 0 && self.ty == *ty
    }

    /// The field names and values, in order.
    pub fn fields(&self) -> impl Iterator<Item = (&str, &Value<'a>)> {
        self.def()
            .fields
            .iter()
            .map(|f| f.name.as_str())
            .zip(&self.values)
    }

    /// The value of field `name`.
    pub fn get(&self, name: &str) -> Option<&Value<'a>> {
        self.def()
            .field_index(name)
            .and_then(|i| self.values.get(i))
    }

    /// Set field `name` to `value`, if it is of the field's kind and within its
    /// bounds (an array's length, a sequence's or string's bound); nested
    /// messages must be of the field's type.
    pub fn set(&mut self, name: &str, value: Value<'a>) -> Result<(), ValueError> {
        let def = self.def();
        let error = |reason: String| ValueError {
            type_name: def.name.clone(),
            field: name.to_owned(),
            reason,
        };
        let i = def
            .field_index(name)
            .ok_or_else(|| error("no such field".into()))?;
        let field = &def.fields[i];
        check(&self.ty, field.element, field.container, &value).map_err(error)?;
        self.values[i] = value;
        self.cut.retain(|(field, _)| *field != i);
        Ok(())
    }

    /// How many elements field `i` holds on the wire: its value's length, or
    /// for a field decoded cut short, the length it was cut from.
    pub(crate) fn wire_len(&self, i: usize) -> Option<usize> {
        match self.cut.iter().find(|(field, _)| *field == i) {
            Some((_, len)) => Some(*len),
            None => self.values.get(i)?.len(),
        }
    }

    /// The message with everything it borrows copied.
    pub fn into_owned(self) -> Message<'static> {
        Message {
            ty: self.ty,
            index: self.index,
            values: self.values.into_iter().map(Value::into_owned).collect(),
            cut: self.cut,
        }
    }
}

/// Whether `value` is a value of a field of `element` in `container`.
fn check(
    ty: &DynamicType,
    element: Element,
    container: Container,
    value: &Value<'_>,
) -> Result<(), String> {
    let nested_ok = |m: &Message<'_>, index: usize| m.ty == *ty && m.index == index;
    let kind_ok = match (container, element, value) {
        (Container::Single, Element::Bool, Value::Bool(_))
        | (Container::Single, Element::Byte | Element::Char | Element::U8, Value::U8(_))
        | (Container::Single, Element::I8, Value::I8(_))
        | (Container::Single, Element::I16, Value::I16(_))
        | (Container::Single, Element::U16, Value::U16(_))
        | (Container::Single, Element::I32, Value::I32(_))
        | (Container::Single, Element::U32, Value::U32(_))
        | (Container::Single, Element::I64, Value::I64(_))
        | (Container::Single, Element::U64, Value::U64(_))
        | (Container::Single, Element::F32, Value::F32(_))
        | (Container::Single, Element::F64, Value::F64(_))
        | (Container::Single, Element::String(_), Value::String(_))
        | (Container::Single, Element::WString(_), Value::WString(_)) => true,
        (Container::Single, Element::Message(index), Value::Message(m)) => nested_ok(m, index),
        (Container::Single, _, _) => false,
        (_, Element::Bool, Value::Bools(_))
        | (_, Element::Byte | Element::Char | Element::U8, Value::U8s(_))
        | (_, Element::I8, Value::I8s(_))
        | (_, Element::I16, Value::I16s(_))
        | (_, Element::U16, Value::U16s(_))
        | (_, Element::I32, Value::I32s(_))
        | (_, Element::U32, Value::U32s(_))
        | (_, Element::I64, Value::I64s(_))
        | (_, Element::U64, Value::U64s(_))
        | (_, Element::F32, Value::F32s(_))
        | (_, Element::F64, Value::F64s(_))
        | (_, Element::String(_), Value::Strings(_))
        | (_, Element::WString(_), Value::WStrings(_)) => true,
        (_, Element::Message(index), Value::Messages(ms)) => ms.iter().all(|m| nested_ok(m, index)),
        _ => false,
    };
    if !kind_ok {
        return Err(format!(
            "a {} is not a value of this field's type",
            value.kind_name()
        ));
    }
    let len = value.len().unwrap_or(0);
    match container {
        Container::Array(n) if len != n => {
            return Err(format!("{len} elements for an array of {n}"))
        }
        Container::BoundedSequence(n) if len > n => {
            return Err(format!("{len} elements for a sequence of at most {n}"))
        }
        _ => {}
    }
    let within = |s: &str, bound: Option<usize>, utf16: bool| match bound {
        Some(bound) => {
            let n = if utf16 {
                s.encode_utf16().count()
            } else {
                s.len()
            };
            n <= bound
        }
        None => true,
    };
    let strings_ok = match (element, value) {
        (Element::String(b), Value::String(s)) => within(s, b, false),
        (Element::String(b), Value::Strings(v)) => v.iter().all(|s| within(s, b, false)),
        (Element::WString(b), Value::WString(s)) => within(s, b, true),
        (Element::WString(b), Value::WStrings(v)) => v.iter().all(|s| within(s, b, true)),
        _ => true,
    };
    if strings_ok {
        Ok(())
    } else {
        Err("a string is longer than the field's bound".into())
    }
}

impl DynamicType {
    /// A message of this type with every field at its default: the default
    /// value its description gives, else zero, empty, or an array of zeros
    /// (every element of a fixed array is made).
    pub fn default_message(&self) -> Message<'static> {
        self.default_struct(0)
    }

    pub(crate) fn default_struct(&self, index: usize) -> Message<'static> {
        let def = &self.inner.structs[index];
        let values = def
            .fields
            .iter()
            .map(|f| {
                let n = match f.container {
                    Container::Array(n) => n,
                    _ => 0,
                };
                let given = super::defaults::parse(f.element, f.container, &f.default_value);
                given.unwrap_or_else(|| self.zero(f.element, f.container, n))
            })
            .collect();
        Message {
            ty: self.clone(),
            index,
            values,
            cut: Vec::new(),
        }
    }

    fn zero(&self, element: Element, container: Container, n: usize) -> Value<'static> {
        if container == Container::Single {
            return match element {
                Element::Bool => Value::Bool(false),
                Element::Byte | Element::Char | Element::U8 => Value::U8(0),
                Element::I8 => Value::I8(0),
                Element::I16 => Value::I16(0),
                Element::U16 => Value::U16(0),
                Element::I32 => Value::I32(0),
                Element::U32 => Value::U32(0),
                Element::I64 => Value::I64(0),
                Element::U64 => Value::U64(0),
                Element::F32 => Value::F32(0.0),
                Element::F64 => Value::F64(0.0),
                Element::String(_) => Value::String(Cow::Borrowed("")),
                Element::WString(_) => Value::WString(String::new()),
                Element::Message(i) => Value::Message(self.default_struct(i)),
            };
        }
        match element {
            Element::Bool => Value::Bools(vec![false; n]),
            Element::Byte | Element::Char | Element::U8 => Value::U8s(Cow::Owned(vec![0; n])),
            Element::I8 => Value::I8s(Cow::Owned(vec![0; n])),
            Element::I16 => Value::I16s(Cow::Owned(vec![0; n])),
            Element::U16 => Value::U16s(Cow::Owned(vec![0; n])),
            Element::I32 => Value::I32s(Cow::Owned(vec![0; n])),
            Element::U32 => Value::U32s(Cow::Owned(vec![0; n])),
            Element::I64 => Value::I64s(Cow::Owned(vec![0; n])),
            Element::U64 => Value::U64s(Cow::Owned(vec![0; n])),
            Element::F32 => Value::F32s(Cow::Owned(vec![0.0; n])),
            Element::F64 => Value::F64s(Cow::Owned(vec![0.0; n])),
            Element::String(_) => Value::Strings(vec![Cow::Borrowed(""); n]),
            Element::WString(_) => Value::WStrings(vec![String::new(); n]),
            Element::Message(i) => {
                Value::Messages((0..n).map(|_| self.default_struct(i)).collect())
            }
        }
    }
}
