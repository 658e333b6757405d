//! Loans: a message built in the buffer its publisher lends (shared memory
//! at or above the pool's threshold), its sequences of numbers writable
//! numpy arrays where they lie, its other fields set as on any message, and
//! published as it lies: no copy of the arrays on the way out.

use std::sync::{Mutex, MutexGuard};

use numpy::PyArrayDescr;
use pyo3::exceptions::{PyAttributeError, PyRuntimeError, PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyString};
use shm_cdr::dynamic::{DynamicType, Element, InPlaceLayout, Message};
use shm_cdr::Endianness;
use shm_runtime::{BufferLoan, LoanedPayload, PayloadKind};

use crate::arrays::{dtype, memory_view};
use crate::message::{generic_getattr, PyMessage, Root};

/// Where a loan's bytes are.
enum LoanState {
    /// Being filled: the buffer, writable.
    Lent(BufferLoan),
    /// Published: the same memory, frozen, kept for the arrays that still
    /// view it (a pool chunk is reused only when they are gone too).
    Sent(#[allow(dead_code, reason = "held for the memory the arrays view")] LoanedPayload),
    /// Between the two, under the lock only.
    Moving,
}

/// The memory of a loan, the base of its numpy arrays: the buffer the
/// publisher lent, kept for as long as an array views it.
#[pyclass(module = "shm_cdr", frozen)]
pub(crate) struct LoanMemory {
    /// The buffer never moves: a pool chunk stays mapped where it is, a heap
    /// buffer is handed to Zenoh as it lies when frozen (`BufferLoan::freeze`
    /// copies nothing). So the arrays stay valid across publishing.
    state: Mutex<LoanState>,
    size: usize,
    kind: PayloadKind,
}

impl LoanMemory {
    fn lock(&self) -> MutexGuard<'_, LoanState> {
        self.state.lock().unwrap_or_else(|p| p.into_inner())
    }
}

#[pymethods]
impl LoanMemory {
    /// Whether the buffer lies in Zenoh shared memory.
    #[getter]
    fn is_shm(&self) -> bool {
        self.kind == PayloadKind::Shm
    }

    /// Where the buffer lies, as `Publisher.publish` names it (`shm`,
    /// `heap`, `heap_fallback`, ...).
    #[getter]
    fn kind(&self) -> String {
        crate::node::kind_name(self.kind)
    }

    /// Whether the message was published.
    #[getter]
    fn published(&self) -> bool {
        !matches!(*self.lock(), LoanState::Lent(_))
    }

    /// The message's size in bytes.
    fn __len__(&self) -> usize {
        self.size
    }

    fn __repr__(&self) -> String {
        format!(
            "<LoanMemory: {} bytes, {}{}>",
            self.size,
            crate::node::kind_name(self.kind),
            if self.published() { ", published" } else { "" }
        )
    }
}

/// A message being built in its publisher's buffer. Its sequences of numbers
/// given as lengths to `Publisher.loan` are writable numpy arrays where they
/// will be sent from (fill them in place: `loan.data[:] = frame`,
/// `numpy.copyto(loan.data, frame)`, or a function's `out=`); its other
/// fields are set as on any message, before `Publisher.publish(loan)` sends
/// it without copying the arrays. Strings and other sequences keep the
/// length they had when the loan was made (the arrays lie after them).
///
/// After publishing, the loan is spent: its arrays are made read-only, and
/// the memory stays valid while any array still views it (a view made with
/// `reshape` or slicing keeps its own flags: do not write through one after
/// publishing; the message has gone).
#[pyclass(name = "Loan", module = "shm_cdr", frozen)]
pub(crate) struct PyLoan {
    publisher: Py<PyAny>,
    message: Py<PyMessage>,
    layout: InPlaceLayout,
    memory: Py<LoanMemory>,
    /// Each array's field name and its view.
    arrays: Vec<(String, Py<PyAny>)>,
}

