//! The interface definitions read from `.msg`, `.srv` and `.action` files, and the
//! message types rosidl derives from services and actions.

use crate::described::DescribedFieldBuf;
use crate::python::{python_float, string_repr};
use crate::type_id::{type_id, TypeId};

/// A primitive (non-message) element type.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Primitive {
    /// `bool`
    Bool,
    /// `byte` (IDL `octet`)
    Byte,
    /// `char` (rosidl maps it to `uint8`)
    Char,
    /// `int8`
    Int8,
    /// `uint8`
    UInt8,
    /// `int16`
    Int16,
    /// `uint16`
    UInt16,
    /// `int32`
    Int32,
    /// `uint32`
    UInt32,
    /// `int64`
    Int64,
    /// `uint64`
    UInt64,
    /// `float32`
    Float32,
    /// `float64`
    Float64,
    /// `string` or `string<=N`
    String(Option<usize>),
    /// `wstring` or `wstring<=N`
    WString(Option<usize>),
}

impl Primitive {
    /// The `.msg` spelling of a primitive without a bound.
    pub fn from_msg_name(name: &str) -> Option<Self> {
        Some(match name {
            "bool" => Self::Bool,
            "byte" => Self::Byte,
            "char" => Self::Char,
            "int8" => Self::Int8,
            "uint8" => Self::UInt8,
            "int16" => Self::Int16,
            "uint16" => Self::UInt16,
            "int32" => Self::Int32,
            "uint32" => Self::UInt32,
            "int64" => Self::Int64,
            "uint64" => Self::UInt64,
            "float32" => Self::Float32,
            "float64" => Self::Float64,
            "string" => Self::String(None),
            "wstring" => Self::WString(None),
            _ => return None,
        })
    }

    /// Integer types: their inclusive range.
    pub fn int_range(self) -> Option<(i128, i128)> {
        Some(match self {
            Self::Byte | Self::Char | Self::UInt8 => (0, u8::MAX.into()),
            Self::Int8 => (i8::MIN.into(), i8::MAX.into()),
            Self::Int16 => (i16::MIN.into(), i16::MAX.into()),
            Self::UInt16 => (0, u16::MAX.into()),
            Self::Int32 => (i32::MIN.into(), i32::MAX.into()),
            Self::UInt32 => (0, u32::MAX.into()),
            Self::Int64 => (i64::MIN.into(), i64::MAX.into()),
            Self::UInt64 => (0, u64::MAX.into()),
            _ => return None,
        })
    }

    /// `float32` or `float64`.
    pub fn is_float(self) -> bool {
        matches!(self, Self::Float32 | Self::Float64)
    }

    /// `string`/`wstring`, bounded or not.
    pub fn is_string(self) -> bool {
        matches!(self, Self::String(_) | Self::WString(_))
    }

    /// The element kind a type description gives it: a `.msg` `char` is
    /// `uint8`, as rosidl maps it.
    pub fn element(self) -> TypeId {
        match self {
            Self::Bool => TypeId::Boolean,
            Self::Byte => TypeId::Byte,
            Self::Char | Self::UInt8 => TypeId::Uint8,
            Self::Int8 => TypeId::Int8,
            Self::Int16 => TypeId::Int16,
            Self::UInt16 => TypeId::Uint16,
            Self::Int32 => TypeId::Int32,
            Self::UInt32 => TypeId::Uint32,
            Self::Int64 => TypeId::Int64,
            Self::UInt64 => TypeId::Uint64,
            Self::Float32 => TypeId::Float32,
            Self::Float64 => TypeId::Float64,
            Self::String(None) => TypeId::String,
            Self::WString(None) => TypeId::WString,
            Self::String(Some(_)) => TypeId::BoundedString,
            Self::WString(Some(_)) => TypeId::BoundedWString,
        }
    }

    /// The bound of a bounded string or wstring, else 0.
    pub fn string_capacity(self) -> usize {
        match self {
            Self::String(Some(n)) | Self::WString(Some(n)) => n,
            _ => 0,
        }
    }
}

/// A reference to a message type: `pkg/msg/Name` (or `pkg/srv/…`, `pkg/action/…`
/// for the types rosidl derives from services and actions).
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct TypeRef {
    /// The package.
    pub package: String,
    /// `msg`, `srv` or `action`.
    pub namespace: String,
    /// The type's name, e.g. `Pose` or `AddTwoInts_Request`.
    pub name: String,
}

impl TypeRef {
    /// `pkg/namespace/Name`.
    pub fn full_name(&self) -> String {
        format!("{}/{}/{}", self.package, self.namespace, self.name)
    }
}

