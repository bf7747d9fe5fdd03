//! The gains of one step, and the dispatch to the fuzzy or the Kalman recursion of the spreads.
//!
//! The correction of a step is x̂ = x̂^e + xx·ν + xv·ν', x̂' = x̂'^e + vx·ν + vv·ν' with the
//! position innovation ν = z - x̂^e and the velocity innovation ν' = z' - x̂'^e (0 when that
//! channel is missing or not measured). In the source's notation (position measurements only)
//! α_n = xx and β_n = vx·τ_n [K95 7].

use super::model::{GainRule, MotionModel};
use super::{fuzzy_gains, kalman_gains};
use crate::error::{FieldError, Result};

/// The gains of one step (see the module documentation).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Gain {
    pub xx: f64,
    pub xv: f64,
    pub vx: f64,
    pub vv: f64,
}

impl Gain {
    pub(crate) fn is_finite(&self) -> bool {
        self.xx.is_finite() && self.xv.is_finite() && self.vx.is_finite() && self.vv.is_finite()
    }
}

/// Which channels of a sample hold a measurement.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Seen {
    pub pos: bool,
    pub vel: bool,
}

impl Seen {
    /// A sample with every measured channel present.
    pub const ALL: Seen = Seen {
        pos: true,
        vel: true,
    };
}

/// The recursion's state: (P, P', unused) of the fuzzy filter, (Σ_xx, Σ_xv, Σ_vv) of Kalman.
pub type Spread = [f64; 3];

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
