//! Messages as YAML text, character for character what `ros2 topic echo`
//! prints: rosidl_runtime_py's `message_to_yaml` (fields in order, `byte`s as
//! one-character strings, numbers as Python writes them, the same truncation
//! and abbreviations) through PyYAML's emitter (`allow_unicode=True`, unlimited
//! width, block or flow style). The emitter below follows PyYAML's rules for
//! the documents a message makes: block and flow mappings and sequences of
//! scalars, with PyYAML's choice between plain, single- and double-quoted
//! scalars.

use std::borrow::Cow;
use std::fmt::{self, Write as _};

use super::numbers::{Number, Numbers};
use super::structs::{Element, FieldDef};
use super::value::{Field, Message, MessageRef, Value};
use crate::describe::{Container, PLACEHOLDER_MEMBER};
use shm_interface::python::python_float;

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
        let tree = message_node(self.as_message_ref(), options);
        let mut emitter = Emitter::new(options.flow_style);
        emitter.document(&tree);
        emitter.out
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
        let tree = self.node();
        let mut emitter = Emitter::new(false);
        emitter.document(&tree);
        emitter.out
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

/// What rosidl_runtime_py turns a message into before PyYAML writes it.
#[derive(Debug)]
enum Node<'m> {
    /// A string: quoted where PyYAML would read it back as something else.
    Str(Cow<'m, str>),
    /// A number or boolean, in the form PyYAML writes it.
    Plain(String),
    Seq(Vec<Node<'m>>),
    /// A message's array or sequence: its items are made one at a time as
    /// they are written, so that writing a message takes memory for its
    /// depth, not for its elements.
    List(List<'m>),
    Map(Vec<(&'m str, Node<'m>)>),
}

struct List<'m> {
    /// Items shown (`...` follows when some are cut).
    len: usize,
    cut: bool,
    item: Box<dyn Fn(usize) -> Node<'m> + 'm>,
}

impl fmt::Debug for List<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("List")
            .field("len", &self.len)
            .field("cut", &self.cut)
            .finish_non_exhaustive()
    }
}

impl<'m> List<'m> {
    /// How many items are written, `...` included.
    fn written(&self) -> usize {
        self.len + usize::from(self.cut)
    }

