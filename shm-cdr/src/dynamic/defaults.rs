//! Default values: as a type description writes them (Python's `str()` of
//! the value: `1.5`, `True`, `(0, 127, -128)`, `('', 'a b')`, a string as its
//! text) read back into [`Value`]s, and a type's default message made of
//! them.

use std::borrow::Cow;

use super::model::DynamicType;
use super::structs::Element;
use super::value::{Message, Messages, Value};
use crate::describe::Container;
use crate::wire::wstring::utf16_len;

/// The value `text` gives a field of `element` in `container`; `None` if it
/// is empty or not a value of that field (the field then starts at zero).
pub(crate) fn parse(element: Element, container: Container, text: &str) -> Option<Value<'static>> {
    if text.is_empty() {
        return None;
    }
    if container == Container::Single {
        return match element {
            Element::String(bound) => {
                within(bound, text.len()).then(|| Value::String(Cow::Owned(text.to_owned())))
            }
            Element::WString(bound) => {
                within(bound, utf16_len(text)).then(|| Value::WString(text.to_owned()))
            }
            _ => scalar(element, text),
        };
    }
    let inner = text.strip_prefix('(')?.strip_suffix(')')?;
    let mut items = shm_interface::python::split_list(inner)?;
    // Python writes a one-item tuple `(a,)`.
    if items.last() == Some(&"") {
        items.pop();
    }
    let value = match element {
        Element::String(bound) => Value::Strings(
            items
                .iter()
                .map(|i| {
                    python_str(i)
                        .filter(|s| within(bound, s.len()))
                        .map(Cow::Owned)
                })
                .collect::<Option<_>>()?,
        ),
        Element::WString(bound) => Value::WStrings(
            items
                .iter()
                .map(|i| python_str(i).filter(|s| within(bound, utf16_len(s))))
                .collect::<Option<_>>()?,
        ),
        Element::Message(_) => return None,
        _ => {
            let values: Vec<Value<'static>> = items
                .iter()
                .map(|i| scalar(element, i))
                .collect::<Option<_>>()?;
            collect(element, values)?
        }
    };
    let len = value.len().unwrap_or(0);
    match container {
        Container::Array(n) if len != n => None,
        Container::BoundedSequence(n) if len > n => None,
        _ => Some(value),
    }
}

/// Whether a string of `len` (bytes, or UTF-16 units for a `wstring`) fits
/// `bound`: a default past its field's bound is no value of the field, as
/// rosidl would refuse it.
fn within(bound: Option<usize>, len: usize) -> bool {
    match bound {
        Some(bound) => len <= bound,
        None => true,
    }
}

fn scalar(element: Element, text: &str) -> Option<Value<'static>> {
    Some(match element {
        Element::Bool => match text {
            "True" => Value::Bool(true),
            "False" => Value::Bool(false),
            _ => return None,
        },
        Element::Byte | Element::Char | Element::U8 => Value::U8(text.parse().ok()?),
        Element::I8 => Value::I8(text.parse().ok()?),
        Element::I16 => Value::I16(text.parse().ok()?),
        Element::U16 => Value::U16(text.parse().ok()?),
        Element::I32 => Value::I32(text.parse().ok()?),
        Element::U32 => Value::U32(text.parse().ok()?),
        Element::I64 => Value::I64(text.parse().ok()?),
        Element::U64 => Value::U64(text.parse().ok()?),
        Element::F32 => Value::F32(text.parse().ok()?),
        Element::F64 => Value::F64(text.parse().ok()?),
        _ => return None,
    })
}

