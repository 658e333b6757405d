//! Message types known at run time: the standard set built in (as the
//! distribution `ROS_DISTRO` names defines it), or interface files.

use std::path::PathBuf;

use pyo3::exceptions::{PyLookupError, PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyTuple};
use shm_cdr::describe::Container;
use shm_cdr::dynamic::{DynamicType, Element, FieldDef};
use shm_runtime::rmw::Distro;
use shm_runtime::types::local::LocalInterfaces;

use crate::convert;
use crate::errors::middleware;
use crate::message::{Payload, PyMessage, Root};

/// A ROS 2 message type. Call it to make a message: `Image(height=480,
/// encoding="rgb8")`, every other field at its default.
#[pyclass(name = "MessageType", module = "shm_cdr", frozen)]
pub(crate) struct PyMessageType {
    pub(crate) ty: DynamicType,
}

impl PyMessageType {
    /// The type `obj` names: a `MessageType`, or a name resolved as
    /// [`message_type`] resolves it.
    pub(crate) fn resolve(obj: &Bound<'_, PyAny>) -> PyResult<DynamicType> {
        if let Ok(ty) = obj.cast::<PyMessageType>() {
            return Ok(ty.get().ty.clone());
        }
        if let Ok(name) = obj.extract::<String>() {
            return by_name(&name, &[]);
        }
        Err(PyTypeError::new_err(
            "a message type is a shm_cdr.MessageType or its name (\"pkg/msg/Name\")",
        ))
    }
}

pub(crate) fn by_name(name: &str, interfaces: &[PathBuf]) -> PyResult<DynamicType> {
    let distro = Distro::from_env().map_err(|e| PyValueError::new_err(e.to_string()))?;
    let local = LocalInterfaces::load(interfaces).map_err(middleware)?;
    match shm_runtime::types::message_by_name(distro, name, &local) {
        Some(Ok(resolved)) => Ok(resolved.ty),
        Some(Err(e)) => Err(middleware(e)),
        None => Err(PyLookupError::new_err(format!(
            "no message type {name}: it is not in the standard set of {} and no interface file \
             given defines it (pass interfaces=[\"path/to/pkg\"] for your own .msg files)",
            distro.name()
        ))),
    }
}

/// The message type `name` (`pkg/msg/Name` or `pkg/Name`): from the
/// standard set built in, as the distribution `ROS_DISTRO` names defines it
/// (Kilted if unset), else from the `.msg` files of `interfaces` (package
/// directories, or directories holding packages).
#[pyfunction]
#[pyo3(signature = (name, interfaces = None))]
pub(crate) fn message_type(
    name: &str,
    interfaces: Option<Vec<PathBuf>>,
) -> PyResult<PyMessageType> {
    Ok(PyMessageType {
        ty: by_name(name, interfaces.as_deref().unwrap_or_default())?,
    })
}

/// A field's type as rclpy's `get_fields_and_field_types()` writes it (the
/// IDL names rosidl_generator_py gives: `double[9]`, `string<10>`,
/// `sequence<octet>`, `sequence<geometry_msgs/Point, 5>`).
fn field_type(ty: &DynamicType, field: &FieldDef) -> String {
    let element = match field.element {
        Element::Bool => "boolean".to_owned(),
        Element::Byte => "octet".to_owned(),
        Element::Char | Element::U8 => "uint8".to_owned(),
        Element::I8 => "int8".to_owned(),
        Element::I16 => "int16".to_owned(),
        Element::U16 => "uint16".to_owned(),
        Element::I32 => "int32".to_owned(),
        Element::U32 => "uint32".to_owned(),
        Element::I64 => "int64".to_owned(),
        Element::U64 => "uint64".to_owned(),
        Element::F32 => "float".to_owned(),
        Element::F64 => "double".to_owned(),
        Element::String(None) => "string".to_owned(),
        Element::String(Some(n)) => format!("string<{n}>"),
        Element::WString(None) => "wstring".to_owned(),
        Element::WString(Some(n)) => format!("wstring<{n}>"),
        Element::Message(i) => ty.structs().get(i).map_or_else(String::new, |s| {
            // `pkg/msg/Name` (or a service's or action's part) as `pkg/Name`.
            match s.name.split('/').collect::<Vec<_>>()[..] {
                [package, _, name] => format!("{package}/{name}"),
                _ => s.name.clone(),
            }
        }),
    };
    match field.container {
        Container::Single => element,
        Container::Array(n) => format!("{element}[{n}]"),
        Container::BoundedSequence(n) => format!("sequence<{element}, {n}>"),
        Container::Sequence => format!("sequence<{element}>"),
    }
}

