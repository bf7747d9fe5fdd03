//! Streaming states as flat float64 arrays (the pickled form): counters and flags are stored
//! as exact small integers, and every read is checked, so a truncated array or one saved by
//! another configuration is an error, not a panic.

use crate::{FieldError, Result};

/// Collects a state.
#[derive(Default)]
pub struct Writer(pub(crate) Vec<f64>);

impl Writer {
    pub(crate) fn f64(&mut self, v: f64) {
        self.0.push(v);
    }
    pub(crate) fn f64s(&mut self, v: &[f64]) {
        self.0.extend_from_slice(v);
    }
    pub(crate) fn flag(&mut self, b: bool) {
        self.0.push(f64::from(u8::from(b)));
    }
    pub(crate) fn count(&mut self, n: u64) {
        self.0.push(n as f64);
    }
}

/// Reads a state back.
pub struct Reader<'a>(&'a [f64]);

/// The largest counter stored exactly in a float64.
const MAX_COUNT: f64 = 9_007_199_254_740_992.0;

impl<'a> Reader<'a> {
    pub(crate) fn new(values: &'a [f64]) -> Self {
        Self(values)
    }
    pub(crate) fn corrupt(&self) -> FieldError {
        FieldError::InvalidParameter(
            "the saved state is truncated, altered or was saved with another configuration".into(),
        )
    }
    pub(crate) fn f64(&mut self) -> Result<f64> {
        let (&head, tail) = self.0.split_first().ok_or_else(|| self.corrupt())?;
        self.0 = tail;
        Ok(head)
    }
    pub(crate) fn fill(&mut self, out: &mut [f64]) -> Result<()> {
        for o in out.iter_mut() {
            *o = self.f64()?;
        }
        Ok(())
    }
    pub(crate) fn flag(&mut self) -> Result<bool> {
        match self.f64()? {
            0.0 => Ok(false),
            1.0 => Ok(true),
            _ => Err(self.corrupt()),
        }
    }
    pub(crate) fn count(&mut self) -> Result<u64> {
        let v = self.f64()?;
        if (0.0..=MAX_COUNT).contains(&v) && v.fract() == 0.0 {
            Ok(v as u64)
        } else {
            Err(self.corrupt())
        }
    }
    /// Error unless every number was read.
    pub(crate) fn finish(&self) -> Result<()> {
        if self.0.is_empty() {
            Ok(())
        } else {
            Err(self.corrupt())
        }
    }
}
