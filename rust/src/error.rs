//! The crate's error type: every invalid input is reported, never panicked on.

use std::fmt;

/// What was wrong with the input of a kernel.
#[derive(Debug, Clone, PartialEq)]
pub enum FieldError {
    /// A parameter is outside its domain (the message says which and why).
    InvalidParameter(String),
    /// An array has the wrong shape or size.
    Shape(String),
    /// An input array holds NaN or infinite values.
    NonFinite(String),
    /// A buffer could not be allocated (the message says which and how large).
    OutOfMemory(String),
}

impl fmt::Display for FieldError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            FieldError::InvalidParameter(m)
            | FieldError::Shape(m)
            | FieldError::NonFinite(m)
            | FieldError::OutOfMemory(m) => f.write_str(m),
        }
    }
}

impl std::error::Error for FieldError {}

/// Shorthand for results of this crate.
pub type Result<T> = std::result::Result<T, FieldError>;

/// `len` zeros, or an `OutOfMemory` error naming `what` when they cannot be allocated (a
/// frame-sized buffer: an infallible allocation would abort the process).
pub(crate) fn try_zeros(len: usize, what: &str) -> Result<Vec<f64>> {
    let mut values = Vec::new();
    values.try_reserve_exact(len).map_err(|_| {
        FieldError::OutOfMemory(format!(
            "cannot allocate {what}: {:.1} GiB",
            len as f64 * 8.0 / f64::from(1u32 << 30)
        ))
    })?;
    values.resize(len, 0.0);
    Ok(values)
}

/// Ok when the noise variance is positive and finite (every filter's precondition).
pub(crate) fn check_noise_var(noise_var: f64) -> Result<()> {
    if noise_var.is_finite() && noise_var > 0.0 {
        return Ok(());
    }
    Err(FieldError::InvalidParameter(format!(
        "noise_var must be positive and finite, got {noise_var}"
    )))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_impossible_buffer_is_an_out_of_memory_error() {
        let err = try_zeros(usize::MAX / 16, "the test buffer").unwrap_err();
        assert!(matches!(err, FieldError::OutOfMemory(ref m) if m.contains("the test buffer")));
        assert_eq!(try_zeros(3, "three").unwrap(), vec![0.0; 3]);
    }
}
