//! A template (the fragment searched for), with the sums every score needs.

use super::region::MAX_DEVIATION;
use crate::{FieldError, Result};

/// An h × w template as float64: its pixels, their mean-removed copy and their sums.
#[derive(Debug, Clone, PartialEq)]
pub struct Template {
    pub(crate) raw: Vec<f64>,
    pub(crate) centred: Vec<f64>,
    pub(crate) h: usize,
    pub(crate) w: usize,
    /// Σ t.
    pub(crate) sum: f64,
    /// Σ (t − t̄)².
    pub(crate) centred_norm2: f64,
    /// Every pixel equal: the normalised cross-correlation is undefined.
    pub(crate) constant: bool,
}

impl Template {
    /// An h × w template (row-major); an error if it is empty, a pixel is not finite or the
    /// pixels spread beyond ±1e130 about their mean.
    pub fn new(raw: Vec<f64>, h: usize, w: usize) -> Result<Self> {
        if h == 0 || w == 0 {
            return Err(FieldError::Shape(format!(
                "the template is empty (shape ({h}, {w}))"
            )));
        }
        if h.checked_mul(w) != Some(raw.len()) {
            return Err(FieldError::Shape(format!(
                "a ({h}, {w}) template needs {} pixels, got {}",
                h.saturating_mul(w),
                raw.len()
            )));
        }
        if let Some(k) = raw.iter().position(|v| !v.is_finite()) {
            return Err(FieldError::NonFinite(format!(
                "the template has a non-finite pixel (NaN or inf) at (x, y) = ({}, {})",
                k % w,
                k / w
            )));
        }
        let n = raw.len() as f64;
        let sum: f64 = raw.iter().sum();
        let mean = sum / n;
        let centred: Vec<f64> = raw.iter().map(|v| v - mean).collect();
        if centred.iter().any(|d| d.abs() > MAX_DEVIATION) {
            return Err(FieldError::InvalidParameter(format!(
                "the template's pixels spread beyond ±{MAX_DEVIATION:e} about their mean; \
                 rescale it"
            )));
        }
        let centred_norm2 = centred.iter().map(|d| d * d).sum();
        let constant = raw.iter().all(|&v| v == raw[0]);
        Ok(Self {
            raw,
            centred,
            h,
            w,
            sum,
            centred_norm2,
            constant,
        })
    }

    /// Rows.
    pub fn height(&self) -> usize {
        self.h
    }

    /// Columns.
    pub fn width(&self) -> usize {
        self.w
    }

    /// The pixels, row-major.
    pub fn pixels(&self) -> &[f64] {
        &self.raw
    }
}
