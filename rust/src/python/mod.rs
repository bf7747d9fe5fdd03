//! The thin binding layer: `kalmanfield._core`, one file per domain, each with its
//! `register`. Validation of Python-side types happens here (`convert`); every numerical
//! check is done by the plain-Rust kernels, whose errors become ValueError.

use crate::error::FieldError;
use pyo3::exceptions::{PyMemoryError, PyValueError};
use pyo3::prelude::*;

mod branching;
mod convert;
mod denoising;
mod field;
mod filterbank;
mod identification;
mod kalman;
mod rowfilter;
mod segment;
mod threads;
mod trajectory;

pyo3::create_exception!(
    _core,
    NonFiniteError,
    PyValueError,
    "A NaN or infinite value where the kernel needs a finite one (FieldError::NonFinite)."
);

impl From<FieldError> for PyErr {
    fn from(e: FieldError) -> PyErr {
        match e {
            FieldError::NonFinite(_) => NonFiniteError::new_err(e.to_string()),
            FieldError::OutOfMemory(_) => PyMemoryError::new_err(e.to_string()),
            _ => PyValueError::new_err(e.to_string()),
        }
    }
}

#[pymodule]
fn _core(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("NonFiniteError", m.py().get_type::<NonFiniteError>())?;
    field::register(m)?;
    identification::register(m)?;
    rowfilter::register(m)?;
    denoising::register(m)?;
    segment::register(m)?;
    branching::register(m)?;
    kalman::register(m)?;
    filterbank::register(m)?;
    trajectory::register(m)?;
    Ok(())
}