/// The element type of a field.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum BaseType {
    /// A primitive.
    Primitive(Primitive),
    /// A nested message.
    Message(TypeRef),
}

/// How a field holds its elements: the one definition, the type
/// description's.
pub use crate::type_id::Container;

/// A field's full type.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct FieldType {
    /// The element type.
    pub base: BaseType,
    /// Single, array or sequence.
    pub container: Container,
}

impl std::fmt::Display for FieldType {
    /// The type as a `.msg` file writes it, e.g. `float64[<=3]`.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match &self.base {
            BaseType::Primitive(p) => write!(f, "{p}")?,
            BaseType::Message(r) => write!(f, "{}/{}", r.package, r.name)?,
        }
        match self.container {
            Container::Single => Ok(()),
            Container::Array(n) => write!(f, "[{n}]"),
            Container::BoundedSequence(n) => write!(f, "[<={n}]"),
            Container::Sequence => write!(f, "[]"),
        }
    }
}

impl std::fmt::Display for Primitive {
    /// The `.msg` spelling, e.g. `string<=8`.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let name = match self {
            Self::Bool => "bool",
            Self::Byte => "byte",
            Self::Char => "char",
            Self::Int8 => "int8",
            Self::UInt8 => "uint8",
            Self::Int16 => "int16",
            Self::UInt16 => "uint16",
            Self::Int32 => "int32",
            Self::UInt32 => "uint32",
            Self::Int64 => "int64",
            Self::UInt64 => "uint64",
            Self::Float32 => "float32",
            Self::Float64 => "float64",
            Self::String(None) => "string",
            Self::WString(None) => "wstring",
            Self::String(Some(n)) => return write!(f, "string<={n}"),
            Self::WString(Some(n)) => return write!(f, "wstring<={n}"),
        };
        f.write_str(name)
    }
}

/// A literal from an interface file (a default value or a constant).
#[derive(Debug, Clone, PartialEq)]
pub enum Value {
    /// `true` / `false`.
    Bool(bool),
    /// An integer, range-checked against its type.
    Int(i128),
    /// A float, as written (normalized so that Rust reads it as a float).
    Float(String),
    /// A string, unquoted and unescaped.
    Str(String),
    /// `[a, b, c]`, for arrays and sequences.
    List(Vec<Value>),
}

/// A field of a message.
#[derive(Debug, Clone, PartialEq)]
pub struct Field {
    /// The field name.
    pub name: String,
    /// Its type.
    pub ty: FieldType,
    /// The default value written after the name, if any.
    pub default: Option<Value>,
    /// Comment lines attached to the field.
    pub doc: Vec<String>,
}

impl Value {
    /// `str()` of the Python value rosidl parses from a default: a scalar as Python
    /// prints it, a list as a tuple.
    pub fn description_default(&self) -> String {
        match self {
            Value::Str(text) => text.clone(),
            Value::List(items) => {
                let mut out = String::from("(");
                for (i, item) in items.iter().enumerate() {
                    if i > 0 {
                        out.push_str(", ");
                    }
                    out.push_str(&item.repr());
                }
                if items.len() == 1 {
                    out.push(',');
                }
                out.push(')');
                out
            }
            scalar => scalar.repr(),
        }
    }

    /// Python's `repr()` of a scalar (inside a tuple, strings are quoted).
    fn repr(&self) -> String {
        match self {
            Value::Bool(true) => "True".into(),
            Value::Bool(false) => "False".into(),
            Value::Int(n) => n.to_string(),
            // The text is Rust's shortest form of the same `f64`: it reads back
            // exactly.
            Value::Float(text) => text.parse().map_or_else(|_| text.clone(), python_float),
            Value::Str(text) => string_repr(text),
            Value::List(_) => self.description_default(),
        }
    }
}

impl Field {
    /// The field as its message's type description states it: its
    /// `type_id`, capacity, string bound and nested type, and its default
    /// value as rosidl writes it.
    pub fn described(&self) -> DescribedFieldBuf {
        let (element, string_capacity, nested_type_name) = match &self.ty.base {
            BaseType::Message(r) => (TypeId::Nested, 0, r.full_name()),
            BaseType::Primitive(p) => (p.element(), p.string_capacity(), String::new()),
        };
        DescribedFieldBuf {
            name: self.name.clone(),
            type_id: type_id(element, self.ty.container.kind()),
            capacity: self.ty.container.capacity() as u64,
            string_capacity: string_capacity as u64,
            nested_type_name,
            default_value: self
                .default
                .as_ref()
                .map(Value::description_default)
                .unwrap_or_default(),
        }
    }
}

