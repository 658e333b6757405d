//! Messages from YAML (or JSON) text, as `ros2 topic pub` reads them
//! (rosidl_runtime_py's `set_message_fields`): a mapping of field names to
//! values; fields not named keep their defaults; nested messages are
//! mappings and arrays and sequences are lists; a `std_msgs/msg/Header` can
//! be `auto` and a `builtin_interfaces/msg/Time` `now`, stamped with the time
//! the caller gives.
//!
//! The text is read through serde, guided by the type: a string field takes
//! the text of any scalar as written (`1e5`, `0o17`, `yes` stay text, as
//! PyYAML reads them for a string), so whatever [`Message::to_yaml`] writes
//! reads back to the same message.

use std::borrow::Cow;
use std::fmt;

use std::cell::RefCell;

use serde::de::{self, DeserializeSeed, Deserializer, MapAccess, SeqAccess, Visitor};

use super::model::DynamicType;
use super::structs::Element;
use super::value::{Field, Message, Messages, Value};
use crate::describe::Container;

/// Why text could not be read as a message: where (`header.stamp.sec`,
/// `points[3].x`) and what is wrong.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TextError {
    /// The field path, empty for the whole message.
    pub path: String,
    /// What is wrong, and what would be accepted.
    pub reason: String,
}

impl fmt::Display for TextError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.path.is_empty() {
            f.write_str(&self.reason)
        } else {
            write!(f, "{}: {}", self.path, self.reason)
        }
    }
}

impl std::error::Error for TextError {}

impl DynamicType {
    /// A message of this type from YAML or JSON text, as `ros2 topic pub`
    /// reads its values: fields left out keep their defaults, so `""` and
    /// `{}` give [`default_message`](Self::default_message). Numbers must fit
    /// their field (integers for integer fields, any number for floats),
    /// `byte` and `char` fields take a number or a one-character string (as
    /// [`Message::to_yaml`] writes them), and arrays must have their length.
    /// `auto` for a `std_msgs/msg/Header` and `now` for a
    /// `builtin_interfaces/msg/Time` are refused here: see
    /// [`message_from_yaml_at`](Self::message_from_yaml_at).
    ///
    /// ```
    /// use shm_cdr::dynamic::{DynamicType, Value};
    /// use shm_cdr::msgs::geometry_msgs::PointStamped;
    /// use shm_cdr::RosMessage;
    ///
    /// let ty = DynamicType::from_description(&PointStamped::full_description())?;
    /// let message = ty.message_from_yaml("{header: {frame_id: map}, point: {x: 1, y: 2.5}}")?;
    /// let point: PointStamped = shm_cdr::from_bytes(&shm_cdr::to_vec(&message)?)?;
    /// assert_eq!((point.header.frame_id.as_str(), point.point.x, point.point.y), ("map", 1.0, 2.5));
    ///
    /// let error = ty.message_from_yaml("point: {w: 1}").unwrap_err();
    /// assert_eq!(error.to_string(), "point.w: geometry_msgs/msg/Point has no field `w` (its fields: x, y, z)");
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn message_from_yaml(&self, text: &str) -> Result<Message<'static>, TextError> {
        self.read_yaml(text, None)
    }

    /// [`message_from_yaml`](Self::message_from_yaml), with `auto` accepted
    /// for a `std_msgs/msg/Header` (its stamp set to `now`, its frame empty)
    /// and `now` for a `builtin_interfaces/msg/Time`, as `ros2 topic pub`
    /// does; `now` is seconds and nanoseconds.
    pub fn message_from_yaml_at(
        &self,
        text: &str,
        now: (i32, u32),
    ) -> Result<Message<'static>, TextError> {
        self.read_yaml(text, Some(now))
    }

    fn read_yaml(
        &self,
        text: &str,
        now: Option<(i32, u32)>,
    ) -> Result<Message<'static>, TextError> {
        crate::text_limits::check_yaml(text).map_err(|e| TextError {
            path: String::new(),
            reason: e.reason,
        })?;
        let mut message = self.default_message();
        if text.trim().is_empty() {
            return Ok(message);
        }
        let reader = Reader {
            now,
            path: RefCell::new(String::new()),
            failure: RefCell::new(None),
        };
        let result = MessageSeed {
            reader: &reader,
            message: &mut message,
        }
        .deserialize(yaml_serde::Deserializer::from_str(text));
        match result {
            Ok(()) => Ok(message),
            Err(e) => Err(match reader.failure.into_inner() {
                Some((path, reason)) => TextError { path, reason },
                None => TextError {
                    path: String::new(),
                    reason: format!("cannot read the text: {e}"),
                },
            }),
        }
    }
}

