//! Messages as YAML text, character for character what `ros2 topic echo`
//! prints: rosidl_runtime_py's `message_to_yaml` (fields in order, `byte`s as
//! one-character strings, numbers as Python writes them, the same truncation
//! and abbreviations) through PyYAML's emitter (`allow_unicode=True`, unlimited
//! width, block or flow style).
//!
//! - here: a message (or [`YamlValue`]) mapped to the document
//!   rosidl_runtime_py hands PyYAML;
//! - [`scalars`]: numbers as PyYAML writes them, and the strings its resolver
//!   would read back as something else;
//! - [`emitter`]: PyYAML's emitter for those documents (block and flow
//!   mappings and sequences of scalars, with its choice between plain,
//!   single- and double-quoted scalars).

mod emitter;
mod scalars;

use std::borrow::Cow;

use super::numbers::{Number, Numbers};
use super::structs::{Element, FieldDef};
use super::value::{Field, Message, MessageRef, Value};
use crate::describe::{Container, PLACEHOLDER_MEMBER};
use emitter::{List, Node};
use scalars::yaml_float;

/// How [`Message::to_yaml_with`] writes a message: the options of
/// `ros2 topic echo` (and rosidl_runtime_py's `message_to_yaml`).
///
/// ```
/// use shm_cdr::dynamic::{DynamicType, YamlOptions};
/// use shm_cdr::msgs::std_msgs::{Header, Int32MultiArray};
/// use shm_cdr::RosMessage;
///
/// let ty = DynamicType::from_description(&Header::full_description())?;
/// let mut header = ty.default_message();
/// header.set("frame_id", shm_cdr::dynamic::Value::String("map".into()))?;
/// assert_eq!(header.to_yaml(), "stamp:\n  sec: 0\n  nanosec: 0\nframe_id: map\n");
///
/// let array = Int32MultiArray { data: vec![1, 2, 3], ..Default::default() };
/// let ty = DynamicType::from_description(&Int32MultiArray::full_description())?;
/// let bytes = shm_cdr::to_vec(&array)?;
/// let message = ty.decode(&bytes)?;
/// assert_eq!(
///     message.to_yaml_with(&YamlOptions::echo().flow_style(true)),
///     "layout:\n  dim: []\n  data_offset: 0\ndata: [1, 2, 3]\n"
/// );
/// assert_eq!(
///     message.to_yaml_with(&YamlOptions::echo().truncate_length(Some(2))),
///     "layout:\n  dim: []\n  data_offset: 0\ndata:\n- 1\n- 2\n- '...'\n"
/// );
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[non_exhaustive]
pub struct YamlOptions {
    /// Strings longer than this many characters, and arrays and sequences of
    /// more elements, are cut to this length and followed by `...`
    /// (`--truncate-length`; `None`: `--full-length`).
    pub truncate_length: Option<usize>,
    /// Arrays and sequences are replaced by their type and length
    /// (`--no-arr`).
    pub no_arr: bool,
    /// Strings are replaced by their length (`--no-str`).
    pub no_str: bool,
    /// Arrays and sequences, and what they hold, on one line in YAML's flow
    /// style (`--flow-style`); fields stay one per line.
    pub flow_style: bool,
}

impl YamlOptions {
    /// Every value in full, in block style: `message_to_yaml`'s defaults.
    pub const fn full() -> Self {
        Self {
            truncate_length: None,
            no_arr: false,
            no_str: false,
            flow_style: false,
        }
    }

    /// `ros2 topic echo`'s defaults: strings, arrays and sequences cut after
    /// 128 characters or elements.
    pub const fn echo() -> Self {
        Self {
            truncate_length: Some(128),
            ..Self::full()
        }
    }

    /// Cut strings, arrays and sequences after `length` characters or
    /// elements (`None`: never).
    pub const fn truncate_length(mut self, length: Option<usize>) -> Self {
        self.truncate_length = length;
        self
    }

    /// Replace arrays and sequences by their type and length.
    pub const fn no_arr(mut self, on: bool) -> Self {
        self.no_arr = on;
        self
    }

    /// Replace strings by their length.
    pub const fn no_str(mut self, on: bool) -> Self {
        self.no_str = on;
        self
    }

    /// Write arrays and sequences in flow style, on one line.
    pub const fn flow_style(mut self, on: bool) -> Self {
        self.flow_style = on;
        self
    }
}

impl Message<'_> {
    /// The message as YAML, every value in full, as rosidl_runtime_py's
    /// `message_to_yaml` writes it (and `ros2 topic echo --full-length`
    /// prints it, before its `---` line).
    pub fn to_yaml(&self) -> String {
        self.to_yaml_with(&YamlOptions::full())
    }

    /// The message as YAML with `ros2 topic echo`'s options.
    pub fn to_yaml_with(&self, options: &YamlOptions) -> String {
        emitter::document(
            &message_node(self.as_message_ref(), options),
            options.flow_style,
        )
    }
}

