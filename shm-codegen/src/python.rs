//! Default values as rosidl writes them into a type description: rosidl reads
//! the value with Python and stores `str()` of it, so `1.0`, `True`,
//! `(0, 127, -128)`, `('', 'max value')`, and a string as its plain text.

use std::fmt::Write as _;

use crate::ast::Value;

/// `str()` of the Python value rosidl parses from a default: a scalar as Python
/// prints it, a list as a tuple.
pub fn description_default(value: &Value) -> String {
    match value {
        Value::Str(text) => text.clone(),
        Value::List(items) => {
            let mut out = String::from("(");
            for (i, item) in items.iter().enumerate() {
                if i > 0 {
                    out.push_str(", ");
                }
                out.push_str(&repr(item));
            }
            if items.len() == 1 {
                out.push(',');
            }
            out.push(')');
            out
        }
        scalar => repr(scalar),
    }
}

/// Python's `repr()` of a scalar (inside a tuple, strings are quoted).
fn repr(value: &Value) -> String {
    match value {
        Value::Bool(true) => "True".into(),
        Value::Bool(false) => "False".into(),
        Value::Int(n) => n.to_string(),
        Value::Float(text) => float_repr(text),
        Value::Str(text) => string_repr(text),
        Value::List(_) => description_default(value),
    }
}

/// Python's `repr()` of a float from Rust's `{:?}` of the same `f64`. Both print
/// the shortest digits that read back to the value and switch to an exponent
/// below 1e-4 and from 1e16; Python writes the exponent with a sign and at
/// least two digits (`1e+16`, `1.5e-07`).
fn float_repr(rust: &str) -> String {
    let Some((mantissa, exponent)) = rust.split_once('e') else {
        return rust.to_owned();
    };
    let (sign, digits) = match exponent.strip_prefix('-') {
        Some(digits) => ('-', digits),
        None => ('+', exponent),
    };
    format!("{mantissa}e{sign}{digits:0>2}")
}

/// Python's `repr()` of a `str`: single quotes unless the text holds a single
/// quote and no double quote; backslashes, the quote and control characters
/// escaped. (What ROS 2's Python tools print for a string in a list.)
///
/// ```
/// assert_eq!(shm_codegen::python::string_repr("it's"), "\"it's\"");
/// assert_eq!(shm_codegen::python::string_repr("a\tb"), "'a\\tb'");
/// ```
pub fn string_repr(text: &str) -> String {
    let quote = if text.contains('\'') && !text.contains('"') {
        '"'
    } else {
        '\''
    };
    let mut out = String::with_capacity(text.len() + 2);
    out.push(quote);
    for c in text.chars() {
        match c {
            '\\' => out.push_str("\\\\"),
            '\n' => out.push_str("\\n"),
            '\r' => out.push_str("\\r"),
            '\t' => out.push_str("\\t"),
            c if c == quote => {
                out.push('\\');
                out.push(c);
            }
            c if (c as u32) < 0x20 || (0x7f..0xa0).contains(&(c as u32)) => {
                let _ = write!(out, "\\x{:02x}", c as u32);
            }
            c => out.push(c),
        }
    }
    out.push(quote);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scalars_print_as_python_str() {
        assert_eq!(description_default(&Value::Bool(true)), "True");
        assert_eq!(description_default(&Value::Int(-128)), "-128");
        assert_eq!(description_default(&Value::Float("1.0".into())), "1.0");
        assert_eq!(description_default(&Value::Float("1e16".into())), "1e+16");
        assert_eq!(
            description_default(&Value::Float("1.5e-7".into())),
            "1.5e-07"
        );
        assert_eq!(
            description_default(&Value::Str("Hello'world!".into())),
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
            description_default(&strings),
            r#"('', 'max value', "it's", 'a\\b"c\'')"#
        );
        assert_eq!(
            description_default(&Value::List(vec![Value::Int(3)])),
            "(3,)"
        );
        assert_eq!(description_default(&Value::List(Vec::new())), "()");
        assert_eq!(
            description_default(&Value::List(vec![Value::Bool(false), Value::Bool(true)])),
            "(False, True)"
        );
    }
}
