//! Values between Rust and Python: a field's value to the Python object a
//! ROS 2 Python developer expects, and a Python object to a field's value,
//! refusing what does not fit with the field's name and what to give.

use std::borrow::Cow;
use std::sync::Arc;

use numpy::{PyArrayDyn, PyArrayMethods, PyUntypedArray, PyUntypedArrayMethods};
use pyo3::exceptions::{PyOverflowError, PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyByteArray, PyBytes, PyDict, PyFloat, PyList, PyString};
use shm_cdr::describe::Container;
use shm_cdr::dynamic::{
    DynamicType, Element, Field, FieldDef, Message, MessageRef, Messages, Number, Numbers, Value,
};

use crate::arrays;
use crate::message::{Payload, PyMessage};

/// A value as Python sees it.
pub(crate) fn to_py<'py>(
    py: Python<'py>,
    value: &Value<'_>,
    payload: Option<&Arc<Payload>>,
) -> PyResult<Bound<'py, PyAny>> {
    Ok(match value {
        Value::Bool(v) => PyBool::new(py, *v).to_owned().into_any(),
        Value::U8(v) => v.into_pyobject(py)?.into_any(),
        Value::I8(v) => v.into_pyobject(py)?.into_any(),
        Value::I16(v) => v.into_pyobject(py)?.into_any(),
        Value::U16(v) => v.into_pyobject(py)?.into_any(),
        Value::I32(v) => v.into_pyobject(py)?.into_any(),
        Value::U32(v) => v.into_pyobject(py)?.into_any(),
        Value::I64(v) => v.into_pyobject(py)?.into_any(),
        Value::U64(v) => v.into_pyobject(py)?.into_any(),
        Value::F32(v) => PyFloat::new(py, f64::from(*v)).into_any(),
        Value::F64(v) => PyFloat::new(py, *v).into_any(),
        Value::String(s) => PyString::new(py, s).into_any(),
        Value::WString(s) => PyString::new(py, s).into_any(),
        Value::Message(m) => Bound::new(
            py,
            PyMessage::new(crate::message::Root::owned(m.clone().into_owned())),
        )?
        .into_any(),
        Value::Bools(v) => numpy::PyArray1::from_slice(py, v).into_any(),
        Value::U8s(v) => arrays::u8s(py, v, matches!(v, Cow::Borrowed(_)), payload)?,
        Value::I8s(v) => arrays::i8s(py, v, matches!(v, Cow::Borrowed(_)), payload)?,
        Value::I16s(v) => arrays::numbers(py, v, payload)?,
        Value::U16s(v) => arrays::numbers(py, v, payload)?,
        Value::I32s(v) => arrays::numbers(py, v, payload)?,
        Value::U32s(v) => arrays::numbers(py, v, payload)?,
        Value::I64s(v) => arrays::numbers(py, v, payload)?,
        Value::U64s(v) => arrays::numbers(py, v, payload)?,
        Value::F32s(v) => arrays::numbers(py, v, payload)?,
        Value::F64s(v) => arrays::numbers(py, v, payload)?,
        Value::Strings(v) => PyList::new(py, v.iter().map(|s| s.as_ref()))?.into_any(),
        Value::WStrings(v) => PyList::new(py, v)?.into_any(),
        Value::Messages(messages) => {
            let list = PyList::empty(py);
            for m in messages.iter() {
                list.append(to_dict(py, &m, payload)?)?;
            }
            list.into_any()
        }
    })
}

/// A message's fields as a dict, nested messages as dicts.
pub(crate) fn to_dict<'py>(
    py: Python<'py>,
    message: &MessageRef<'_, '_>,
    payload: Option<&Arc<Payload>>,
) -> PyResult<Bound<'py, PyDict>> {
    let dict = PyDict::new(py);
    for (name, field) in message.fields().filter(|(name, _)| shown(name)) {
        match field {
            Field::Message(nested) => dict.set_item(name, to_dict(py, &nested, payload)?)?,
            Field::Value(value) => dict.set_item(name, to_py(py, value, payload)?)?,
        }
    }
    Ok(dict)
}

