//! Message objects: a message of a run-time type, received (its values
//! borrowing from the sample) or built in Python, with attribute access to
//! its fields, nested messages as handles into the same message.

use std::sync::{Arc, Mutex, MutexGuard};

use pyo3::exceptions::{PyAttributeError, PyTypeError};
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict, PyList, PyString};
use shm_cdr::dynamic::{DynamicType, Field, Message, MessageRef, Value};
use shm_runtime::RosSample;

use crate::convert;
use crate::errors::middleware;

/// The bytes of a received message, where they stay until the last holder
/// (the message, a numpy array viewing them) lets go.
// One per received message, in an `Arc`: boxing the sample would add an
// allocation to each.
#[allow(clippy::large_enum_variant)]
pub(crate) enum Payload {
    /// A sample whose payload is one contiguous slice: a Zenoh buffer
    /// (shared memory or the network's) held by the sample.
    Sample(RosSample),
    /// A copy, of a payload that arrived in fragments or of given bytes.
    Copied(Box<[u8]>),
}

impl Payload {
    /// The sample's bytes where they lie if they are one slice, else a copy.
    pub(crate) fn of(sample: RosSample) -> Self {
        if sample.payload().slices().count() == 1 {
            Self::Sample(sample)
        } else {
            Self::Copied(sample.payload().to_bytes().into_owned().into_boxed_slice())
        }
    }

    pub(crate) fn bytes(&self) -> &[u8] {
        match self {
            Self::Sample(sample) => sample.payload().slices().next().unwrap_or_default(),
            Self::Copied(bytes) => bytes,
        }
    }

    pub(crate) fn is_shm(&self) -> bool {
        match self {
            Self::Sample(sample) => sample.is_shm(),
            Self::Copied(_) => false,
        }
    }
}

/// A message and the payload its values may borrow from.
pub(crate) struct Root {
    /// Strings and arrays decoded from `payload` borrow from it: declared
    /// first, so dropped first. Values given in Python are owned. A value
    /// taken out of one `Root` into another is made owned first
    /// ([`transfer`]).
    pub(crate) message: Message<'static>,
    pub(crate) payload: Option<Arc<Payload>>,
}

impl Root {
    pub(crate) fn owned(message: Message<'static>) -> Self {
        Self {
            message,
            payload: None,
        }
    }

    /// Decode `payload` as a message of `ty`; strings are copied from shared
    /// memory (another process maps it), arrays are not.
    pub(crate) fn decode(ty: &DynamicType, payload: Payload) -> PyResult<Self> {
        let payload = Arc::new(payload);
        let bytes = payload.bytes();
        // SAFETY: `bytes` lie in memory `payload` owns: a Zenoh buffer held
        // by the sample (reference-counted, never moved or written while
        // held) or a boxed copy; neither moves when the `Arc` is cloned or
        // moved. The message borrowing them lives in the `Root` beside the
        // `Arc` and is dropped before it; every value leaving the `Root`
        // either is copied (`transfer`, strings to Python) or carries a
        // clone of the `Arc` (numpy views).
        let bytes: &'static [u8] = unsafe { &*std::ptr::from_ref::<[u8]>(bytes) };
        let message = if payload.is_shm() {
            ty.decode_shared(bytes)
        } else {
            ty.decode(bytes)
        }
        .map_err(|e| middleware(format!("a {} that cannot be decoded: {e}", ty.name())))?;
        Ok(Self {
            message,
            payload: Some(payload),
        })
    }
}

/// One step from a message to one it holds.
#[derive(Clone, Copy, Debug)]
pub(crate) enum Step {
    /// The message nested by value in field `.0`.
    Nested(usize),
    /// Element `.1` of the array or sequence of messages in field `.0`.
    Element(usize, usize),
}

/// The message at `path` from `message`.
fn at<'m>(message: &'m Message<'static>, path: &[Step]) -> Option<MessageRef<'m, 'static>> {
    let mut here = message.as_message_ref();
    for step in path {
        here = match *step {
            Step::Nested(field) => match here.fields().nth(field)? {
                (_, Field::Message(nested)) => nested,
                _ => return None,
            },
            Step::Element(field, element) => match here.fields().nth(field)? {
                (_, Field::Value(Value::Messages(messages))) => messages.get(element)?,
                _ => return None,
            },
        };
    }
    Some(here)
}

