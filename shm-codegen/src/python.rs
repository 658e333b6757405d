//! Default values as rosidl writes them into a type description: rosidl reads
//! the value with Python and stores `str()` of it, so `1.0`, `True`,
//! `(0, 127, -128)`, `('', 'max value')`, and a string as its plain text.

use shm_interface::python::python_float;
pub use shm_interface::python::string_repr;

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
        // The text is Rust's shortest form of the same `f64`: it reads back
        // exactly.
        Value::Float(text) => text.parse().map_or_else(|_| text.clone(), python_float),
        Value::Str(text) => string_repr(text),
        Value::List(_) => description_default(value),
    }
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
