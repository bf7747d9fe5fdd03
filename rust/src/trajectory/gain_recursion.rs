//! The gain recursion: the fuzzy or the Kalman recursion of the spreads, chosen by the
//! model's rule, step by step or over a whole segment.

use super::gain::{Gain, Seen, Spread};
use super::model::{GainRule, MotionModel};
use super::{fuzzy_gains, kalman_gains};
use crate::{FieldError, Result};

/// Gains and spreads at the start of a segment (n = 0, position observed) [K95 5].
pub(crate) fn start(model: &MotionModel, seen_vel: bool) -> (Spread, Gain) {
    match model.rule {
        GainRule::Fuzzy => fuzzy_gains::start(model, seen_vel),
        GainRule::Kalman => kalman_gains::start(model, seen_vel),
    }
}

/// Gains of step n ≥ 1 after a time step τ; `spread` moves from n-1 to n [K95 6].
pub(crate) fn advance(model: &MotionModel, spread: &mut Spread, tau: f64, seen: Seen) -> Gain {
    match model.rule {
        GainRule::Fuzzy => fuzzy_gains::advance(model, spread, tau, seen),
        GainRule::Kalman => kalman_gains::advance(model, spread, tau, seen),
    }
}

pub(crate) fn overflow() -> FieldError {
    FieldError::NonFinite(
        "the spreads, time steps or samples overflow float64 in the recursion: rescale them".into(),
    )
}

/// The gains of a segment starting at `times[0]` with every sample observed.
pub fn gain_sequence(model: &MotionModel, times: &[f64]) -> Result<Vec<Gain>> {
    let mut out = Vec::with_capacity(times.len());
    let Some(&first) = times.first() else {
        return Ok(out);
    };
    let (mut spread, g) = start(model, true);
    out.push(g);
    let mut last = first;
    for &t in &times[1..] {
        let tau = super::time_step(last, t)?;
        out.push(advance(model, &mut spread, tau, Seen::ALL));
        last = t;
    }
    if out.iter().all(Gain::is_finite) && spread.iter().all(|s| s.is_finite()) {
        Ok(out)
    } else {
        Err(overflow())
    }
}