/// A constant of a message (`TYPE NAME=value`).
#[derive(Debug, Clone, PartialEq)]
pub struct Constant {
    /// The constant's name (upper case).
    pub name: String,
    /// Its type (a primitive, never a message, array or sequence).
    pub ty: Primitive,
    /// Its value.
    pub value: Value,
    /// Comment lines attached to it.
    pub doc: Vec<String>,
}

/// A message type.
#[derive(Debug, Clone, PartialEq)]
pub struct Message {
    /// Its name, package and namespace.
    pub ty: TypeRef,
    /// The fields, in order (may be empty).
    pub fields: Vec<Field>,
    /// The constants, in order.
    pub constants: Vec<Constant>,
    /// The comment that opens the definition.
    pub doc: Vec<String>,
    /// The interface file's text, lines joined by `\n` with no newline at the end
    /// (as rosidl reports it in `TypeSource`); `None` for a type rosidl derives
    /// from another file (`…_Request`, `…_Goal`, `…_SendGoal`, …).
    pub source: Option<String>,
}

impl Message {
    /// The fields as the type description states them: rosidl gives a
    /// message without fields its one placeholder member
    /// ([`PLACEHOLDER_MEMBER`](crate::PLACEHOLDER_MEMBER)).
    pub fn described_fields(&self) -> Vec<DescribedFieldBuf> {
        if self.fields.is_empty() {
            return vec![DescribedFieldBuf {
                name: crate::PLACEHOLDER_MEMBER.to_owned(),
                type_id: type_id(TypeId::Uint8, crate::ContainerKind::Single),
                ..DescribedFieldBuf::default()
            }];
        }
        self.fields.iter().map(Field::described).collect()
    }
}

/// A service: its request and response, and the event message rosidl adds.
#[derive(Debug, Clone, PartialEq)]
pub struct Service {
    /// `pkg/srv/Name` (or `pkg/action/Name_SendGoal` for an action's service).
    pub ty: TypeRef,
    /// `Name_Request`.
    pub request: Message,
    /// `Name_Response`.
    pub response: Message,
    /// `Name_Event`: `service_msgs/ServiceEventInfo info`, `Name_Request[<=1] request`,
    /// `Name_Response[<=1] response`.
    pub event: Message,
    /// The comment that opens the definition.
    pub doc: Vec<String>,
    /// The interface file's text, lines joined by `\n` with no newline at the end
    /// (as rosidl reports it in `TypeSource`); `None` for a type rosidl derives
    /// from another file (`…_Request`, `…_Goal`, `…_SendGoal`, …).
    pub source: Option<String>,
}

/// An action: its goal, result and feedback, and the services and message
/// rosidl derives from them.
#[derive(Debug, Clone, PartialEq)]
pub struct Action {
    /// `pkg/action/Name`.
    pub ty: TypeRef,
    /// `Name_Goal`.
    pub goal: Message,
    /// `Name_Result`.
    pub result: Message,
    /// `Name_Feedback`.
    pub feedback: Message,
    /// `Name_SendGoal`: request `{goal_id, goal}`, response `{accepted, stamp}`.
    pub send_goal: Service,
    /// `Name_GetResult`: request `{goal_id}`, response `{status, result}`.
    pub get_result: Service,
    /// `Name_FeedbackMessage`: `{goal_id, feedback}`.
    pub feedback_message: Message,
    /// The comment that opens the definition.
    pub doc: Vec<String>,
    /// The interface file's text, lines joined by `\n` with no newline at the end
    /// (as rosidl reports it in `TypeSource`); `None` for a type rosidl derives
    /// from another file (`…_Request`, `…_Goal`, `…_SendGoal`, …).
    pub source: Option<String>,
}

/// One interface package.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Package {
    /// The package name.
    pub name: String,
    /// `msg/*.msg`, sorted by name.
    pub messages: Vec<Message>,
    /// `srv/*.srv`, sorted by name.
    pub services: Vec<Service>,
    /// `action/*.action`, sorted by name.
    pub actions: Vec<Action>,
}

impl Package {
    /// Every message type of the package: its messages, then the request,
    /// response and event of each service, then every type of each action.
    pub fn all_messages(&self) -> impl Iterator<Item = &Message> {
        let services = self
            .services
            .iter()
            .flat_map(|s| [&s.request, &s.response, &s.event]);
        let actions = self.actions.iter().flat_map(|a| {
            [&a.goal, &a.result, &a.feedback]
                .into_iter()
                .chain(
                    [&a.send_goal, &a.get_result]
                        .into_iter()
                        .flat_map(|s| [&s.request, &s.response, &s.event]),
                )
                .chain([&a.feedback_message])
        });
        self.messages.iter().chain(services).chain(actions)
    }