/// `pkg.msg.Name(field=value, …)`, as rclpy writes a message, each value
/// in Python's (numpy's) own `repr`.
pub(crate) fn repr(
    py: Python<'_>,
    message: &MessageRef<'_, '_>,
    payload: Option<&Arc<Payload>>,
) -> PyResult<String> {
    let mut out = message.type_name().replace('/', ".");
    out.push('(');
    for (i, (name, field)) in message.fields().filter(|(name, _)| shown(name)).enumerate() {
        if i > 0 {
            out.push_str(", ");
        }
        out.push_str(name);
        out.push('=');
        match field {
            Field::Message(nested) => out.push_str(&repr(py, &nested, payload)?),
            Field::Value(Value::Messages(messages)) => {
                out.push('[');
                for (k, m) in messages.iter().enumerate() {
                    if k > 0 {
                        out.push_str(", ");
                    }
                    out.push_str(&repr(py, &m, payload)?);
                }
                out.push(']');
            }
            Field::Value(value) => {
                out.push_str(&to_py(py, value, payload)?.repr()?.to_string_lossy())
            }
        }
    }
    out.push(')');
    Ok(out)
}

/// The message `obj` gives (a message of that name, or a dict of its
/// fields) as one of struct `index` of `ty`.
pub(crate) fn message_from_py(
    obj: &Bound<'_, PyAny>,
    ty: &DynamicType,
    index: usize,
) -> PyResult<Message<'static>> {
    let template = ty
        .default_struct_message(index)
        .ok_or_else(|| PyValueError::new_err("internal: a nested type past the type's last"))?;
    if let Ok(message) = obj.cast::<PyMessage>() {
        return message.get().to_message_in(template);
    }
    if let Ok(dict) = obj.cast::<PyDict>() {
        return fill(template, ty, index, dict);
    }
    Err(PyTypeError::new_err(format!(
        "a {} is given as a message of that type or a dict of its fields, not {}",
        template.type_name(),
        type_name(obj)
    )))
}

/// `message` (struct `index` of `ty`) with the fields `dict` names set.
pub(crate) fn fill(
    mut message: Message<'static>,
    ty: &DynamicType,
    index: usize,
    dict: &Bound<'_, PyDict>,
) -> PyResult<Message<'static>> {
    let def = ty
        .structs()
        .get(index)
        .ok_or_else(|| PyValueError::new_err("internal: a nested type past the type's last"))?;
    for (key, value) in dict.iter() {
        let name: String = key.extract().map_err(|_| {
            PyTypeError::new_err(format!(
                "the keys of a {} dict are field names (str), not {}",
                def.name,
                type_name(&key)
            ))
        })?;
        let field = def.fields.iter().find(|f| f.name == name).ok_or_else(|| {
            let names: Vec<&str> = def.fields.iter().map(|f| f.name.as_str()).collect();
            PyValueError::new_err(format!(
                "{} has no field '{name}'; its fields are: {}",
                def.name,
                names.join(", ")
            ))
        })?;
        let value = from_py(&value, ty, index, field)?;
        message
            .set(&name, value)
            .map_err(|e| PyValueError::new_err(e.to_string()))?;
    }
    Ok(message)
}

