//! numpy arrays of a message's number fields: views of the received sample
//! where its bytes lie (in shared memory when it came through it), or new
//! arrays for values built in Python.

use std::ffi::c_void;
use std::sync::Arc;

use numpy::npyffi::{npy_intp, NpyTypes, NPY_ARRAY_WRITEABLE, PY_ARRAY_API};
use numpy::{Element as NumpyElement, PyArray1, PyArrayDescr, PyArrayDescrMethods};
use pyo3::prelude::*;
use shm_cdr::dynamic::{Number, Numbers};
use shm_cdr::Endianness;

use crate::message::Payload;

/// The memory of a received message, kept for as long as a numpy array
/// views it: the array's `base`. It holds the Zenoh sample (its shared
/// memory stays the publisher's to reuse only when every holder let go).
#[pyclass(module = "shm_cdr", frozen)]
pub(crate) struct SampleMemory {
    payload: Arc<Payload>,
}

impl SampleMemory {
    pub(crate) fn of(payload: Arc<Payload>) -> Self {
        Self { payload }
    }
}

#[pymethods]
impl SampleMemory {
    /// Whether the bytes lie in Zenoh shared memory.
    #[getter]
    fn is_shm(&self) -> bool {
        self.payload.is_shm()
    }

    /// The size of the received message, in bytes.
    fn __len__(&self) -> usize {
        self.payload.bytes().len()
    }

    fn __repr__(&self) -> String {
        format!(
            "<SampleMemory: {} bytes{}>",
            self.payload.bytes().len(),
            if self.payload.is_shm() {
                " in shared memory"
            } else {
                ""
            }
        )
    }
}

/// A read-only 1-D array of `len` elements of `dtype` viewing `bytes`, which
/// lie in `payload`'s memory; the array holds `payload` until it is freed.
fn view<'py>(
    py: Python<'py>,
    payload: &Arc<Payload>,
    bytes: &[u8],
    dtype: Bound<'py, PyArrayDescr>,
    len: usize,
) -> PyResult<Bound<'py, PyAny>> {
    let within = payload.bytes().as_ptr_range();
    let ends = bytes.as_ptr_range();
    if ends.start < within.start || ends.end > within.end {
        return Err(pyo3::exceptions::PySystemError::new_err(
            "an array field's bytes lie outside the received message",
        ));
    }
    let base = Bound::new(py, SampleMemory::of(payload.clone()))?.into_any();
    // SAFETY: `bytes` lie within `payload` (checked above; the decoder
    // checked that the `len` elements of `dtype` fill them), whose memory
    // stays where it is, unwritten, for as long as `payload` lives (see
    // `Payload`): `base` holds it. The array is read-only.
    unsafe { memory_view(py, base, bytes.as_ptr() as *mut u8, dtype, len, false) }
}

/// A 1-D array of `len` elements of `dtype` over the memory at `data`,
/// writable if `writable`, holding `base` (the owner of that memory) until
/// it is freed. numpy works out its alignment itself, so numbers that are
/// not aligned in memory (CDR aligns from the body) are read correctly.
///
/// # Safety
/// `data` must point to `len` elements of `dtype` that stay valid for as
/// long as `base` lives, and, if `writable`, that nothing else reads or
/// writes as Rust references while Python may write them.
pub(crate) unsafe fn memory_view<'py>(
    py: Python<'py>,
    base: Bound<'py, PyAny>,
    data: *mut u8,
    dtype: Bound<'py, PyArrayDescr>,
    len: usize,
    writable: bool,
) -> PyResult<Bound<'py, PyAny>> {
    let mut dims = [npy_intp::try_from(len)
        .map_err(|_| pyo3::exceptions::PyOverflowError::new_err("array too long for numpy"))?];
    let flags = if writable { NPY_ARRAY_WRITEABLE } else { 0 };
    // SAFETY: `PyArray_NewFromDescr` takes the reference to `dtype` (given
    // up with `into_dtype_ptr`) and makes a 1-D array of `len` elements over
    // `data`, which the caller promises hold them for as long as `base`
    // lives; `PyArray_SetBaseObject` takes the reference to `base` (given up
    // with `into_ptr`) and numpy keeps it until the array is freed.
    unsafe {
        let subtype = PY_ARRAY_API.get_type_object(py, NpyTypes::PyArray_Type);
        let array = PY_ARRAY_API.PyArray_NewFromDescr(
            py,
            subtype,
            dtype.into_dtype_ptr(),
            1,
            dims.as_mut_ptr(),
            std::ptr::null_mut(),
            data.cast::<c_void>(),
            flags,
            std::ptr::null_mut(),
        );
        if array.is_null() {
            return Err(PyErr::fetch(py));
        }
        let array = Bound::from_owned_ptr(py, array);
        if PY_ARRAY_API.PyArray_SetBaseObject(py, array.as_ptr().cast(), base.into_ptr()) < 0 {
            return Err(PyErr::fetch(py));
        }
        Ok(array)
    }
}

/// `T`'s dtype in `order`.
pub(crate) fn dtype<'py, T: NumpyElement>(
    py: Python<'py>,
    order: Endianness,
) -> PyResult<Bound<'py, PyArrayDescr>> {
    let native = numpy::dtype::<T>(py);
    let swapped = match order {
        Endianness::Little => cfg!(target_endian = "big"),
        Endianness::Big => cfg!(target_endian = "little"),
    };
    if swapped && std::mem::size_of::<T>() > 1 {
        let order = match order {
            Endianness::Little => "<",
            Endianness::Big => ">",
        };
        Ok(native.call_method1("newbyteorder", (order,))?.cast_into()?)
    } else {
        Ok(native)
    }
}

/// An array of `numbers`: a view of the sample where they lie in it, else a
/// new array of their values.
pub(crate) fn numbers<'py, T: Number + NumpyElement>(
    py: Python<'py>,
    numbers: &Numbers<'_, T>,
    payload: Option<&Arc<Payload>>,
) -> PyResult<Bound<'py, PyAny>> {
    if let (Some((bytes, order)), Some(payload)) = (numbers.wire(), payload) {
        return view(py, payload, bytes, dtype::<T>(py, order)?, numbers.len());
    }
    Ok(PyArray1::from_vec(py, numbers.to_vec()).into_any())
}

/// An array of a `uint8[]`/`byte[]`/`char[]` field: a view where it borrows
/// from the sample, else a new array.
pub(crate) fn u8s<'py>(
    py: Python<'py>,
    values: &[u8],
    borrowed: bool,
    payload: Option<&Arc<Payload>>,
) -> PyResult<Bound<'py, PyAny>> {
    match (borrowed, payload) {
        (true, Some(payload)) => view(py, payload, values, numpy::dtype::<u8>(py), values.len()),
        _ => Ok(PyArray1::from_slice(py, values).into_any()),
    }
}

/// An array of an `int8[]` field: a view where it borrows from the sample,
/// else a new array.
pub(crate) fn i8s<'py>(
    py: Python<'py>,
    values: &[i8],
    borrowed: bool,
    payload: Option<&Arc<Payload>>,
) -> PyResult<Bound<'py, PyAny>> {
    match (borrowed, payload) {
        (true, Some(payload)) => {
            let raw: &[u8] = bytemuck::cast_slice(values);
            view(py, payload, raw, numpy::dtype::<i8>(py), raw.len())
        }
        _ => Ok(PyArray1::from_slice(py, values).into_any()),
    }
}