/// What the seeds share: `auto`/`now`'s time, the path to the value being
/// read, and the first failure with its path (serde's errors carry text only).
struct Reader {
    now: Option<(i32, u32)>,
    path: RefCell<String>,
    failure: RefCell<Option<(String, String)>>,
}

impl Reader {
    fn fail<E: de::Error>(&self, reason: String) -> E {
        let path = self.path.borrow().clone();
        let text = if path.is_empty() {
            reason.clone()
        } else {
            format!("{path}: {reason}")
        };
        self.failure.borrow_mut().get_or_insert((path, reason));
        E::custom(text)
    }

    /// Run `f` with `segment` (`.name` or `[i]`) added to the path; a
    /// failure of serde's own (a list where a number belongs) is kept with
    /// the path it happened at.
    fn within<T, E: fmt::Display>(
        &self,
        segment: std::fmt::Arguments<'_>,
        f: impl FnOnce() -> Result<T, E>,
    ) -> Result<T, E> {
        let start = self.path.borrow().len();
        {
            let mut path = self.path.borrow_mut();
            let text = segment.to_string();
            if path.is_empty() {
                path.push_str(text.trim_start_matches('.'));
            } else {
                path.push_str(&text);
            }
        }
        let out = f();
        if let Err(e) = &out {
            let path = self.path.borrow().clone();
            let text = e.to_string();
            // yaml_serde starts its messages with the path it knows.
            let reason = text
                .strip_prefix(&format!("{path}: "))
                .unwrap_or(&text)
                .to_owned();
            self.failure.borrow_mut().get_or_insert((path, reason));
        }
        self.path.borrow_mut().truncate(start);
        out
    }
}

/// Fills the fields a mapping names into a message.
struct MessageSeed<'r, 'm> {
    reader: &'r Reader,
    message: &'m mut Message<'static>,
}

impl<'de> DeserializeSeed<'de> for MessageSeed<'_, '_> {
    type Value = ();

    fn deserialize<D: Deserializer<'de>>(self, deserializer: D) -> Result<(), D::Error> {
        deserializer.deserialize_any(self)
    }
}

impl<'de> Visitor<'de> for MessageSeed<'_, '_> {
    type Value = ();

    fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "a mapping of {}'s fields to values",
            self.message.type_name()
        )
    }

    fn visit_str<E: de::Error>(self, s: &str) -> Result<(), E> {
        let type_name = self.message.type_name();
        match (self.reader.now, type_name, s) {
            (Some(now), "std_msgs/msg/Header", "auto") => {
                if let Some(i) = self.message.def().field_index("stamp") {
                    if let Some(mut stamp) = self.message.message("stamp").map(|m| m.to_message()) {
                        set_time(&mut stamp, now);
                        self.message.store(i, Value::Message(Box::new(stamp)));
                    }
                }
                Ok(())
            }
            (Some(now), "builtin_interfaces/msg/Time", "now") => {
                set_time(self.message, now);
                Ok(())
            }
            _ => Err(self.reader.fail(format!(
                "a {type_name} is a mapping of its fields to values, not the string {s:?}"
            ))),
        }
    }

    fn visit_unit<E: de::Error>(self) -> Result<(), E> {
        Ok(())
    }

    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<(), A::Error> {
        let reader = self.reader;
        while let Some(name) = map.next_key::<String>()? {
            reader.within(format_args!(".{name}"), || {
                let def = self.message.def();
                let Some(index) = def.field_index(&name) else {
                    let fields: Vec<&str> = def.fields.iter().map(|f| f.name.as_str()).collect();
                    return Err(reader.fail(format!(
                        "{} has no field `{name}` (its fields: {})",
                        def.name,
                        fields.join(", ")
                    )));
                };
                let (element, container) = (def.fields[index].element, def.fields[index].container);
                if container == Container::Single {
                    if let Some(Field::Message(nested)) = self.message.as_message_ref().field(index)
                    {
                        let mut nested = nested.to_message();
                        map.next_value_seed(MessageSeed {
                            reader,
                            message: &mut nested,
                        })?;
                        self.message.store(index, Value::Message(Box::new(nested)));
                        return Ok(());
                    }
                }
                let value = map.next_value_seed(FieldSeed {
                    reader,
                    ty: &self.message.ty,
                    element,
                    container,
                })?;
                self.message.store(index, value);
                Ok(())
            })?;
        }
        Ok(())
    }
}