/// `obj` as the value of `field` of struct `parent` of `ty`.
pub(crate) fn from_py(
    obj: &Bound<'_, PyAny>,
    ty: &DynamicType,
    parent: usize,
    field: &FieldDef,
) -> PyResult<Value<'static>> {
    let what = || {
        let parent = ty.structs().get(parent).map_or("", |s| s.name.as_str());
        format!("{parent}.{}", field.name)
    };
    let wrong = |expected: &str| {
        PyTypeError::new_err(format!("{} is {expected}, not {}", what(), type_name(obj)))
    };
    if field.container == Container::Single {
        return Ok(match field.element {
            Element::Bool => Value::Bool(boolean(obj, &what)?),
            Element::Byte | Element::Char | Element::U8 => Value::U8(integer(obj, &what)?),
            Element::I8 => Value::I8(integer(obj, &what)?),
            Element::I16 => Value::I16(integer(obj, &what)?),
            Element::U16 => Value::U16(integer(obj, &what)?),
            Element::I32 => Value::I32(integer(obj, &what)?),
            Element::U32 => Value::U32(integer(obj, &what)?),
            Element::I64 => Value::I64(integer(obj, &what)?),
            Element::U64 => Value::U64(integer(obj, &what)?),
            Element::F32 => Value::F32(float32(obj, &what)?),
            Element::F64 => Value::F64(float(obj, &what)?),
            Element::String(_) => Value::String(Cow::Owned(
                obj.extract::<String>().map_err(|_| wrong("a str"))?,
            )),
            Element::WString(_) => {
                Value::WString(obj.extract::<String>().map_err(|_| wrong("a str"))?)
            }
            Element::Message(index) => Value::Message(Box::new(message_from_py(obj, ty, index)?)),
        });
    }
    if let Element::Message(index) = field.element {
        let template = ty
            .default_struct_message(parent)
            .and_then(|m| match m.value(&field.name) {
                Some(Value::Messages(messages)) => Some((**messages).clone()),
                _ => None,
            })
            .ok_or_else(|| {
                PyValueError::new_err(format!("internal: {} has no messages", what()))
            })?;
        let mut messages: Messages<'static> = template;
        messages.clear();
        for item in sequence(obj, &what)? {
            messages
                .push(message_from_py(&item, ty, index)?)
                .map_err(|e| PyValueError::new_err(e.to_string()))?;
        }
        return Ok(Value::Messages(Box::new(messages)));
    }
    Ok(match field.element {
        Element::Byte | Element::Char | Element::U8 => Value::U8s(Cow::Owned(octets(obj, &what)?)),
        Element::I8 => Value::I8s(Cow::Owned(numbers::<i8>(obj, &what)?)),
        Element::Bool => Value::Bools(numbers::<bool>(obj, &what)?),
        Element::I16 => Value::I16s(owned(numbers::<i16>(obj, &what)?)),
        Element::U16 => Value::U16s(owned(numbers::<u16>(obj, &what)?)),
        Element::I32 => Value::I32s(owned(numbers::<i32>(obj, &what)?)),
        Element::U32 => Value::U32s(owned(numbers::<u32>(obj, &what)?)),
        Element::I64 => Value::I64s(owned(numbers::<i64>(obj, &what)?)),
        Element::U64 => Value::U64s(owned(numbers::<u64>(obj, &what)?)),
        Element::F32 => Value::F32s(owned(numbers::<f32>(obj, &what)?)),
        Element::F64 => Value::F64s(owned(numbers::<f64>(obj, &what)?)),
        Element::String(_) => Value::Strings(
            sequence(obj, &what)?
                .iter()
                .map(|s| s.extract::<String>().map(Cow::Owned))
                .collect::<PyResult<_>>()
                .map_err(|_| wrong("a list of str"))?,
        ),
        Element::WString(_) => Value::WStrings(
            sequence(obj, &what)?
                .iter()
                .map(|s| s.extract::<String>())
                .collect::<PyResult<_>>()
                .map_err(|_| wrong("a list of str"))?,
        ),
        // Arrays of messages were read above.
        Element::Message(_) => return Err(PyValueError::new_err(format!("internal: {}", what()))),
    })
}

fn owned<T: Number>(values: Vec<T>) -> Numbers<'static, T> {
    Numbers::from(values)
}

/// The Python type's name of `obj`, for errors.
fn type_name(obj: &Bound<'_, PyAny>) -> String {
    obj.get_type()
        .name()
        .map_or_else(|_| "?".to_owned(), |n| n.to_string())
}

