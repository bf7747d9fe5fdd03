//! Streaming states as flat float64 arrays (the pickled form): counters and flags are stored
//! as exact small integers, and every read is checked, so a truncated array or one saved by
//! another configuration is an error, not a panic. The loaders check the numbers too (within
//! [`MAX_VALUE`], spreads that are spreads, times in order): an altered state is refused at
//! load, not by a later step.

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

/// Largest |estimate|, spread or covariance entry of a restored state: the samples' range
/// (`MAX_SAMPLE`); beyond it the next step's products leave float64.
pub(crate) const MAX_VALUE: f64 = 1e150;
/// Largest restored statistic built from squared innovations (averages, CUSUM sums).
pub(crate) const MAX_SQUARE: f64 = 1e300;

/// The same last time (both NaN: no sample yet).
pub(crate) fn same_time(a: f64, b: f64) -> bool {
    a == b || (a.is_nan() && b.is_nan())
}

/// Within ±[`MAX_VALUE`] (NaN and infinities are not).
pub(crate) fn within(v: f64) -> bool {
    v.abs() <= MAX_VALUE
}

/// Missing (NaN) or within ±[`MAX_VALUE`].
pub(crate) fn nan_or_within(v: f64) -> bool {
    v.is_nan() || within(v)
}

/// A statistic of squares: in [0, [`MAX_SQUARE`]].
pub(crate) fn square_statistic(v: f64) -> bool {
    (0.0..=MAX_SQUARE).contains(&v)
}

/// Spreads a recursion can hold: the fuzzy spreads (P, P', unused) non-negative, the Kalman
/// covariance (Σxx, Σxv, Σvv) positive semi-definite (up to rounding); entries within
/// ±[`MAX_VALUE`].
pub(crate) fn is_spread(s: &[f64; 3], kalman: bool) -> bool {
    let [a, b, c] = *s;
    let sign_ok = if kalman {
        a >= 0.0 && c >= 0.0 && b * b <= a * c * (1.0 + 1e-9)
    } else {
        a >= 0.0 && b >= 0.0
    };
    s.iter().all(|&v| within(v)) && sign_ok
}

impl<'a> Reader<'a> {
    pub(crate) fn new(values: &'a [f64]) -> Self {
        Self(values)
    }
    pub(crate) fn corrupt(&self) -> FieldError {
        FieldError::InvalidParameter(
            "the saved state is truncated, altered or was saved with another configuration".into(),
        )
    }
    /// The error of a state whose numbers no run could have left (`what` says which).
    pub(crate) fn altered(&self, what: &str) -> FieldError {
        FieldError::InvalidParameter(format!("the saved state is altered: {what}"))
    }
    /// Ok when `ok`, else [`Reader::altered`].
    pub(crate) fn check(&self, ok: bool, what: &str) -> Result<()> {
        if ok {
            Ok(())
        } else {
            Err(self.altered(what))
        }
    }
    /// A time: NaN (none yet) or finite.
    pub(crate) fn time(&mut self) -> Result<f64> {
        let t = self.f64()?;
        self.check(!t.is_infinite(), "an infinite time")?;
        Ok(t)
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