    fn node(&self, i: usize) -> Node<'m> {
        if i < self.len {
            (self.item)(i)
        } else {
            Node::Str(Cow::Borrowed("..."))
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

/// A float as PyYAML writes it: Python's `repr`, lower case, with `.0` added
/// to a mantissa without a point, `.inf`, `-.inf` and `.nan`.
pub(crate) fn yaml_float(x: f64) -> String {
    if x.is_nan() {
        return ".nan".into();
    }
    if x.is_infinite() {
        return if x > 0.0 { ".inf" } else { "-.inf" }.into();
    }
    // Finite here: Python's repr of it.
    let mut out = python_float(x);
    if !out.contains('.') {
        if let Some(e) = out.find('e') {
            out.insert_str(e, ".0");
        }
    }
    out
}

/// Whether PyYAML's resolver would read `s`, written plain, as something
/// other than a string (a bool, int, float, null, timestamp, merge or value
/// key, by YAML 1.1's patterns): such strings are quoted.
fn resolves_to_non_string(s: &str) -> bool {
    let b = s.as_bytes();
    is_yaml11_bool(s)
        || is_yaml11_int(b)
        || is_yaml11_float(b)
        || matches!(s, "~" | "null" | "Null" | "NULL" | "" | "<<" | "=")
        || is_yaml11_timestamp(b)
}

fn is_yaml11_bool(s: &str) -> bool {
    matches!(
        s,
        "yes"
            | "Yes"
            | "YES"
            | "no"
            | "No"
            | "NO"
            | "true"
            | "True"
            | "TRUE"
            | "false"
            | "False"
            | "FALSE"
            | "on"
            | "On"
            | "ON"
            | "off"
            | "Off"
            | "OFF"
    )
}

/// The number of leading bytes of `b` from `from` on that satisfy `f`.
fn run(b: &[u8], from: usize, f: impl Fn(u8) -> bool) -> usize {
    b.get(from..)
        .map_or(0, |rest| rest.iter().take_while(|c| f(**c)).count())
}

fn skip_sign(b: &[u8]) -> usize {
    usize::from(matches!(b.first(), Some(b'-' | b'+')))
}

fn digit_or_underscore(c: u8) -> bool {
    c.is_ascii_digit() || c == b'_'
}

/// `(:[0-5]?[0-9])+` from `i`: the index after it, if there is one.
fn sexagesimal(b: &[u8], mut i: usize) -> Option<usize> {
    let mut groups = 0;
    while b.get(i) == Some(&b':') {
        let n = run(b, i + 1, |c| c.is_ascii_digit());
        let ok = match n {
            1 => true,
            2 => b[i + 1] <= b'5',
            _ => false,
        };
        if !ok {
            break;
        }
        i += 1 + n;
        groups += 1;
    }
    (groups > 0).then_some(i)
}

fn is_yaml11_int(b: &[u8]) -> bool {
    let s = skip_sign(b);
    let body = &b[s..];
    if let Some(rest) = body.strip_prefix(b"0b") {
        return !rest.is_empty() && rest.iter().all(|c| matches!(c, b'0' | b'1' | b'_'));
    }
    if let Some(rest) = body.strip_prefix(b"0x") {
        return !rest.is_empty() && rest.iter().all(|c| c.is_ascii_hexdigit() || *c == b'_');
    }
    if body == b"0" {
        return true;
    }
    if let Some(rest) = body.strip_prefix(b"0") {
        return !rest.is_empty() && rest.iter().all(|c| matches!(c, b'0'..=b'7' | b'_'));
    }
    match body.first() {
        Some(b'1'..=b'9') => {
            let end = 1 + run(body, 1, digit_or_underscore);
            end == body.len() || sexagesimal(body, end) == Some(body.len())
        }
        _ => false,
    }
}

fn is_yaml11_float(b: &[u8]) -> bool {
    let s = skip_sign(b);
    let body = &b[s..];
    if matches!(body, b".inf" | b".Inf" | b".INF") {
        return true;
    }
    if s == 0 && matches!(body, b".nan" | b".NaN" | b".NAN") {
        return true;
    }
    // `\.[0-9][0-9_]*` exponent?, without a sign.
    if s == 0 && body.first() == Some(&b'.') {
        if !body.get(1).is_some_and(u8::is_ascii_digit) {
            return false;
        }
        let end = 2 + run(body, 2, digit_or_underscore);
        return exponent_to_end(body, end);
    }
    if !body.first().is_some_and(u8::is_ascii_digit) {
        return false;
    }
    let int_end = 1 + run(body, 1, digit_or_underscore);
    // `[0-9][0-9_]*\.[0-9_]*` exponent?
    if body.get(int_end) == Some(&b'.') {
        let end = int_end + 1 + run(body, int_end + 1, digit_or_underscore);
        if exponent_to_end(body, end) {
            return true;
        }
    }
    // `[0-9][0-9_]*(:[0-5]?[0-9])+\.[0-9_]*`
    if let Some(end) = sexagesimal(body, int_end) {
        if body.get(end) == Some(&b'.') {
            let rest = end + 1 + run(body, end + 1, digit_or_underscore);
            return rest == body.len();
        }
    }
    false
}

/// Whether `b[i..]` is empty or `[eE][-+][0-9]+`.
fn exponent_to_end(b: &[u8], i: usize) -> bool {
    if i == b.len() {
        return true;
    }
    matches!(b.get(i), Some(b'e' | b'E')) && matches!(b.get(i + 1), Some(b'-' | b'+')) && {
        let n = run(b, i + 2, |c| c.is_ascii_digit());
        n > 0 && i + 2 + n == b.len()
    }
}

fn is_yaml11_timestamp(b: &[u8]) -> bool {
    let digits = |from: usize, n: usize| {
        b.get(from..from + n)
            .is_some_and(|d| d.iter().all(u8::is_ascii_digit))
    };
    if !(digits(0, 4) && b.get(4) == Some(&b'-')) {
        return false;
    }
    // `YYYY-MM-DD` alone.
    if b.len() == 10 && digits(5, 2) && b.get(7) == Some(&b'-') && digits(8, 2) {
        return true;
    }
    // `YYYY-M?M-D?D(T|t|[ \t]+)H?H:MM:SS(.f*)?([ \t]*(Z|[-+]H?H(:MM)?))?`
    let mut i = 5;
    let one_or_two = |i: usize| run(b, i, |c| c.is_ascii_digit()).min(2);
    let n = one_or_two(i);
    if n == 0 || b.get(i + n) != Some(&b'-') {
        return false;
    }
    i += n + 1;
    let n = one_or_two(i);
    if n == 0 {
        return false;
    }
    i += n;
    match b.get(i) {
        Some(b'T' | b't') => i += 1,
        Some(b' ' | b'\t') => i += run(b, i, |c| c == b' ' || c == b'\t'),
        _ => return false,
    }
    let n = one_or_two(i);
    if n == 0 {
        return false;
    }
    i += n;
    for _ in 0..2 {
        if b.get(i) != Some(&b':') || !digits(i + 1, 2) {
            return false;
        }
        i += 3;
    }
    if b.get(i) == Some(&b'.') {
        i += 1 + run(b, i + 1, |c| c.is_ascii_digit());
    }
    if i == b.len() {
        return true;
    }
    i += run(b, i, |c| c == b' ' || c == b'\t');
    match b.get(i) {
        Some(b'Z') => i + 1 == b.len(),
        Some(b'-' | b'+') => {
            let n = one_or_two(i + 1);
            if n == 0 {
                return false;
            }
            let j = i + 1 + n;
            j == b.len() || (b.get(j) == Some(&b':') && digits(j + 1, 2) && j + 3 == b.len())
        }
        _ => false,
    }
}

/// What PyYAML's `analyze_scalar` finds in a scalar: which styles can write it.
struct Analysis {
    empty: bool,
    multiline: bool,
    allow_flow_plain: bool,
    allow_block_plain: bool,
    allow_single_quoted: bool,
}

fn is_break(c: char) -> bool {
    matches!(c, '\n' | '\u{85}' | '\u{2028}' | '\u{2029}')
}

fn is_space_or_break(c: char) -> bool {
    matches!(c, '\0' | ' ' | '\t' | '\r') || is_break(c)
}

/// Printable with `allow_unicode`: written as itself in any style.
fn is_printable_unicode(c: char) -> bool {
    c == '\u{85}'
        || ('\u{A0}'..='\u{D7FF}').contains(&c)
        || ('\u{E000}'..='\u{FFFD}').contains(&c)
        || ('\u{10000}'..'\u{10FFFF}').contains(&c)
}

fn analyze(scalar: &str) -> Analysis {
    if scalar.is_empty() {
        return Analysis {
            empty: true,
            multiline: false,
            allow_flow_plain: false,
            allow_block_plain: true,
            allow_single_quoted: true,
        };
    }
    let chars: Vec<char> = scalar.chars().collect();
    let mut block_indicators = false;
    let mut flow_indicators = false;
    let mut line_breaks = false;
    let mut special = false;
    let (mut leading_space, mut leading_break) = (false, false);
    let (mut trailing_space, mut trailing_break) = (false, false);
    let (mut break_space, mut space_break) = (false, false);
    if scalar.starts_with("---") || scalar.starts_with("...") {
        block_indicators = true;
        flow_indicators = true;
    }
    let mut preceded_by_whitespace = true;
    let mut followed_by_whitespace = chars.len() == 1 || is_space_or_break(chars[1]);
    let (mut previous_space, mut previous_break) = (false, false);
    let last = chars.len() - 1;
    for (index, &ch) in chars.iter().enumerate() {
        if index == 0 {
            if "#,[]{}&*!|>'\"%@`".contains(ch) {
                flow_indicators = true;
                block_indicators = true;
            }
            if ch == '?' || ch == ':' {
                flow_indicators = true;
                if followed_by_whitespace {
                    block_indicators = true;
                }
            }
            if ch == '-' && followed_by_whitespace {
                flow_indicators = true;
                block_indicators = true;
            }
        } else {
            if ",?[]{}".contains(ch) {
                flow_indicators = true;
            }
            if ch == ':' {
                flow_indicators = true;
                if followed_by_whitespace {
                    block_indicators = true;
                }
            }
            if ch == '#' && preceded_by_whitespace {
                flow_indicators = true;
                block_indicators = true;
            }
        }
        if is_break(ch) {
            line_breaks = true;
        }
        let printable = ch == '\n'
            || (' '..='~').contains(&ch)
            || (is_printable_unicode(ch) && ch != '\u{FEFF}');
        if !printable {
            special = true;
        }
        if ch == ' ' {
            if index == 0 {
                leading_space = true;
            }
            if index == last {
                trailing_space = true;
            }
            if previous_break {
                break_space = true;
            }
            previous_space = true;
            previous_break = false;
        } else if is_break(ch) {
            if index == 0 {
                leading_break = true;
            }
            if index == last {
                trailing_break = true;
            }
            if previous_space {
                space_break = true;
            }
            previous_space = false;
            previous_break = true;
        } else {
            previous_space = false;
            previous_break = false;
        }
        preceded_by_whitespace = is_space_or_break(ch);
        followed_by_whitespace = chars.get(index + 2).is_none_or(|&c| is_space_or_break(c));
    }
    let mut allow_flow_plain = true;
    let mut allow_block_plain = true;
    let mut allow_single_quoted = true;
    if leading_space || leading_break || trailing_space || trailing_break {
        allow_flow_plain = false;
        allow_block_plain = false;
    }
    if break_space {
        allow_flow_plain = false;
        allow_block_plain = false;
        allow_single_quoted = false;
    }
    if space_break || special {
        allow_flow_plain = false;
        allow_block_plain = false;
        allow_single_quoted = false;
    }
    if line_breaks {
        allow_flow_plain = false;
        allow_block_plain = false;
    }
    if flow_indicators {
        allow_flow_plain = false;
    }
    if block_indicators {
        allow_block_plain = false;
    }
    Analysis {
        empty: false,
        multiline: line_breaks,
        allow_flow_plain,
        allow_block_plain,
        allow_single_quoted,
    }
}

#[derive(Clone, Copy, PartialEq, Eq)]
enum Style {
    Plain,
    Single,
    Double,
}

/// Where a node is written (PyYAML's emitter contexts).
#[derive(Clone, Copy, Default)]
struct Context {
    mapping: bool,
    simple_key: bool,
}

/// PyYAML's emitter state for the documents messages make.
struct Emitter {
    out: String,
    flow_style: bool,
    column: usize,
    indent: Option<usize>,
    indents: Vec<Option<usize>>,
    flow_level: usize,
    whitespace: bool,
    indention: bool,
}

const BEST_INDENT: usize = 2;

impl Emitter {
    fn new(flow_style: bool) -> Self {
        Self {
            out: String::new(),
            flow_style,
            column: 0,
            indent: None,
            indents: Vec::new(),
            flow_level: 0,
            whitespace: true,
            indention: true,
        }
    }

    fn document(&mut self, root: &Node<'_>) {
        self.node(root, Context::default());
        // The document's end: a line break.
        self.indent = None;
        self.write_indent();
    }

    fn increase_indent(&mut self, flow: bool, indentless: bool) {
        self.indents.push(self.indent);
        self.indent = match self.indent {
            None if flow => Some(BEST_INDENT),
            None => Some(0),
            Some(i) if !indentless => Some(i + BEST_INDENT),
            Some(i) => Some(i),
        };
    }

    fn pop_indent(&mut self) {
        self.indent = self.indents.pop().flatten();
    }

    fn write_indicator(
        &mut self,
        indicator: &str,
        need_whitespace: bool,
        whitespace: bool,
        indention: bool,
    ) {
        if !self.whitespace && need_whitespace {
            self.out.push(' ');
            self.column += 1;
        }
        self.out.push_str(indicator);
        self.column += indicator.chars().count();
        self.whitespace = whitespace;
        self.indention = self.indention && indention;
    }

    fn write_indent(&mut self) {
        let indent = self.indent.unwrap_or(0);
        if !self.indention || self.column > indent || (self.column == indent && !self.whitespace) {
            self.write_line_break(None);
        }
        if self.column < indent {
            self.whitespace = true;
            for _ in self.column..indent {
                self.out.push(' ');
            }
            self.column = indent;
        }
    }

    fn write_line_break(&mut self, data: Option<char>) {
        self.out.push(data.unwrap_or('\n'));
        self.whitespace = true;
        self.indention = true;
        self.column = 0;
    }

    fn write_text(&mut self, text: &str) {
        self.out.push_str(text);
        self.column += text.chars().count();
    }

    fn node(&mut self, node: &Node<'_>, context: Context) {
        match node {
            Node::Str(s) => self.scalar(s, !resolves_to_non_string(s), context),
            Node::Plain(s) => self.scalar(s, true, context),
            Node::Seq(items) => {
                let each = |e: &mut Self, i: usize| {
                    if let Some(item) = items.get(i) {
                        e.node(item, Context::default());
                    }
                };
                if self.flow_level > 0 || self.flow_style || items.is_empty() {
                    self.flow_sequence(items.len(), each);
                } else {
                    self.block_sequence(items.len(), context, each);
                }
            }
            Node::List(list) => {
                let each = |e: &mut Self, i: usize| e.node(&list.node(i), Context::default());
                let n = list.written();
                if self.flow_level > 0 || self.flow_style || n == 0 {
                    self.flow_sequence(n, each);
                } else {
                    self.block_sequence(n, context, each);
                }
            }
            Node::Map(entries) => {
                // rosidl_runtime_py makes its mapping nodes itself, with no
                // style: `flow_style` reaches only the sequences.
                if self.flow_level > 0 || entries.is_empty() {
                    self.flow_mapping(entries);
                } else {
                    self.block_mapping(entries);
                }
            }
        }
    }

    fn flow_sequence(&mut self, len: usize, mut item: impl FnMut(&mut Self, usize)) {
        self.write_indicator("[", true, true, false);
        self.flow_level += 1;
        self.increase_indent(true, false);
        for i in 0..len {
            if i > 0 {
                self.write_indicator(",", false, false, false);
            }
            item(self, i);
        }
        self.pop_indent();
        self.flow_level -= 1;
        self.write_indicator("]", false, false, false);
    }

    fn flow_mapping(&mut self, entries: &[(&str, Node<'_>)]) {
        self.write_indicator("{", true, true, false);
        self.flow_level += 1;
        self.increase_indent(true, false);
        for (i, (key, value)) in entries.iter().enumerate() {
            if i > 0 {
                self.write_indicator(",", false, false, false);
            }
            if is_simple_key(key) {
                self.key(key, true);
                self.write_indicator(":", false, false, false);
            } else {
                self.write_indicator("?", true, false, false);
                self.key(key, false);
                self.write_indicator(":", true, false, false);
            }
            self.node(
                value,
                Context {
                    mapping: true,
                    simple_key: false,
                },
            );
        }
        self.pop_indent();
        self.flow_level -= 1;
        self.write_indicator("}", false, false, false);
    }

    fn block_sequence(
        &mut self,
        len: usize,
        context: Context,
        mut item: impl FnMut(&mut Self, usize),
    ) {
        let indentless = context.mapping && !self.indention;
        self.increase_indent(false, indentless);
        for i in 0..len {
            self.write_indent();
            self.write_indicator("-", true, false, true);
            item(self, i);
        }
        self.pop_indent();
    }

    fn block_mapping(&mut self, entries: &[(&str, Node<'_>)]) {
        self.increase_indent(false, false);
        for (key, value) in entries {
            self.write_indent();
            if is_simple_key(key) {
                self.key(key, true);
                self.write_indicator(":", false, false, false);
            } else {
                self.write_indicator("?", true, false, true);
                self.key(key, false);
                self.write_indent();
                self.write_indicator(":", true, false, true);
            }
            self.node(
                value,
                Context {
                    mapping: true,
                    simple_key: false,
                },
            );
        }
        self.pop_indent();
    }

    fn key(&mut self, key: &str, simple: bool) {
        self.scalar(
            key,
            !resolves_to_non_string(key),
            Context {
                mapping: true,
                simple_key: simple,
            },
        );
    }

    fn scalar(&mut self, text: &str, implicit: bool, context: Context) {
        self.increase_indent(true, false);
        let analysis = analyze(text);
        let style = self.choose_style(&analysis, implicit, context);
        match style {
            Style::Plain => self.write_plain(text),
            Style::Single => self.write_single_quoted(text),
            Style::Double => self.write_double_quoted(text),
        }
        self.pop_indent();
    }

    fn choose_style(&self, analysis: &Analysis, implicit: bool, context: Context) -> Style {
        let awkward_key = context.simple_key && (analysis.empty || analysis.multiline);
        let plain_here = if self.flow_level > 0 {
            analysis.allow_flow_plain
        } else {
            analysis.allow_block_plain
        };
        if implicit && !awkward_key && plain_here {
            return Style::Plain;
        }
        if analysis.allow_single_quoted && !(context.simple_key && analysis.multiline) {
            return Style::Single;
        }
        Style::Double
    }

    fn write_plain(&mut self, text: &str) {
        if text.is_empty() {
            return;
        }
        if !self.whitespace {
            self.out.push(' ');
            self.column += 1;
        }
        self.whitespace = false;
        self.indention = false;
        // Plain scalars never hold line breaks here, and lines are never
        // folded (unlimited width): the text as it is.
        self.write_text(text);
    }

    fn write_single_quoted(&mut self, text: &str) {
        self.write_indicator("'", true, false, false);
        let chars: Vec<char> = text.chars().collect();
        let (mut spaces, mut breaks) = (false, false);
        let mut start = 0;
        let mut end = 0;
        while end <= chars.len() {
            let ch = chars.get(end).copied();
            if spaces {
                if ch != Some(' ') {
                    let run: String = chars[start..end].iter().collect();
                    self.write_text(&run);
                    start = end;
                }
            } else if breaks {
                if ch.is_none_or(|c| !is_break(c)) {
                    if chars[start] == '\n' {
                        self.write_line_break(None);
                    }
                    for &br in &chars[start..end] {
                        self.write_line_break(Some(br));
                    }
                    self.write_indent();
                    start = end;
                }
            } else if ch.is_none_or(|c| c == ' ' || is_break(c) || c == '\'') && start < end {
                let run: String = chars[start..end].iter().collect();
                self.write_text(&run);
                start = end;
            }
            if ch == Some('\'') {
                self.write_text("''");
                start = end + 1;
            }
            if let Some(c) = ch {
                spaces = c == ' ';
                breaks = is_break(c);
            }
            end += 1;
        }
        self.write_indicator("'", false, false, false);
    }

    fn write_double_quoted(&mut self, text: &str) {
        self.write_indicator("\"", true, false, false);
        let mut run = String::new();
        for ch in text.chars() {
            let plain = (' '..='~').contains(&ch)
                || ('\u{A0}'..='\u{D7FF}').contains(&ch)
                || ('\u{E000}'..='\u{FFFD}').contains(&ch);
            if plain
                && !matches!(
                    ch,
                    '"' | '\\' | '\u{85}' | '\u{2028}' | '\u{2029}' | '\u{FEFF}'
                )
            {
                run.push(ch);
                continue;
            }
            let escaped = match ch {
                '\0' => "\\0".to_owned(),
                '\u{07}' => "\\a".to_owned(),
                '\u{08}' => "\\b".to_owned(),
                '\t' => "\\t".to_owned(),
                '\n' => "\\n".to_owned(),
                '\u{0B}' => "\\v".to_owned(),
                '\u{0C}' => "\\f".to_owned(),
                '\r' => "\\r".to_owned(),
                '\u{1B}' => "\\e".to_owned(),
                '"' => "\\\"".to_owned(),
                '\\' => "\\\\".to_owned(),
                '\u{85}' => "\\N".to_owned(),
                '\u{A0}' => "\\_".to_owned(),
                '\u{2028}' => "\\L".to_owned(),
                '\u{2029}' => "\\P".to_owned(),
                c if u32::from(c) <= 0xFF => format!("\\x{:02X}", u32::from(c)),
                c if u32::from(c) <= 0xFFFF => format!("\\u{:04X}", u32::from(c)),
                c => format!("\\U{:08X}", u32::from(c)),
            };
            run.push_str(&escaped);
        }
        let _ = write!(self.out, "{run}");
        self.column += run.chars().count();
        self.write_indicator("\"", false, false, false);
    }
}

/// PyYAML's `check_simple_key` for a string key.
fn is_simple_key(key: &str) -> bool {
    let analysis = analyze(key);
    key.chars().count() < 128 && !analysis.empty && !analysis.multiline
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    // The ties below are written as the exact binary values they are.
    #[allow(clippy::excessive_precision)]
    fn floats_are_written_as_python_and_pyyaml_write_them() {
        for (x, text) in [
            (0.0, "0.0"),
            (-0.0, "-0.0"),
            (1.5, "1.5"),
            (100.0, "100.0"),
            (0.0001, "0.0001"),
            (0.00001, "1.0e-05"),
            (1e15, "1000000000000000.0"),
            (1e16, "1.0e+16"),
            (1.7976931348623157e308, "1.7976931348623157e+308"),
            (5e-324, "5.0e-324"),
            (f64::from(0.1f32), "0.10000000149011612"),
            (-123456.789, "-123456.789"),
            // Two shortest strings, equally near: Python takes the even digit.
            (-654701260200.65625, "-654701260200.6562"),
            (163058953422.390625, "163058953422.39062"),
            (f64::INFINITY, ".inf"),
            (f64::NEG_INFINITY, "-.inf"),
            (f64::NAN, ".nan"),
        ] {
            assert_eq!(yaml_float(x), text, "{x:e}");
        }
    }

    #[test]
    fn strings_that_read_as_other_types_are_recognized() {
        for s in [
            "yes",
            "Off",
            "1",
            "-1_000",
            "0b101",
            "0x1F",
            "017",
            "1:30",
            "1.",
            ".5",
            "1.5e-03",
            "-.inf",
            ".NaN",
            "1:20.5",
            "~",
            "null",
            "",
            "<<",
            "=",
            "2001-12-14",
            "2001-12-14t21:59:43.10-05:00",
            "2001-12-14 21:59:43.10 -5",
            "2002-12-14T1:02:03Z",
        ] {
            assert!(resolves_to_non_string(s), "{s:?} reads as a non-string");
        }
        for s in [
            "y", "n", "09", "0o7", "1e5", ".", "+.nan", "abc", "1.5e3", "2001-1-1", "12:61", "-",
            "0b", "0x", "nil",
        ] {
            assert!(!resolves_to_non_string(s), "{s:?} reads as a string");
        }
    }
}