/// An integer field's value: an `int` (or anything with `__index__`, as a
/// numpy integer), within the field's range.
fn integer<T: TryFrom<i128> + Bounded>(
    obj: &Bound<'_, PyAny>,
    what: &dyn Fn() -> String,
) -> PyResult<T> {
    let not_integer = || {
        PyTypeError::new_err(format!(
            "{} is an integer ({}), not {}",
            what(),
            T::NAME,
            type_name(obj)
        ))
    };
    if obj.is_instance_of::<PyBool>() || obj.is_instance_of::<PyFloat>() {
        return Err(not_integer());
    }
    let out_of_range = || {
        PyOverflowError::new_err(format!(
            "{} is {}: {} is out of its range [{}, {}]",
            what(),
            T::NAME,
            obj.repr()
                .map_or_else(|_| "the value".into(), |r| r.to_string()),
            T::MIN,
            T::MAX
        ))
    };
    let wide: i128 = obj.extract().map_err(|e: PyErr| {
        if e.is_instance_of::<PyOverflowError>(obj.py()) {
            out_of_range()
        } else {
            not_integer()
        }
    })?;
    T::try_from(wide).map_err(|_| out_of_range())
}

/// The range of an integer field's type, for errors.
trait Bounded {
    const NAME: &'static str;
    const MIN: i128;
    const MAX: i128;
}

macro_rules! bounded {
    ($($t:ty => $name:literal),*) => {$(
        impl Bounded for $t {
            const NAME: &'static str = $name;
            const MIN: i128 = <$t>::MIN as i128;
            const MAX: i128 = <$t>::MAX as i128;
        }
        impl Item for $t {
            fn from_item(obj: &Bound<'_, PyAny>, what: &dyn Fn() -> String) -> PyResult<Self> {
                integer(obj, what)
            }
        }
    )*};
}
bounded!(u8 => "uint8", i8 => "int8", i16 => "int16", u16 => "uint16", i32 => "int32",
    u32 => "uint32", i64 => "int64", u64 => "uint64");

/// One element of an array field, from Python, as a single field of its
/// kind takes it.
trait Item: Sized {
    fn from_item(obj: &Bound<'_, PyAny>, what: &dyn Fn() -> String) -> PyResult<Self>;
}

impl Item for f64 {
    fn from_item(obj: &Bound<'_, PyAny>, what: &dyn Fn() -> String) -> PyResult<Self> {
        float(obj, what)
    }
}

impl Item for f32 {
    fn from_item(obj: &Bound<'_, PyAny>, what: &dyn Fn() -> String) -> PyResult<Self> {
        float32(obj, what)
    }
}

impl Item for bool {
    fn from_item(obj: &Bound<'_, PyAny>, what: &dyn Fn() -> String) -> PyResult<Self> {
        boolean(obj, what)
    }
}

/// A bool field's value: `True`, `False` or a numpy bool.
fn boolean(obj: &Bound<'_, PyAny>, what: &dyn Fn() -> String) -> PyResult<bool> {
    if let Ok(b) = obj.cast::<PyBool>() {
        return Ok(b.is_true());
    }
    if obj
        .get_type()
        .name()
        .is_ok_and(|n| n == "bool" || n == "bool_")
    {
        return obj.is_truthy();
    }
    Err(PyTypeError::new_err(format!(
        "{} is a bool, not {}",
        what(),
        type_name(obj)
    )))
}

fn float(obj: &Bound<'_, PyAny>, what: &dyn Fn() -> String) -> PyResult<f64> {
    if obj.is_instance_of::<PyBool>() {
        return Err(PyTypeError::new_err(format!(
            "{} is a float, not bool",
            what()
        )));
    }
    obj.extract::<f64>()
        .map_err(|_| PyTypeError::new_err(format!("{} is a float, not {}", what(), type_name(obj))))
}

/// A `float32` field's value: a finite value beyond `float32`'s range is
/// refused (rclpy refuses it too), not made infinite.
fn float32(obj: &Bound<'_, PyAny>, what: &dyn Fn() -> String) -> PyResult<f32> {
    let value = float(obj, what)?;
    if value.is_finite() && value.abs() > f64::from(f32::MAX) {
        return Err(PyOverflowError::new_err(format!(
            "{} is float32: {value} is out of its range",
            what()
        )));
    }
    // Narrowing, as rclpy does: the nearest float32.
    #[allow(clippy::cast_possible_truncation)]
    Ok(value as f32)
}

/// The items of a list, tuple or other sequence (not a str or bytes).
fn sequence<'py>(
    obj: &Bound<'py, PyAny>,
    what: &dyn Fn() -> String,
) -> PyResult<Vec<Bound<'py, PyAny>>> {
    if obj.is_instance_of::<PyString>() {
        return Err(PyTypeError::new_err(format!(
            "{} is an array; give a list, not a str",
            what()
        )));
    }
    obj.try_iter()
        .map_err(|_| {
            PyTypeError::new_err(format!(
                "{} is an array; give a list, not {}",
                what(),
                type_name(obj)
            ))
        })?
        .collect()
}

