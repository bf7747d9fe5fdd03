//! From Python arguments to the kernels' slices: the dtype dispatch, C-contiguity and the
//! shapes of images, stacks and outputs.

use numpy::ndarray::Dimension;
use numpy::{
    Element, PyReadonlyArray, PyReadwriteArray, PyReadwriteArrayDyn, PyUntypedArray,
    PyUntypedArrayMethods,
};
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;

/// Evaluates `$body` with `$array` bound to `$any` (a `&Bound<PyAny>`) extracted as
/// `$kind<T>` for the first `T` of the list whose dtype the array has (a numpy array of that
/// dtype, native byte order), `$otherwise` if none matches: one copy of `$body` per dtype.
macro_rules! with_dtype {
    ($any:expr, $kind:ident<$($t:ty),+>, |$array:ident| $body:expr, else $otherwise:expr) => {
        $crate::python::convert::with_dtype!(@try $any, $kind, |$array| $body, $otherwise, $($t),+)
    };
    (@try $any:expr, $kind:ident, |$array:ident| $body:expr, $otherwise:expr,
     $t:ty $(, $rest:ty)*) => {
        if let Ok(array) = $any.extract::<$kind<$t>>() {
            #[allow(unused_mut)]
            let mut $array = array;
            $body
        } else {
            $crate::python::convert::with_dtype!(
                @try $any, $kind, |$array| $body, $otherwise $(, $rest)*
            )
        }
    };
    (@try $any:expr, $kind:ident, |$array:ident| $body:expr, $otherwise:expr) => {
        $otherwise
    };
}
pub(super) use with_dtype;

/// The argument `name` as a numpy array of `ndim` dimensions, any dtype (dispatched next by
/// `with_dtype!`).
pub(super) fn untyped_array<'a, 'py>(
    any: &'a Bound<'py, PyAny>,
    name: &str,
    ndim: usize,
) -> PyResult<&'a Bound<'py, PyUntypedArray>> {
    let array = any
        .cast::<PyUntypedArray>()
        .map_err(|_| PyTypeError::new_err(format!("{name} must be a numpy array")))?;
    if array.ndim() != ndim {
        return Err(PyValueError::new_err(format!(
            "{name} must be {ndim}-D, got {} dimensions",
            array.ndim()
        )));
    }
    Ok(array)
}

/// The TypeError for an image array `name` whose dtype no pixel kernel takes.
pub(super) fn pixel_dtype_error(array: &Bound<'_, PyUntypedArray>, name: &str) -> PyErr {
    PyTypeError::new_err(format!(
        "{name} dtype must be uint8, uint16, float32 or float64 (native byte order), got {}",
        array.dtype()
    ))
}

/// The values of an array `name`, checked C-contiguous.
pub(super) fn contiguous<'a, T: Element, D: Dimension>(
    a: &'a PyReadonlyArray<'_, T, D>,
    name: &str,
) -> PyResult<&'a [T]> {
    a.as_slice()
        .map_err(|_| PyValueError::new_err(format!("{name} must be C-contiguous")))
}

/// The shape and the values of a writable array `name`, checked C-contiguous.
pub(super) fn shaped_mut<'a, T: Element>(
    a: &'a mut PyReadwriteArrayDyn<'_, T>,
    name: &str,
) -> PyResult<(Vec<usize>, &'a mut [T])> {
    let shape = a.shape().to_vec();
    Ok((shape, contiguous_mut(a, name)?))
}

/// The values of a writable array `name`, checked C-contiguous.
pub(super) fn contiguous_mut<'a, T: Element, D: Dimension>(
    a: &'a mut PyReadwriteArray<'_, T, D>,
    name: &str,
) -> PyResult<&'a mut [T]> {
    a.as_slice_mut()
        .map_err(|_| PyValueError::new_err(format!("{name} must be C-contiguous")))
}

/// (frames, height, width) of an image (H, W) or a stack (F, H, W).
pub(super) fn stack_dims(shape: &[usize]) -> PyResult<(usize, usize, usize)> {
    match shape {
        [h, w] => Ok((1, *h, *w)),
        [f, h, w] => Ok((*f, *h, *w)),
        _ => Err(PyValueError::new_err("z must be 2-D or 3-D")),
    }
}

/// The values of an output array `name` of `shape`, checked shape and C-contiguous.
pub(super) fn output<'a>(
    out: &'a mut PyReadwriteArrayDyn<'_, f64>,
    shape: &[usize],
    name: &str,
) -> PyResult<&'a mut [f64]> {
    if out.shape() != shape {
        return Err(PyValueError::new_err(format!(
            "{name} must have the shape of z"
        )));
    }
    contiguous_mut(out, name)
}
