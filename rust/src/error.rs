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
}

impl fmt::Display for FieldError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            FieldError::InvalidParameter(m) | FieldError::Shape(m) | FieldError::NonFinite(m) => {
                f.write_str(m)
            }
        }
    }
}

impl std::error::Error for FieldError {}

/// Shorthand for results of this crate.
pub type Result<T> = std::result::Result<T, FieldError>;

/// Ok when the noise variance is positive and finite (every filter's precondition).
pub(crate) fn check_noise_var(noise_var: f64) -> Result<()> {
    if noise_var.is_finite() && noise_var > 0.0 {
        return Ok(());
    }
    Err(FieldError::InvalidParameter(format!(
        "noise_var must be positive and finite, got {noise_var}"
    )))
}