/// Reads the value of a field that is not a single nested message.
struct FieldSeed<'r> {
    reader: &'r Reader,
    ty: &'r DynamicType,
    element: Element,
    container: Container,
}

impl<'de> DeserializeSeed<'de> for FieldSeed<'_> {
    type Value = Value<'static>;

    fn deserialize<D: Deserializer<'de>>(
        self,
        deserializer: D,
    ) -> Result<Value<'static>, D::Error> {
        let reader = self.reader;
        if self.container == Container::Single {
            let value = ScalarSeed {
                reader,
                element: self.element,
            }
            .deserialize(deserializer)?;
            return check_strings(self.element, &value)
                .map(|()| value)
                .map_err(|r| reader.fail(r));
        }
        let value = deserializer.deserialize_seq(ListVisitor {
            reader,
            ty: self.ty,
            element: self.element,
        })?;
        let len = value.len().unwrap_or(0);
        match self.container {
            Container::Array(n) if len != n => {
                return Err(reader.fail(format!("{len} elements for an array of {n}")))
            }
            Container::BoundedSequence(n) if len > n => {
                return Err(reader.fail(format!("{len} elements for a sequence of at most {n}")))
            }
            _ => {}
        }
        check_strings(self.element, &value).map_err(|r| reader.fail(r))?;
        Ok(value)
    }
}

struct ListVisitor<'r> {
    reader: &'r Reader,
    ty: &'r DynamicType,
    element: Element,
}

impl<'de> Visitor<'de> for ListVisitor<'_> {
    type Value = Value<'static>;

    fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("a list")
    }

    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Value<'static>, A::Error> {
        let reader = self.reader;
        // Never reserve on the word of the input: grow as elements arrive.
        let mut i = 0usize;
        let value = match self.element {
            Element::Message(index) => {
                let mut out = Messages::from_slots(self.ty.clone(), index, 0, Vec::new());
                loop {
                    let mut nested = self.ty.default_struct(index);
                    let more = reader.within(format_args!("[{i}]"), || {
                        seq.next_element_seed(MessageSeed {
                            reader,
                            message: &mut nested,
                        })
                    })?;
                    if more.is_none() {
                        break;
                    }
                    out.push(nested).map_err(|e| reader.fail(e.reason))?;
                    i += 1;
                }
                Value::Messages(Box::new(out))
            }
            element => {
                let mut out = Vec::new();
                while let Some(v) = reader.within(format_args!("[{i}]"), || {
                    seq.next_element_seed(ScalarSeed { reader, element })
                })? {
                    out.push(v);
                    i += 1;
                }
                match element {
                    Element::String(_) => Value::Strings(
                        out.into_iter()
                            .filter_map(|v| match v {
                                Value::String(s) => Some(s),
                                _ => None,
                            })
                            .collect(),
                    ),
                    Element::WString(_) => Value::WStrings(
                        out.into_iter()
                            .filter_map(|v| match v {
                                Value::WString(s) => Some(s),
                                _ => None,
                            })
                            .collect(),
                    ),
                    // Every value is of `element`: `collect` takes them all.
                    _ => super::defaults::collect(element, out)
                        .ok_or_else(|| reader.fail("values of different kinds".into()))?,
                }
            }
        };
        Ok(value)
    }
}