/// Plain data to write as YAML the way PyYAML's `yaml.dump(data,
/// default_flow_style=False)` writes it: what ROS 2's tools print for data
/// that is not a message (`ros2 param dump`, say). Mappings keep the order
/// given (`yaml.dump` sorts them: sort first to match it).
///
/// ```
/// use shm_cdr::dynamic::YamlValue;
///
/// let doc = YamlValue::Map(vec![(
///     "/talker".into(),
///     YamlValue::Map(vec![
///         ("gain".into(), YamlValue::Float(0.5)),
///         ("names".into(), YamlValue::Seq(vec![YamlValue::Str("yes".into())])),
///     ]),
/// )]);
/// assert_eq!(doc.to_yaml(), "/talker:\n  gain: 0.5\n  names:\n  - 'yes'\n");
/// ```
#[derive(Debug, Clone, PartialEq)]
pub enum YamlValue {
    /// `true`, `false`.
    Bool(bool),
    /// An integer.
    Int(i64),
    /// A float, in Python's `repr` (`.inf`, `.nan` as YAML writes them).
    Float(f64),
    /// A string, quoted where YAML would read it as something else.
    Str(String),
    /// A sequence, block style (flow style when empty).
    Seq(Vec<YamlValue>),
    /// A mapping, block style (flow style when empty).
    Map(Vec<(String, YamlValue)>),
}

impl YamlValue {
    /// The YAML text, ending with a line break.
    pub fn to_yaml(&self) -> String {
        emitter::document(&self.node(), false)
    }

    fn node(&self) -> Node<'_> {
        match self {
            Self::Bool(b) => bool_node(*b),
            Self::Int(i) => Node::Plain(i.to_string()),
            Self::Float(x) => float_node(*x),
            Self::Str(s) => Node::Str(Cow::Borrowed(s)),
            Self::Seq(items) => Node::Seq(items.iter().map(Self::node).collect()),
            Self::Map(entries) => Node::Map(
                entries
                    .iter()
                    .map(|(k, v)| (k.as_str(), v.node()))
                    .collect(),
            ),
        }
    }
}

fn message_node<'m>(message: MessageRef<'m, '_>, options: &YamlOptions) -> Node<'m> {
    let def = message.def();
    let placeholder = def.fields.len() == 1 && def.fields[0].name == PLACEHOLDER_MEMBER; // rclpy leaves it out
    let mut entries = Vec::with_capacity(def.fields.len());
    if !placeholder {
        for (i, field) in def.fields.iter().enumerate() {
            let node = match message.field(i) {
                Some(Field::Message(nested)) => message_node(nested, options),
                Some(Field::Value(value)) => field_node(message, i, field, value, options),
                None => continue,
            };
            entries.push((field.name.as_str(), node));
        }
    }
    Node::Map(entries)
}

fn field_node<'m>(
    message: MessageRef<'m, '_>,
    i: usize,
    field: &FieldDef,
    value: &'m Value<'_>,
    options: &YamlOptions,
) -> Node<'m> {
    if options.no_arr && field.container != Container::Single {
        return Node::Str(Cow::Owned(abbreviate(message, field, message.wire_len(i))));
    }
    value_node(field.element, value, options)
}

/// `--no-arr`'s text: rosidl_parser's name of the element type, with the
/// array's size or the sequence's bound and length.
fn abbreviate(message: MessageRef<'_, '_>, field: &FieldDef, len: Option<usize>) -> String {
    let element = match field.element {
        Element::Bool => "boolean",
        Element::Byte => "octet",
        Element::Char => "char",
        Element::I8 => "int8",
        Element::U8 => "uint8",
        Element::I16 => "int16",
        Element::U16 => "uint16",
        Element::I32 => "int32",
        Element::U32 => "uint32",
        Element::I64 => "int64",
        Element::U64 => "uint64",
        Element::F32 => "float",
        Element::F64 => "double",
        Element::String(_) => "string",
        Element::WString(_) => "wstring",
        Element::Message(i) => message
            .ty()
            .structs()
            .get(i)
            .map_or("unknown", |s| s.name.as_str()),
    };
    let len = len.unwrap_or(0);
    match field.container {
        Container::Array(n) => format!("<array type: {element}[{n}]>"),
        Container::BoundedSequence(n) => {
            format!("<sequence type: {element}[{n}], length: {len}>")
        }
        Container::Sequence | Container::Single => {
            format!("<sequence type: {element}, length: {len}>")
        }
    }
}