#[pymethods]
impl PyMessageType {
    /// A message of this type: fields from keyword arguments (or one dict),
    /// the rest at their defaults.
    #[pyo3(signature = (*args, **fields))]
    fn __call__(
        &self,
        args: &Bound<'_, PyTuple>,
        fields: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<PyMessage> {
        let message = self.ty.default_message();
        let message = match (args.len(), fields) {
            (0, None) => message,
            (0, Some(fields)) => convert::fill(message, &self.ty, 0, fields)?,
            (1, None) => {
                let dict = args.get_item(0)?;
                let dict = dict.cast::<PyDict>().map_err(|_| {
                    PyTypeError::new_err(format!(
                        "{}(…) takes its fields as keyword arguments or one dict",
                        self.ty.name()
                    ))
                })?;
                convert::fill(message, &self.ty, 0, dict)?
            }
            _ => {
                return Err(PyTypeError::new_err(format!(
                    "{}(…) takes its fields as keyword arguments or one dict, not both",
                    self.ty.name()
                )))
            }
        };
        Ok(PyMessage::new(Root::owned(message)))
    }

    /// `pkg/msg/Name`.
    #[getter]
    fn name(&self) -> &str {
        self.ty.name()
    }

    /// The type's RIHS01 hash, as rosidl computes it.
    #[getter]
    fn hash(&self) -> String {
        self.ty.type_hash()
    }

    /// Each field's name and type, in order, as rclpy's
    /// `get_fields_and_field_types()` gives them (`double[9]`,
    /// `sequence<uint8>`).
    fn get_fields_and_field_types<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let dict = PyDict::new(py);
        for field in self
            .ty
            .root()
            .fields
            .iter()
            .filter(|f| convert::shown(&f.name))
        {
            dict.set_item(&field.name, field_type(&self.ty, field))?;
        }
        Ok(dict)
    }

    /// The message `data` encodes (its CDR bytes, as rclpy's
    /// `serialize_message` gives them): copied once, its arrays views of the
    /// copy.
    fn deserialize(&self, data: &[u8]) -> PyResult<PyMessage> {
        let payload = Payload::Copied(data.to_vec().into_boxed_slice());
        Ok(PyMessage::new(Root::decode(&self.ty, payload)?))
    }

    /// A message of this type from a dict of its fields.
    // A method of the type object, as Python names such constructors.
    #[allow(clippy::wrong_self_convention)]
    fn from_dict(&self, fields: &Bound<'_, PyDict>) -> PyResult<PyMessage> {
        let message = convert::fill(self.ty.default_message(), &self.ty, 0, fields)?;
        Ok(PyMessage::new(Root::owned(message)))
    }

    fn __eq__(&self, other: &Bound<'_, PyAny>) -> bool {
        other
            .cast::<PyMessageType>()
            .is_ok_and(|o| o.get().ty == self.ty)
    }

    fn __hash__(&self) -> u64 {
        use std::hash::{Hash, Hasher};
        let mut h = std::collections::hash_map::DefaultHasher::new();
        self.ty.type_hash().hash(&mut h);
        h.finish()
    }

    fn __repr__(&self) -> String {
        format!("shm_cdr.message_type({:?})", self.ty.name())
    }
}