/// Set field `field` of the message at `path` to `value`.
fn set_at(
    message: &mut Message<'static>,
    path: &[Step],
    field: &str,
    value: Value<'static>,
) -> Result<(), String> {
    let Some((step, rest)) = path.split_first() else {
        return message.set(field, value).map_err(|e| e.to_string());
    };
    if path.iter().all(|step| matches!(step, Step::Nested(_))) {
        // Messages nested by value: set in place, none of them copied.
        let mut names = Vec::with_capacity(path.len() + 1);
        let mut at = message.as_message_ref();
        for step in path {
            let Step::Nested(i) = *step else { break };
            let Some((name, Field::Message(nested))) = at.fields().nth(i) else {
                return Err("the message changed under this handle".to_owned());
            };
            names.push(name.to_owned());
            at = nested;
        }
        let mut names: Vec<&str> = names.iter().map(String::as_str).collect();
        names.push(field);
        return message.set_path(&names, value).map_err(|e| e.to_string());
    }
    let name_of = |i: usize| {
        message
            .fields()
            .nth(i)
            .map(|(name, _)| name.to_owned())
            .ok_or_else(|| "the message changed under this handle".to_owned())
    };
    match *step {
        Step::Nested(i) => {
            let name = name_of(i)?;
            let mut nested = message
                .message(&name)
                .ok_or_else(|| format!("{name} is not a nested message"))?
                .to_message();
            set_at(&mut nested, rest, field, value)?;
            message
                .set(&name, Value::Message(Box::new(nested)))
                .map_err(|e| e.to_string())
        }
        Step::Element(i, k) => {
            let name = name_of(i)?;
            let Some(Value::Messages(messages)) = message.value(&name) else {
                return Err(format!("{name} is not an array of messages"));
            };
            let mut elements: Vec<Message<'static>> =
                messages.iter().map(|m| m.to_message()).collect();
            let mut rebuilt = (**messages).clone();
            let element = elements
                .get_mut(k)
                .ok_or_else(|| format!("{name}[{k}] is past its end"))?;
            set_at(element, rest, field, value)?;
            rebuilt.clear();
            for element in elements {
                rebuilt.push(element).map_err(|e| e.to_string())?;
            }
            message
                .set(&name, Value::Messages(Box::new(rebuilt)))
                .map_err(|e| e.to_string())
        }
    }
}

/// `into`, a message of the same name as `from` (of any type that
/// describes it), with `from`'s values, copied: for a message taken from
/// one message (or type) into another.
pub(crate) fn transfer(
    from: &MessageRef<'_, '_>,
    mut into: Message<'static>,
) -> Result<Message<'static>, String> {
    if from.type_name() != into.type_name() {
        return Err(format!(
            "a {} where a {} goes",
            from.type_name(),
            into.type_name()
        ));
    }
    for (name, field) in from.fields() {
        let value = match field {
            Field::Message(nested) => {
                let target = into
                    .message(name)
                    .ok_or_else(|| format!("{} has no field {name}", into.type_name()))?
                    .to_message();
                Value::Message(Box::new(transfer(&nested, target)?))
            }
            Field::Value(Value::Messages(messages)) => {
                let Some(Value::Messages(target)) = into.value(name) else {
                    return Err(format!(
                        "{}'s field {name} is not an array of messages",
                        into.type_name()
                    ));
                };
                let mut target = (**target).clone();
                let element = target.default_element();
                target.clear();
                for m in messages.iter() {
                    target
                        .push(transfer(&m, element.clone())?)
                        .map_err(|e| e.to_string())?;
                }
                Value::Messages(Box::new(target))
            }
            Field::Value(value) => value.clone().into_owned(),
        };
        into.set(name, value).map_err(|e| e.to_string())?;
    }
    Ok(into)
}

/// `obj.name` as for any object, without the object's own
/// `__getattribute__`: its methods and other attributes.
pub(crate) fn generic_getattr<'py>(
    obj: &Bound<'py, PyAny>,
    name: &Bound<'py, PyString>,
) -> PyResult<Bound<'py, PyAny>> {
    // SAFETY: both pointers are of live objects, held by the `Bound`s for
    // the call, with the GIL held (`'py`). `PyObject_GenericGetAttr` returns
    // a new reference, or NULL with an exception set: what
    // `from_owned_ptr_or_err` takes over.
    unsafe {
        Bound::from_owned_ptr_or_err(
            obj.py(),
            pyo3::ffi::PyObject_GenericGetAttr(obj.as_ptr(), name.as_ptr()),
        )
    }
}