/// One value of `element` (not a nested message).
struct ScalarSeed<'r> {
    reader: &'r Reader,
    element: Element,
}

impl<'de> DeserializeSeed<'de> for ScalarSeed<'_> {
    type Value = Value<'static>;

    fn deserialize<D: Deserializer<'de>>(
        self,
        deserializer: D,
    ) -> Result<Value<'static>, D::Error> {
        match self.element {
            // A string field takes any scalar's text as written.
            Element::String(_) | Element::WString(_) => deserializer.deserialize_str(self),
            _ => deserializer.deserialize_any(self),
        }
    }
}

impl ScalarSeed<'_> {
    fn want(&self) -> String {
        match self.element {
            Element::Bool => "true or false".into(),
            Element::Byte | Element::Char => {
                "a number from 0 to 255 or one character up to U+00FF".into()
            }
            Element::U8 => int_range::<u8>("uint8"),
            Element::I8 => int_range::<i8>("int8"),
            Element::I16 => int_range::<i16>("int16"),
            Element::U16 => int_range::<u16>("uint16"),
            Element::I32 => int_range::<i32>("int32"),
            Element::U32 => int_range::<u32>("uint32"),
            Element::I64 => int_range::<i64>("int64"),
            Element::U64 => int_range::<u64>("uint64"),
            Element::F32 | Element::F64 => "a number".into(),
            Element::String(_) | Element::WString(_) => "a string".into(),
            Element::Message(_) => "a mapping".into(),
        }
    }

    fn refuse<E: de::Error>(&self, found: String) -> E {
        self.reader.fail(format!("{}, not {found}", self.want()))
    }

    fn integer<E: de::Error>(&self, n: i128) -> Result<Value<'static>, E> {
        let value = match self.element {
            Element::Byte | Element::Char | Element::U8 => u8::try_from(n).ok().map(Value::U8),
            Element::I8 => i8::try_from(n).ok().map(Value::I8),
            Element::I16 => i16::try_from(n).ok().map(Value::I16),
            Element::U16 => u16::try_from(n).ok().map(Value::U16),
            Element::I32 => i32::try_from(n).ok().map(Value::I32),
            Element::U32 => u32::try_from(n).ok().map(Value::U32),
            Element::I64 => i64::try_from(n).ok().map(Value::I64),
            Element::U64 => u64::try_from(n).ok().map(Value::U64),
            // Integers are numbers too (i128 to f64 rounds as Python's float()).
            Element::F32 | Element::F64 => return self.float(n as f64),
            Element::String(_) | Element::WString(_) => return Ok(self.text(n.to_string())),
            _ => None,
        };
        value.ok_or_else(|| self.refuse(format!("`{n}`")))
    }

    fn float<E: de::Error>(&self, x: f64) -> Result<Value<'static>, E> {
        match self.element {
            Element::F64 => Ok(Value::F64(x)),
            Element::F32 if x.is_finite() && x.abs() > f64::from(f32::MAX) => {
                Err(self.reader.fail(format!("{x:e} is beyond float32's range")))
            }
            Element::F32 => Ok(Value::F32(x as f32)),
            _ => Err(self.refuse(format!("`{x}`"))),
        }
    }

    fn text(&self, s: String) -> Value<'static> {
        match self.element {
            Element::WString(_) => Value::WString(s),
            _ => Value::String(Cow::Owned(s)),
        }
    }
}

fn int_range<T: num_bounds::Bounded>(name: &str) -> String {
    format!(
        "an integer from {} to {} ({name})",
        T::MIN_TEXT,
        T::MAX_TEXT
    )
}

mod num_bounds {
    /// The range of an integer type, for messages.
    pub(super) trait Bounded {
        const MIN_TEXT: &'static str;
        const MAX_TEXT: &'static str;
    }
    macro_rules! bounded {
        ($($t:ty: $min:literal, $max:literal;)*) => {
            $(impl Bounded for $t {
                const MIN_TEXT: &'static str = $min;
                const MAX_TEXT: &'static str = $max;
            })*
        };
    }
    bounded! {
        u8: "0", "255";
        i8: "-128", "127";
        i16: "-32768", "32767";
        u16: "0", "65535";
        i32: "-2147483648", "2147483647";
        u32: "0", "4294967295";
        i64: "-9223372036854775808", "9223372036854775807";
        u64: "0", "18446744073709551615";
    }
}