impl PyLoan {
    /// Lay `message` out with the `lengths` (top-level field names) filled in
    /// place, in a buffer `publisher` lends; the arrays zeroed if `zeroed`.
    pub(crate) fn new(
        py: Python<'_>,
        publisher: Py<PyAny>,
        ty: &DynamicType,
        lend: impl FnOnce(usize) -> BufferLoan + Send,
        message: Message<'static>,
        lengths: &Bound<'_, PyDict>,
        zeroed: bool,
    ) -> PyResult<Self> {
        let mut arrays: Vec<(String, usize)> = Vec::with_capacity(lengths.len());
        for (name, len) in lengths.iter() {
            let name: String = name.extract()?;
            let len: usize = len.extract().map_err(|_| {
                PyTypeError::new_err(format!(
                    "{name}: give the number of elements to lend (an int, 0 or more)"
                ))
            })?;
            arrays.push((name, len));
        }
        if arrays.is_empty() {
            return Err(PyTypeError::new_err(format!(
                "name the sequences to fill in place with their lengths, as \
                 loan(data=n); {} has: {}",
                message.type_name(),
                in_place_fields(ty).join(", ")
            )));
        }
        let paths: Vec<[&str; 1]> = arrays.iter().map(|(name, _)| [name.as_str()]).collect();
        let wanted: Vec<(&[&str], usize)> = paths
            .iter()
            .zip(&arrays)
            .map(|(path, (_, len))| (&path[..], *len))
            .collect();
        let layout = ty
            .lay_out_in_place(&message, &wanted)
            .map_err(|e| PyValueError::new_err(e.to_string()))?;
        let mut lent = py.detach(|| lend(layout.size()));
        let buffer = lent.as_mut_slice();
        if zeroed {
            for array in layout.arrays() {
                if let Some(bytes) = buffer.get_mut(array.range()) {
                    bytes.fill(0);
                }
            }
        }
        let data = buffer.as_mut_ptr() as usize;
        let memory = Py::new(
            py,
            LoanMemory {
                kind: lent.kind(),
                size: lent.size(),
                state: Mutex::new(LoanState::Lent(lent)),
            },
        )?;
        let mut views = Vec::with_capacity(arrays.len());
        for ((name, _), array) in arrays.into_iter().zip(layout.arrays()) {
            let range = array.range();
            if range.end > layout.size() {
                return Err(PyRuntimeError::new_err(
                    "an array laid out past the end of its loan",
                ));
            }
            let descr = element_dtype(py, array.element())?;
            // SAFETY: `range` lies within the buffer of `layout.size()` bytes
            // at `data` (checked above), which stays valid and unmoved for as
            // long as `memory`, the array's base, lives (see `LoanMemory`):
            // `array.len()` elements of the element's size, little-endian as
            // the dtype states. Rust writes only the bytes around the arrays
            // (`InPlaceLayout::write_around`), never those.
            let view = unsafe {
                memory_view(
                    py,
                    memory.bind(py).clone().into_any(),
                    (data + range.start) as *mut u8,
                    descr,
                    array.len(),
                    true,
                )?
            };
            views.push((name, view.unbind()));
        }
        Ok(Self {
            publisher,
            message: Py::new(py, PyMessage::new(Root::owned(message)))?,
            layout,
            memory,
            arrays: views,
        })
    }

    /// Write the rest of the message around the arrays, freeze the buffer
    /// and hand it over, keeping a clone for the arrays; the arrays are made
    /// read-only. Raises, leaving the loan as it was, if the message no
    /// longer lies as laid out, or if it was published already.
    pub(crate) fn take_for(
        &self,
        py: Python<'_>,
        publisher: &Bound<'_, PyAny>,
    ) -> PyResult<LoanedPayload> {
        if !self.publisher.bind(py).is(publisher) {
            return Err(PyValueError::new_err(
                "this loan was made by another publisher: publish it with the publisher whose \
                 loan() made it",
            ));
        }
        let memory = self.memory.get();
        let mut state = memory.lock();
        let LoanState::Lent(lent) = &mut *state else {
            return Err(spent());
        };
        {
            let message = self.message.get().lock();
            self.layout
                .write_around(&message.message, lent.as_mut_slice())
                .map_err(|e| PyValueError::new_err(e.to_string()))?;
        }
        let LoanState::Lent(lent) = std::mem::replace(&mut *state, LoanState::Moving) else {
            return Err(spent());
        };
        let payload = lent.freeze();
        *state = LoanState::Sent(payload.clone());
        drop(state);
        for (_, view) in &self.arrays {
            view.bind(py).call_method1("setflags", ((), false))?;
        }
        Ok(payload)
    }
}

fn spent() -> PyErr {
    PyRuntimeError::new_err("this loan was published already: loan() again for the next message")
}

