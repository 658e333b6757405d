//! A type description written back as the `.msg` text it could come from
//! (without the comments and constants a description does not carry).

use std::fmt::Write as _;

use crate::described::DescribedField;
use crate::type_id::{split_type_id, ContainerKind, TypeId};

/// `.msg` text declaring `fields`, one per line: a description written back
/// as the file it could come from (without the comments and constants a
/// description does not carry).
pub fn msg_text<'a>(fields: impl Iterator<Item = DescribedField<'a>>) -> String {
    let mut out = String::new();
    for (i, field) in fields.enumerate() {
        if i > 0 {
            out.push('\n');
        }
        // A description that is not one of a type (checked where it is made
        // into one) still gets a line: its element's id as written.
        let (element, container) = split_type_id(field.type_id)
            .map_or((None, ContainerKind::Single), |(id, container)| {
                (TypeId::from_element_id(id).ok(), container)
            });
        match element {
            Some(TypeId::Nested) => {
                // `pkg/msg/Name` is written `pkg/Name` in .msg files.
                let mut parts = field.nested_type_name.split('/');
                match (parts.next(), parts.next(), parts.next()) {
                    (Some(pkg), Some(_), Some(name)) => {
                        let _ = write!(out, "{pkg}/{name}");
                    }
                    _ => out.push_str(field.nested_type_name),
                }
            }
            Some(bounded @ (TypeId::BoundedString | TypeId::BoundedWString)) => {
                let _ = write!(out, "{}<={}", bounded.msg_name(), field.string_capacity);
            }
            Some(element) => out.push_str(element.msg_name()),
            None => {}
        }
        match container {
            ContainerKind::Single => {}
            ContainerKind::Array => {
                let _ = write!(out, "[{}]", field.capacity);
            }
            ContainerKind::BoundedSequence => {
                let _ = write!(out, "[<={}]", field.capacity);
            }
            ContainerKind::Sequence => out.push_str("[]"),
        }
        out.push(' ');
        out.push_str(field.name);
        if !field.default_value.is_empty() {
            out.push(' ');
            let is_text = element.is_some_and(TypeId::is_text);
            out.push_str(&msg_default(
                field.default_value,
                is_text,
                container == ContainerKind::Single,
            ));
        }
    }
    out
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