fn value_node<'m>(element: Element, value: &'m Value<'_>, options: &YamlOptions) -> Node<'m> {
    let byte_text = matches!(element, Element::Byte | Element::Char);
    // Lists make their items as they are written: they keep the options.
    let owned = *options;
    match value {
        Value::Bool(v) => bool_node(*v),
        Value::U8(v) if byte_text => byte_node(*v, options),
        Value::U8(v) => Node::Plain(v.to_string()),
        Value::I8(v) => Node::Plain(v.to_string()),
        Value::I16(v) => Node::Plain(v.to_string()),
        Value::U16(v) => Node::Plain(v.to_string()),
        Value::I32(v) => Node::Plain(v.to_string()),
        Value::U32(v) => Node::Plain(v.to_string()),
        Value::I64(v) => Node::Plain(v.to_string()),
        Value::U64(v) => Node::Plain(v.to_string()),
        Value::F32(v) => float_node(f64::from(*v)),
        Value::F64(v) => float_node(*v),
        Value::String(s) => string_node(s, options),
        Value::WString(s) => string_node(s, options),
        Value::Message(m) => message_node(m.as_message_ref(), options),
        Value::Bools(v) => list(v, options, |b| bool_node(*b)),
        Value::U8s(v) if byte_text => list(v, options, move |b| byte_node(*b, &owned)),
        Value::U8s(v) => list(v, options, |n| Node::Plain(n.to_string())),
        Value::I8s(v) => list(v, options, |n| Node::Plain(n.to_string())),
        Value::I16s(v) => numbers(v, options, |n| Node::Plain(n.to_string())),
        Value::U16s(v) => numbers(v, options, |n| Node::Plain(n.to_string())),
        Value::I32s(v) => numbers(v, options, |n| Node::Plain(n.to_string())),
        Value::U32s(v) => numbers(v, options, |n| Node::Plain(n.to_string())),
        Value::I64s(v) => numbers(v, options, |n| Node::Plain(n.to_string())),
        Value::U64s(v) => numbers(v, options, |n| Node::Plain(n.to_string())),
        Value::F32s(v) => numbers(v, options, |x| float_node(f64::from(x))),
        Value::F64s(v) => numbers(v, options, float_node),
        Value::Strings(v) => list(v, options, move |s| string_node(s, &owned)),
        Value::WStrings(v) => list(v, options, move |s| string_node(s, &owned)),
        Value::Messages(v) => list_of(v.len(), options, move |i| {
            v.get(i)
                .map_or(Node::Seq(Vec::new()), |m| message_node(m, &owned))
        }),
    }
}

fn list<'m, T>(
    items: &'m [T],
    options: &YamlOptions,
    node: impl Fn(&'m T) -> Node<'m> + 'm,
) -> Node<'m> {
    list_of(items.len(), options, move |i| {
        items.get(i).map_or(Node::Seq(Vec::new()), &node)
    })
}

/// [`list`] of numbers, each read from where it lies as it is written.
fn numbers<'m, T: Number>(
    items: &'m Numbers<'_, T>,
    options: &YamlOptions,
    node: impl Fn(T) -> Node<'m> + 'm,
) -> Node<'m> {
    list_of(items.len(), options, move |i| {
        items.get(i).map_or(Node::Seq(Vec::new()), &node)
    })
}

/// A list of `len` items, item `i` made by `item(i)` as it is written.
fn list_of<'m>(
    len: usize,
    options: &YamlOptions,
    item: impl Fn(usize) -> Node<'m> + 'm,
) -> Node<'m> {
    let shown = match options.truncate_length {
        Some(n) => len.min(n),
        None => len,
    };
    Node::List(List {
        len: shown,
        cut: shown < len,
        item: Box::new(item),
    })
}

fn bool_node<'m>(v: bool) -> Node<'m> {
    Node::Plain(if v { "true" } else { "false" }.to_owned())
}

/// rclpy reads a `byte` as a one-byte `bytes`, which rosidl_runtime_py turns
/// into the one-character string of that code point.
fn byte_node<'m>(b: u8, options: &YamlOptions) -> Node<'m> {
    if options.truncate_length == Some(0) {
        return Node::Str(Cow::Borrowed("..."));
    }
    Node::Str(Cow::Owned(char::from(b).to_string()))
}

fn string_node<'m>(s: &'m str, options: &YamlOptions) -> Node<'m> {
    if options.no_str {
        return Node::Str(Cow::Owned(format!(
            "<string length: <{}>>",
            s.chars().count()
        )));
    }
    if let Some(n) = options.truncate_length {
        if let Some((cut, _)) = s.char_indices().nth(n) {
            return Node::Str(Cow::Owned(format!("{}...", &s[..cut])));
        }
    }
    Node::Str(Cow::Borrowed(s))
}

fn float_node<'m>(x: f64) -> Node<'m> {
    Node::Plain(yaml_float(x))
}