/// The dtype of an element of a sequence filled in place, little-endian as
/// CDR's bytes are written.
fn element_dtype(py: Python<'_>, element: Element) -> PyResult<Bound<'_, PyArrayDescr>> {
    let order = Endianness::Little;
    match element {
        Element::Byte | Element::Char | Element::U8 => dtype::<u8>(py, order),
        Element::I8 => dtype::<i8>(py, order),
        Element::I16 => dtype::<i16>(py, order),
        Element::U16 => dtype::<u16>(py, order),
        Element::I32 => dtype::<i32>(py, order),
        Element::U32 => dtype::<u32>(py, order),
        Element::I64 => dtype::<i64>(py, order),
        Element::U64 => dtype::<u64>(py, order),
        Element::F32 => dtype::<f32>(py, order),
        Element::F64 => dtype::<f64>(py, order),
        _ => Err(PyTypeError::new_err(
            "only sequences of numbers and bytes are filled in place",
        )),
    }
}

/// The top-level fields of a message of `ty` that can be filled in place.
fn in_place_fields(ty: &DynamicType) -> Vec<String> {
    ty.root()
        .fields
        .iter()
        .filter(|f| {
            f.element.is_number()
                && matches!(
                    f.container,
                    shm_cdr::describe::Container::Sequence
                        | shm_cdr::describe::Container::BoundedSequence(_)
                )
        })
        .map(|f| f.name.clone())
        .collect()
}

#[pymethods]
impl PyLoan {
    /// The message's fields first, then the loan's own attributes (as
    /// [`PyMessage`]'s, without an `AttributeError` raised per field read).
    fn __getattribute__<'py>(
        slf: &Bound<'py, Self>,
        name: &Bound<'py, PyString>,
    ) -> PyResult<Py<PyAny>> {
        let this = slf.get();
        let py = slf.py();
        let key = name.to_str()?;
        if let Some((_, view)) = this.arrays.iter().find(|(n, _)| n == key) {
            if this.memory.get().published() {
                return Err(spent());
            }
            return Ok(view.clone_ref(py));
        }
        if let Some(value) = this.message.get().field(py, key)? {
            if this.memory.get().published() {
                return Err(spent());
            }
            return Ok(value);
        }
        Ok(generic_getattr(slf.as_any(), name)?.unbind())
    }

    /// Only after the lookup above failed: the message's error, naming its
    /// fields.
    fn __getattr__(&self, py: Python<'_>, name: &str) -> PyResult<Py<PyAny>> {
        if self.memory.get().published() {
            return Err(spent());
        }
        Ok(self.message.bind(py).getattr(name)?.unbind())
    }

    fn __setattr__(&self, py: Python<'_>, name: &str, value: &Bound<'_, PyAny>) -> PyResult<()> {
        if self.memory.get().published() {
            return Err(spent());
        }
        if let Some((_, view)) = self.arrays.iter().find(|(n, _)| n == name) {
            // numpy's assignment into the array where it lies (its shape
            // and casting rules).
            let ellipsis = py.Ellipsis();
            return view.bind(py).set_item(ellipsis, value);
        }
        self.message.bind(py).setattr(name, value)
    }

    fn __delattr__(&self, name: &str) -> PyResult<()> {
        Err(PyAttributeError::new_err(format!(
            "a message's field cannot be deleted ({name}); set it to a value instead"
        )))
    }

    /// The loan's buffer: `memory.is_shm`, `memory.kind`, `len(memory)`.
    #[getter]
    fn memory(&self, py: Python<'_>) -> Py<LoanMemory> {
        self.memory.clone_ref(py)
    }

    /// The message with its arrays as they are now (copied): for printing
    /// or checking before publishing.
    fn to_message(&self, py: Python<'_>) -> PyResult<PyMessage> {
        let mut message = self.message.get().lock().message.clone();
        for (name, view) in &self.arrays {
            let ty = self.layout.ty();
            let field = ty
                .root()
                .fields
                .iter()
                .find(|f| &f.name == name)
                .cloned()
                .ok_or_else(|| PyAttributeError::new_err(name.clone()))?;
            let value = crate::convert::from_py(view.bind(py), ty, 0, &field)?;
            message
                .set(name, value)
                .map_err(|e| PyValueError::new_err(e.to_string()))?;
        }
        Ok(PyMessage::new(Root::owned(message)))
    }

    fn __repr__(&self) -> PyResult<String> {
        let memory = self.memory.get();
        let names: Vec<&str> = self.arrays.iter().map(|(n, _)| n.as_str()).collect();
        let type_name = self.message.get().type_name()?;
        Ok(format!(
            "<Loan of a {type_name}: {} bytes, {}, arrays {}{}>",
            memory.size,
            crate::node::kind_name(memory.kind),
            names.join(", "),
            if memory.published() {
                ", published"
            } else {
                ""
            }
        ))
    }
}
