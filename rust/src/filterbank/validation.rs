//! Checks of a measurement batch: every row is complete (finite) or entirely NaN (missed).

use crate::error::{FieldError, Result};

/// Largest |measurement| accepted: the filters square innovations, and beyond ~1e154 those
/// squares leave float64.
pub const MAX_MEASUREMENT: f64 = 1e150;

/// Per row of m values: true when observed, false when every value is NaN; an error for a
/// partly NaN row, an infinite value or one beyond ±[`MAX_MEASUREMENT`].
pub(crate) fn observed_rows(z: &[f64], m: usize) -> Result<Vec<bool>> {
    z.chunks_exact(m)
        .enumerate()
        .map(|(row, values)| {
            let missing = values.iter().filter(|v| v.is_nan()).count();
            if missing == m {
                return Ok(false);
            }
            if missing > 0 {
                return Err(FieldError::NonFinite(format!(
                    "measurement row {row} is partly NaN: a missed frame is a row of NaN only"
                )));
            }
            if values.iter().any(|v| v.abs() > MAX_MEASUREMENT) {
                return Err(FieldError::NonFinite(format!(
                    "measurement row {row} holds an infinite value or one beyond ±1e150"
                )));
            }
            Ok(true)
        })
        .collect()
}