/// A ROS 2 message. Its fields are attributes: numbers as `int`, `float`
/// and `bool`, strings as `str`, arrays of numbers as numpy arrays (views of
/// the received sample, read-only, where it came from), arrays of strings
/// and messages as lists, nested messages as messages that belong to this
/// one (changing them changes it).
#[pyclass(name = "Message", module = "shm_cdr", frozen)]
pub(crate) struct PyMessage {
    root: Arc<Mutex<Root>>,
    path: Vec<Step>,
}

impl PyMessage {
    pub(crate) fn new(root: Root) -> Self {
        Self {
            root: Arc::new(Mutex::new(root)),
            path: Vec::new(),
        }
    }

    pub(crate) fn lock(&self) -> MutexGuard<'_, Root> {
        // Each change to a message is one `set`, left whole by a panic.
        self.root.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// Run `f` with this message, raising if the handle no longer reaches
    /// one (an element of an array that was shortened since).
    pub(crate) fn with<R>(
        &self,
        f: impl FnOnce(&MessageRef<'_, 'static>, Option<&Arc<Payload>>) -> PyResult<R>,
    ) -> PyResult<R> {
        let root = self.lock();
        let message = at(&root.message, &self.path).ok_or_else(|| {
            PyAttributeError::new_err(
                "this message was an element of an array that no longer holds it",
            )
        })?;
        f(&message, root.payload.as_ref())
    }

    /// The message's values as a standalone message of `ty` (the type of
    /// whatever it goes into), copied.
    pub(crate) fn to_message_in(&self, into: Message<'static>) -> PyResult<Message<'static>> {
        self.with(|m, _| transfer(m, into).map_err(PyTypeError::new_err))
    }

    /// The whole message this one belongs to, for publishing.
    pub(crate) fn root(&self) -> Option<MutexGuard<'_, Root>> {
        self.path.is_empty().then(|| self.lock())
    }

    pub(crate) fn type_name(&self) -> PyResult<String> {
        self.with(|m, _| Ok(m.type_name().to_owned()))
    }
}

impl PyMessage {
    /// The field `name` as Python reads it; `None` if the message has no
    /// such field.
    pub(crate) fn field(&self, py: Python<'_>, name: &str) -> PyResult<Option<Py<PyAny>>> {
        self.with(|message, payload| {
            let Some((index, (_, field))) =
                message.fields().enumerate().find(|(_, (n, _))| *n == name)
            else {
                return Ok(None);
            };
            Ok(Some(match field {
                Field::Message(_) => Py::new(py, self.child(Step::Nested(index)))?.into_any(),
                Field::Value(Value::Messages(messages)) => {
                    let list = PyList::empty(py);
                    for k in 0..messages.len() {
                        list.append(Py::new(py, self.child(Step::Element(index, k)))?)?;
                    }
                    list.into_any().unbind()
                }
                Field::Value(value) => convert::to_py(py, value, payload)?.unbind(),
            }))
        })
    }
}