impl<'de> Visitor<'de> for ScalarSeed<'_> {
    type Value = Value<'static>;

    fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.want())
    }

    fn visit_bool<E: de::Error>(self, b: bool) -> Result<Value<'static>, E> {
        match self.element {
            Element::Bool => Ok(Value::Bool(b)),
            _ => Err(self.refuse(format!("`{b}`"))),
        }
    }

    fn visit_i64<E: de::Error>(self, n: i64) -> Result<Value<'static>, E> {
        self.integer(i128::from(n))
    }

    fn visit_u64<E: de::Error>(self, n: u64) -> Result<Value<'static>, E> {
        self.integer(i128::from(n))
    }

    fn visit_f64<E: de::Error>(self, x: f64) -> Result<Value<'static>, E> {
        self.float(x)
    }

    fn visit_str<E: de::Error>(self, s: &str) -> Result<Value<'static>, E> {
        match self.element {
            Element::String(_) | Element::WString(_) => Ok(self.text(s.to_owned())),
            // YAML 1.1's words, as PyYAML reads them.
            Element::Bool => match s {
                "yes" | "Yes" | "YES" | "on" | "On" | "ON" | "True" | "TRUE" => {
                    Ok(Value::Bool(true))
                }
                "no" | "No" | "NO" | "off" | "Off" | "OFF" | "False" | "FALSE" => {
                    Ok(Value::Bool(false))
                }
                _ => Err(self.refuse(format!("the string {s:?}"))),
            },
            // One character, as `to_yaml` writes a byte.
            Element::Byte | Element::Char => {
                let mut chars = s.chars();
                match (chars.next(), chars.next()) {
                    (Some(c), None) if u32::from(c) <= 0xFF => Ok(Value::U8(u32::from(c) as u8)),
                    _ => Err(self.refuse(format!("the string {s:?}"))),
                }
            }
            _ => Err(self.refuse(format!("the string {s:?}"))),
        }
    }

    fn visit_unit<E: de::Error>(self) -> Result<Value<'static>, E> {
        Err(self.refuse("nothing".into()))
    }

    fn visit_seq<A: SeqAccess<'de>>(self, _: A) -> Result<Value<'static>, A::Error> {
        Err(self.refuse("a list".into()))
    }

    fn visit_map<A: MapAccess<'de>>(self, _: A) -> Result<Value<'static>, A::Error> {
        Err(self.refuse("a mapping".into()))
    }
}

fn set_time(time: &mut Message<'static>, (sec, nanosec): (i32, u32)) {
    if let Some(i) = time.def().field_index("sec") {
        time.store(i, Value::I32(sec));
    }
    if let Some(i) = time.def().field_index("nanosec") {
        time.store(i, Value::U32(nanosec));
    }
}

/// String bounds (in bytes, or UTF-16 units for wide strings).
fn check_strings(element: Element, value: &Value<'_>) -> Result<(), String> {
    let over = |s: &str, bound: Option<usize>, wide: bool| {
        bound.is_some_and(|b| {
            if wide {
                s.encode_utf16().count() > b
            } else {
                s.len() > b
            }
        })
    };
    let bad = match (element, value) {
        (Element::String(b), Value::String(s)) => over(s, b, false),
        (Element::String(b), Value::Strings(v)) => v.iter().any(|s| over(s, b, false)),
        (Element::WString(b), Value::WString(s)) => over(s, b, true),
        (Element::WString(b), Value::WStrings(v)) => v.iter().any(|s| over(s, b, true)),
        _ => false,
    };
    match (bad, element) {
        (false, _) => Ok(()),
        (true, Element::WString(Some(b))) => Err(format!(
            "a string longer than the field's bound of {b} UTF-16 units"
        )),
        (true, Element::String(Some(b))) => Err(format!(
            "a string longer than the field's bound of {b} bytes"
        )),
        (true, _) => Err("a string longer than the field's bound".into()),
    }
}