/// Scalars gathered into the array value of their element.
pub(crate) fn collect(element: Element, values: Vec<Value<'static>>) -> Option<Value<'static>> {
    macro_rules! gather {
        ($variant:ident, $many:ident) => {
            Value::$many(From::from(
                values
                    .into_iter()
                    .map(|v| match v {
                        Value::$variant(x) => Some(x),
                        _ => None,
                    })
                    .collect::<Option<Vec<_>>>()?,
            ))
        };
    }
    Some(match element {
        Element::Bool => Value::Bools(
            values
                .into_iter()
                .map(|v| match v {
                    Value::Bool(x) => Some(x),
                    _ => None,
                })
                .collect::<Option<Vec<_>>>()?,
        ),
        Element::Byte | Element::Char | Element::U8 => gather!(U8, U8s),
        Element::I8 => gather!(I8, I8s),
        Element::I16 => gather!(I16, I16s),
        Element::U16 => gather!(U16, U16s),
        Element::I32 => gather!(I32, I32s),
        Element::U32 => gather!(U32, U32s),
        Element::I64 => gather!(I64, I64s),
        Element::U64 => gather!(U64, U64s),
        Element::F32 => gather!(F32, F32s),
        Element::F64 => gather!(F64, F64s),
        _ => return None,
    })
}

/// A Python string literal (`'a'`, `"it's"`, with backslash escapes) read.
fn python_str(literal: &str) -> Option<String> {
    let quote = literal.chars().next().filter(|c| *c == '\'' || *c == '"')?;
    let body = literal.strip_prefix(quote)?.strip_suffix(quote)?;
    let mut out = String::with_capacity(body.len());
    let mut chars = body.chars();
    while let Some(c) = chars.next() {
        if c != '\\' {
            out.push(c);
            continue;
        }
        match chars.next()? {
            'n' => out.push('\n'),
            't' => out.push('\t'),
            'r' => out.push('\r'),
            'x' => {
                let hex: String = chars.by_ref().take(2).collect();
                out.push(char::from_u32(u32::from_str_radix(&hex, 16).ok()?)?);
            }
            other => out.push(other),
        }
    }
    Some(out)
}

impl DynamicType {
    /// A message of this type with every field at its default: the default
    /// value its description gives, else zero, empty, or an array of zeros
    /// (every element of a fixed array is made).
    pub fn default_message(&self) -> Message<'static> {
        self.default_struct(0)
    }

    /// A message of struct `index` of this type ([`structs`](Self::structs))
    /// with every field at its default, `None` past the last: what a field
    /// of that struct nested in this type's messages takes
    /// ([`Message::set`] takes only nested messages of the same type).
    ///
    /// ```
    /// use shm_cdr::dynamic::{DynamicType, Value};
    /// use shm_cdr::msgs::std_msgs::Header;
    /// use shm_cdr::RosMessage;
    ///
    /// let ty = DynamicType::from_description(&Header::full_description())?;
    /// let time = ty.structs().iter().position(|s| s.name == "builtin_interfaces/msg/Time").unwrap();
    /// let mut stamp = ty.default_struct_message(time).unwrap();
    /// stamp.set("sec", Value::I32(7))?;
    /// let mut header = ty.default_message();
    /// header.set("stamp", Value::Message(Box::new(stamp)))?;
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn default_struct_message(&self, index: usize) -> Option<Message<'static>> {
        (index < self.inner.structs.len()).then(|| self.default_struct(index))
    }

    pub(crate) fn default_struct(&self, index: usize) -> Message<'static> {
        let block = self.inner.plans.get(index).map_or(0, |p| p.block);
        let mut slots = Vec::with_capacity(block);
        self.push_defaults(index, &mut slots);
        Message::from_slots(self.clone(), index, slots)
    }

    /// Push the default values of a message of struct `index` onto `slots`,
    /// in slot order.
    fn push_defaults(&self, index: usize, slots: &mut Vec<Value<'static>>) {
        let Some(def) = self.inner.structs.get(index) else {
            return;
        };
        for f in &def.fields {
            if let (Element::Message(nested), Container::Single) = (f.element, f.container) {
                self.push_defaults(nested, slots);
                continue;
            }
            let n = match f.container {
                Container::Array(n) => n,
                _ => 0,
            };
            let given = parse(f.element, f.container, &f.default_value);
            slots.push(given.unwrap_or_else(|| self.zero(f.element, f.container, n)));
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
                Element::Message(i) => Value::Message(Box::new(self.default_struct(i))),
            };
        }
        match element {
            Element::Bool => Value::Bools(vec![false; n]),
            Element::Byte | Element::Char | Element::U8 => Value::U8s(Cow::Owned(vec![0; n])),
            Element::I8 => Value::I8s(Cow::Owned(vec![0; n])),
            Element::I16 => Value::I16s(vec![0; n].into()),
            Element::U16 => Value::U16s(vec![0; n].into()),
            Element::I32 => Value::I32s(vec![0; n].into()),
            Element::U32 => Value::U32s(vec![0; n].into()),
            Element::I64 => Value::I64s(vec![0; n].into()),
            Element::U64 => Value::U64s(vec![0; n].into()),
            Element::F32 => Value::F32s(vec![0.0; n].into()),
            Element::F64 => Value::F64s(vec![0.0; n].into()),
            Element::String(_) => Value::Strings(vec![Cow::Borrowed(""); n]),
            Element::WString(_) => Value::WStrings(vec![String::new(); n]),
            Element::Message(i) => {
                let block = self.inner.plans.get(i).map_or(0, |p| p.block);
                let mut slots = Vec::with_capacity(n.saturating_mul(block));
                for _ in 0..n {
                    self.push_defaults(i, &mut slots);
                }
                Value::Messages(Box::new(Messages::from_slots(self.clone(), i, n, slots)))
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_default_past_its_string_bound_is_no_value() {
        let single = Container::Single;
        assert_eq!(
            parse(Element::String(Some(0)), single, "hello world!"),
            None
        );
        assert_eq!(
            parse(Element::String(Some(5)), single, "hello"),
            Some(Value::String(Cow::Owned("hello".into())))
        );
        // A bound on a `wstring` counts UTF-16 units: one astral character is two.
        assert_eq!(parse(Element::WString(Some(1)), single, "𝄞"), None);
        assert!(parse(Element::WString(Some(2)), single, "𝄞").is_some());
        let many = Container::Sequence;
        assert_eq!(parse(Element::String(Some(2)), many, "('ab', 'abc')"), None);
        assert!(parse(Element::String(Some(3)), many, "('ab', 'abc')").is_some());
        assert_eq!(parse(Element::WString(Some(1)), many, "('é', '𝄞')"), None);
        assert!(parse(Element::WString(Some(2)), many, "('é', '𝄞')").is_some());
    }
}
