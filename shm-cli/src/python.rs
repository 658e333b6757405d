//! Values as Python prints them, for the verbs whose output is Python's
//! `repr` (`ros2 param get`, `ros2 service call`).

use shm_cdr::dynamic::{python_float, DynamicType, Element, FieldDef, Message, Value};
use shm_codegen::python::string_repr;

/// Python's `repr` of a one-byte `bytes`.
pub(crate) fn bytes_repr(b: u8) -> String {
    match b {
        b'\\' => "b'\\\\'".into(),
        b'\'' => "b\"'\"".into(),
        b'\t' => "b'\\t'".into(),
        b'\n' => "b'\\n'".into(),
        b'\r' => "b'\\r'".into(),
        0x20..=0x7e => format!("b'{}'", char::from(b)),
        _ => format!("b'\\x{b:02x}'"),
    }
}

/// rclpy's `repr` of a message (rosidl_generator_py's `__repr__`):
/// `pkg.msg.Name(field=value, …)`.
pub(crate) fn message_repr(message: &Message<'_>, ty: &DynamicType) -> String {
    let name = message.type_name().replace('/', ".");
    let Some(def) = ty.structs().iter().find(|s| s.name == message.type_name()) else {
        return format!("{name}()");
    };
    let fields: Vec<String> = def
        .fields
        .iter()
        .filter(|f| f.name != "structure_needs_at_least_one_member")
        .filter_map(|f| {
            let value = message.get(&f.name)?;
            Some(format!("{}={}", f.name, value_repr(f, value, ty)))
        })
        .collect();
    format!("{name}({})", fields.join(", "))
}

fn value_repr(field: &FieldDef, value: &Value<'_>, ty: &DynamicType) -> String {
    // A sequence of numbers is an `array` and a fixed array a numpy array in
    // rclpy: both print here as the list they hold.
    let list = |items: Vec<String>| format!("[{}]", items.join(", "));
    match value {
        Value::Bool(b) => bool_repr(*b).to_owned(),
        Value::U8(b) if field.element == Element::Byte => bytes_repr(*b),
        Value::U8(v) => v.to_string(),
        Value::I8(v) => v.to_string(),
        Value::I16(v) => v.to_string(),
        Value::U16(v) => v.to_string(),
        Value::I32(v) => v.to_string(),
        Value::U32(v) => v.to_string(),
        Value::I64(v) => v.to_string(),
        Value::U64(v) => v.to_string(),
        Value::F32(v) => python_float(f64::from(*v)),
        Value::F64(v) => python_float(*v),
        Value::String(s) => string_repr(s),
        Value::WString(s) => string_repr(s),
        Value::Message(m) => message_repr(m, ty),
        Value::Bools(v) => list(v.iter().map(|b| bool_repr(*b).to_owned()).collect()),
        Value::U8s(v) if field.element == Element::Byte => {
            list(v.iter().map(|b| bytes_repr(*b)).collect())
        }
        Value::U8s(v) => list(v.iter().map(u8::to_string).collect()),
        Value::I8s(v) => list(v.iter().map(i8::to_string).collect()),
        Value::I16s(v) => list(v.iter().map(i16::to_string).collect()),
        Value::U16s(v) => list(v.iter().map(u16::to_string).collect()),
        Value::I32s(v) => list(v.iter().map(i32::to_string).collect()),
        Value::U32s(v) => list(v.iter().map(u32::to_string).collect()),
        Value::I64s(v) => list(v.iter().map(i64::to_string).collect()),
        Value::U64s(v) => list(v.iter().map(u64::to_string).collect()),
        Value::F32s(v) => list(v.iter().map(|x| python_float(f64::from(*x))).collect()),
        Value::F64s(v) => list(v.iter().map(|x| python_float(*x)).collect()),
        Value::Strings(v) => list(v.iter().map(|s| string_repr(s)).collect()),
        Value::WStrings(v) => list(v.iter().map(|s| string_repr(s)).collect()),
        Value::Messages(v) => list(v.iter().map(|m| message_repr(m, ty)).collect()),
    }
}

fn bool_repr(b: bool) -> &'static str {
    if b {
        "True"
    } else {
        "False"
    }
}