    /// The packages this one references, sorted, itself excluded.
    pub fn dependencies(&self) -> Vec<String> {
        let mut deps: Vec<String> = self
            .all_messages()
            .flat_map(|m| &m.fields)
            .filter_map(|f| match &f.ty.base {
                BaseType::Message(r) if r.package != self.name => Some(r.package.clone()),
                _ => None,
            })
            .collect();
        deps.sort();
        deps.dedup();
        deps
    }
}

/// An interface file of `theirs` whose text differs from the same file in
/// `ours`, though it defines the same types: another release's wording of its
/// comments. The text is as in [`Message::source`].
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RewordedSource {
    /// `pkg/msg/Name`, `pkg/srv/Name` or `pkg/action/Name`.
    pub type_name: String,
    /// `theirs`' text.
    pub text: String,
}

/// Every interface file `theirs` words differently from `ours`, where both
/// have the file. A file that defines its types differently (fields,
/// constants, default values) is an error naming it: such a type needs a
/// definition of its own, not only another text.
pub fn reworded_sources(ours: &Package, theirs: &Package) -> Result<Vec<RewordedSource>, String> {
    fn definition(message: &Message) -> (Vec<Field>, Vec<Constant>) {
        let fields = message
            .fields
            .iter()
            .map(|f| Field {
                doc: Vec::new(),
                ..f.clone()
            })
            .collect();
        let constants = message
            .constants
            .iter()
            .map(|c| Constant {
                doc: Vec::new(),
                ..c.clone()
            })
            .collect();
        (fields, constants)
    }
    // Each file's type name and text, with the messages it defines.
    fn files(package: &Package) -> Vec<(String, Option<&str>, Vec<&Message>)> {
        let messages = package
            .messages
            .iter()
            .map(|m| (m.ty.full_name(), m.source.as_deref(), vec![m]));
        let services = package.services.iter().map(|s| {
            (
                s.ty.full_name(),
                s.source.as_deref(),
                vec![&s.request, &s.response],
            )
        });
        let actions = package.actions.iter().map(|a| {
            (
                a.ty.full_name(),
                a.source.as_deref(),
                vec![&a.goal, &a.result, &a.feedback],
            )
        });
        messages.chain(services).chain(actions).collect()
    }
    let theirs_files = files(theirs);
    let mut out = Vec::new();
    for (name, text, messages) in files(ours) {
        let Some((_, their_text, their_messages)) =
            theirs_files.iter().find(|(n, _, _)| *n == name)
        else {
            continue;
        };
        let same_definition = messages.len() == their_messages.len()
            && messages
                .iter()
                .zip(their_messages)
                .all(|(a, b)| definition(a) == definition(b));
        if !same_definition {
            return Err(format!(
                "{name} is defined differently in {} than here: give that release a type of its own",
                theirs.name
            ));
        }
        if let (Some(text), Some(their_text)) = (text, their_text) {
            if text != *their_text {
                out.push(RewordedSource {
                    type_name: name,
                    text: (*their_text).to_owned(),
                });
            }
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn default_text(value: &Value) -> String {
        value.description_default()
    }

    #[test]
    fn scalars_print_as_python_str() {
        assert_eq!(default_text(&Value::Bool(true)), "True");
        assert_eq!(default_text(&Value::Int(-128)), "-128");
        assert_eq!(default_text(&Value::Float("1.0".into())), "1.0");
        assert_eq!(default_text(&Value::Float("1e16".into())), "1e+16");
        assert_eq!(default_text(&Value::Float("1.5e-7".into())), "1.5e-07");
        assert_eq!(
            default_text(&Value::Str("Hello'world!".into())),
            "Hello'world!"
        );
    }

    #[test]
    fn lists_print_as_python_tuples() {
        let strings = Value::List(vec![
            Value::Str(String::new()),
            Value::Str("max value".into()),
            Value::Str("it's".into()),
            Value::Str("a\\b\"c'".into()),
        ]);
        assert_eq!(
            default_text(&strings),
            r#"('', 'max value', "it's", 'a\\b"c\'')"#
        );
        assert_eq!(default_text(&Value::List(vec![Value::Int(3)])), "(3,)");
        assert_eq!(default_text(&Value::List(Vec::new())), "()");
        assert_eq!(
            default_text(&Value::List(vec![Value::Bool(false), Value::Bool(true)])),
            "(False, True)"
        );
    }
}
