//! Checks of a measurement batch: every row is complete (finite) or entirely NaN (missed).

use crate::{FieldError, Result};

/// Largest |measurement| accepted: the filters square innovations, and beyond ~1e154 those
/// squares leave float64.
pub const MAX_MEASUREMENT: f64 = 1e150;

/// The observed rows (see [`observed_rows`]) of a batch `z` of `n_traj` × `n_frames` × `m`
/// values for a stream that follows `followed` trajectories (0: not started).
pub(crate) fn checked_batch(
    z: &[f64],
    n_traj: usize,
    n_frames: usize,
    m: usize,
    followed: usize,
) -> Result<Vec<bool>> {
    if n_traj == 0 {
        return Err(FieldError::Shape(
            "a batch needs at least one trajectory".into(),
        ));
    }
    if followed != 0 && n_traj != followed {
        return Err(FieldError::Shape(format!(
            "this stream follows {followed} trajectories, got {n_traj}"
        )));
    }
    if n_traj.checked_mul(n_frames).and_then(|v| v.checked_mul(m)) != Some(z.len()) {
        return Err(FieldError::Shape(format!(
            "measurements must hold n_trajectories × n_frames × {m} values"
        )));
    }
    observed_rows(z, m, n_frames)
}

/// Per row of m values (rows: trajectory after trajectory, `n_frames` each): true when
/// observed, false when every value is NaN; an error for a partly NaN row, an infinite
/// value or one beyond ±[`MAX_MEASUREMENT`].
fn observed_rows(z: &[f64], m: usize, n_frames: usize) -> Result<Vec<bool>> {
    // the common case in one vectorisable pass: no NaN, nothing too large
    if z.iter()
        .fold(true, |ok, v| ok & (v.abs() <= MAX_MEASUREMENT))
    {
        return Ok(vec![true; z.len() / m]);
    }
    let place = |row: usize| (row / n_frames.max(1), row % n_frames.max(1));
    z.chunks_exact(m)
        .enumerate()
        .map(|(row, values)| {
            let missing = values.iter().filter(|v| v.is_nan()).count();
            if missing == m {
                return Ok(false);
            }
            if missing > 0 {
                let (t, f) = place(row);
                return Err(FieldError::NonFinite(format!(
                    "the measurement of trajectory {t}, frame {f} is partly NaN: a missed \
                     frame is a row of NaN only"
                )));
            }
            if values.iter().any(|v| v.abs() > MAX_MEASUREMENT) {
                let (t, f) = place(row);
                return Err(FieldError::NonFinite(format!(
                    "the measurement of trajectory {t}, frame {f} is infinite or beyond \
                     ±1e150 (rescale the data)"
                )));
            }
            Ok(true)
        })
        .collect()
}