#[pymethods]
impl PyMessage {
    /// Fields first, as rclpy's messages read them; anything else (the
    /// methods) as any object's. A field read through `__getattr__` alone
    /// would first fail the generic lookup, raising and formatting an
    /// `AttributeError` each time: most of the cost of reading a field.
    fn __getattribute__<'py>(
        slf: &Bound<'py, Self>,
        name: &Bound<'py, PyString>,
    ) -> PyResult<Py<PyAny>> {
        if let Some(value) = slf.get().field(slf.py(), name.to_str()?)? {
            return Ok(value);
        }
        Ok(generic_getattr(slf.as_any(), name)?.unbind())
    }

    /// Only after the lookup above failed: the error names the fields.
    fn __getattr__(&self, name: &str) -> PyResult<Py<PyAny>> {
        Err(self.with(|message, _| Ok(no_field(message, name)))?)
    }

    fn __setattr__(&self, name: &str, value: &Bound<'_, PyAny>) -> PyResult<()> {
        // What the value must be, read under the lock; the value is
        // converted without it (converting may read another handle of this
        // very message).
        let (ty, parent, field) = self.with(|message, _| {
            let ty = message.ty().clone();
            let parent = ty
                .structs()
                .iter()
                .position(|s| s.name == message.type_name())
                .ok_or_else(|| no_field(message, name))?;
            let field = ty.structs()[parent]
                .field_index(name)
                .ok_or_else(|| no_field(message, name))?;
            Ok((ty, parent, field))
        })?;
        let field = &ty.structs()[parent].fields[field];
        let converted = convert::from_py(value, &ty, parent, field)?;
        let mut root = self.lock();
        set_at(&mut root.message, &self.path, name, converted)
            .map_err(|e| pyo3::exceptions::PyValueError::new_err(format!("{name}: {e}")))
    }

    fn __delattr__(&self, name: &str) -> PyResult<()> {
        Err(PyAttributeError::new_err(format!(
            "a message's field cannot be deleted ({name}); set it to a value instead"
        )))
    }

    fn __dir__(&self) -> PyResult<Vec<String>> {
        let mut names: Vec<String> = ["to_dict", "serialize", "copy", "type_name", "memory"]
            .into_iter()
            .map(str::to_owned)
            .collect();
        self.with(|m, _| {
            names.extend(
                m.fields()
                    .filter(|(n, _)| convert::shown(n))
                    .map(|(n, _)| n.to_owned()),
            );
            Ok(())
        })?;
        Ok(names)
    }

    /// The message's type, `pkg/msg/Name`.
    #[getter(type_name)]
    fn py_type_name(&self) -> PyResult<String> {
        self.type_name()
    }

    /// The received sample's memory this message's arrays view (`None` for
    /// a message built in Python): `memory.is_shm` tells whether it came
    /// through shared memory.
    #[getter]
    fn memory(&self, py: Python<'_>) -> PyResult<Option<Py<crate::arrays::SampleMemory>>> {
        let payload = self.lock().payload.clone();
        payload
            .map(|payload| Py::new(py, crate::arrays::SampleMemory::of(payload)))
            .transpose()
    }

    /// The fields as a dict (nested messages as dicts, arrays of numbers as
    /// numpy arrays, arrays of messages as lists of dicts).
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        self.with(|m, payload| convert::to_dict(py, m, payload))
    }

    /// The message's CDR encoding, as rclpy's `serialize_message` gives it.
    fn serialize<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyBytes>> {
        let bytes = self.with(|m, _| {
            shm_cdr::to_vec(&m.to_message())
                .map_err(|e| middleware(format!("cannot encode a {}: {e}", m.type_name())))
        })?;
        Ok(PyBytes::new(py, &bytes))
    }

    /// A message of its own with the same values, copied: changing it
    /// changes nothing else.
    fn copy(&self) -> PyResult<Self> {
        self.with(|m, _| Ok(Self::new(Root::owned(m.to_message().into_owned()))))
    }

    fn __copy__(&self) -> PyResult<Self> {
        self.copy()
    }

    fn __deepcopy__(&self, _memo: &Bound<'_, PyAny>) -> PyResult<Self> {
        self.copy()
    }

    fn __eq__(&self, other: &Bound<'_, PyAny>) -> PyResult<bool> {
        let Ok(other) = other.cast::<PyMessage>() else {
            return Ok(false);
        };
        let other = other.get();
        if Arc::ptr_eq(&self.root, &other.root) {
            let root = self.lock();
            let a = at(&root.message, &self.path).map(|m| m.to_message());
            let b = at(&root.message, &other.path).map(|m| m.to_message());
            return Ok(matches!((a, b), (Some(a), Some(b)) if a == b));
        }
        let theirs = other.with(|m, _| Ok(m.to_message()))?;
        self.with(|m, _| {
            let ours = m.to_message();
            Ok(ours.type_name() == theirs.type_name()
                && m.ty().type_hash() == theirs.as_message_ref().ty().type_hash()
                && transfer(&theirs.as_message_ref(), ours.clone()).is_ok_and(|t| t == ours))
        })
    }

    fn __repr__(&self, py: Python<'_>) -> PyResult<String> {
        self.with(|m, payload| convert::repr(py, m, payload))
    }

    fn __reduce__(&self) -> PyResult<Py<PyAny>> {
        Err(PyTypeError::new_err(
            "a message is pickled as its CDR bytes: pickle msg.serialize() and the type's name, \
             and rebuild it with shm_cdr.message_type(name).deserialize(bytes)",
        ))
    }
}

impl PyMessage {
    fn child(&self, step: Step) -> Self {
        let mut path = self.path.clone();
        path.push(step);
        Self {
            root: self.root.clone(),
            path,
        }
    }
}

fn no_field(message: &MessageRef<'_, '_>, name: &str) -> PyErr {
    let fields: Vec<&str> = message
        .fields()
        .map(|(n, _)| n)
        .filter(|n| convert::shown(n))
        .collect();
    PyAttributeError::new_err(format!(
        "{} has no field '{name}'; its fields are: {}",
        message.type_name(),
        fields.join(", ")
    ))
}