/// A `uint8[]` field's bytes: `bytes`, `bytearray`, a numpy `uint8` array
/// or a list of ints.
fn octets(obj: &Bound<'_, PyAny>, what: &dyn Fn() -> String) -> PyResult<Vec<u8>> {
    if let Ok(bytes) = obj.cast::<PyBytes>() {
        return Ok(bytes.as_bytes().to_vec());
    }
    if let Ok(bytes) = obj.cast::<PyByteArray>() {
        return Ok(bytes.to_vec());
    }
    numbers::<u8>(obj, what)
}

/// An array field's numbers: a 1-D numpy array of exactly the field's
/// dtype, or a sequence of numbers each within the element's range.
fn numbers<T>(obj: &Bound<'_, PyAny>, what: &dyn Fn() -> String) -> PyResult<Vec<T>>
where
    T: numpy::Element + Item + Copy,
{
    if let Ok(array) = obj.cast::<PyUntypedArray>() {
        let expected = numpy::dtype::<T>(obj.py());
        let Ok(typed) = array.cast::<PyArrayDyn<T>>() else {
            return Err(PyTypeError::new_err(format!(
                "{} holds {}, but the array's dtype is {}: convert it with .astype(numpy.{})",
                what(),
                expected.str()?,
                array.dtype().str()?,
                expected.str()?,
            )));
        };
        if typed.ndim() != 1 {
            return Err(PyValueError::new_err(format!(
                "{} is a one-dimensional array, but this array's shape is {:?}: flatten it \
                 with .ravel()",
                what(),
                typed.shape()
            )));
        }
        // numpy arrays may be unaligned (a view of a CDR payload is where
        // its numbers lie): rust-numpy reads only aligned ones, so such an
        // array is copied by numpy into an aligned one first.
        if typed.data().align_offset(std::mem::align_of::<T>()) != 0 {
            return numbers(&obj.call_method0("copy")?, what);
        }
        let readonly = typed.readonly();
        return Ok(match readonly.as_slice() {
            Ok(slice) => slice.to_vec(),
            Err(_) => readonly.as_array().iter().copied().collect(),
        });
    }
    sequence(obj, what)?
        .iter()
        .map(|item| T::from_item(item, what))
        .collect()
}

/// `msg` (a message of `ty` or of any type describing it, or a dict of its
/// fields) as a message of `ty`, owned.
pub(crate) fn message_of(ty: &DynamicType, msg: &Bound<'_, PyAny>) -> PyResult<Message<'static>> {
    if let Ok(message) = msg.cast::<PyMessage>() {
        let message = message.get();
        if let Some(root) = message.root() {
            if root.message.is_of(ty) {
                return Ok(root.message.clone().into_owned());
            }
        }
        return message.to_message_in(ty.default_message());
    }
    if let Ok(dict) = msg.cast::<PyDict>() {
        return fill(ty.default_message(), ty, 0, dict);
    }
    Err(PyTypeError::new_err(format!(
        "a {} or a dict of its fields goes here",
        ty.name()
    )))
}

/// Whether Python sees a field: all but rosidl's placeholder member of an
/// empty message, which rclpy's messages do not list either.
pub(crate) fn shown(name: &str) -> bool {
    name != shm_cdr::describe::PLACEHOLDER_MEMBER
}
