//! The gains of one step, the channels it saw and the spreads the recursion carries.
//!
//! The correction of a step is x̂ = x̂^e + xx·ν + xv·ν', x̂' = x̂'^e + vx·ν + vv·ν' with the
//! position innovation ν = z - x̂^e and the velocity innovation ν' = z' - x̂'^e (0 when that
//! channel is missing or not measured). In the source's notation (position measurements only)
//! α_n = xx and β_n = vx·τ_n [K95 7].

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
