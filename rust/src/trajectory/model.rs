//! The motion model of one scalar parameter (SPEC §4, [K95 1–2]) and the rule of its gains.
//!
//! x_n = x_{n-1} + x'_{n-1} τ_n + w_n, x'_n = x'_{n-1} + w'_n, z_n = x_n + v_n (and, in the
//! variant with velocity measurements, z'_n = x'_n + v'_n). The five spreads are those of the
//! membership functions exp(-a²/s²) of the fuzzy filter, or the standard deviations of the
//! Kalman filter of the same model.

use crate::{FieldError, Result};

/// The largest spread accepted: the recursions square spreads times time steps.
pub const MAX_SPREAD: f64 = 1e100;

/// Which filter computes the gains.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GainRule {
    /// The possibility-theory filter [K95 5–7].
    Fuzzy,
    /// The Kalman filter with covariances P², Q², R² (the source's comparison).
    Kalman,
}

impl GainRule {
    /// "fuzzy" or "kalman".
    pub fn parse(name: &str) -> Result<Self> {
        match name {
            "fuzzy" => Ok(Self::Fuzzy),
            "kalman" => Ok(Self::Kalman),
            _ => Err(FieldError::InvalidParameter(format!(
                "the gain rule must be 'fuzzy' or 'kalman', got {name:?}"
            ))),
        }
    }
}

/// Spreads of the initial state (p, p_vel), of the process (q, q_vel) and of the
/// measurements (r, r_vel: `Some` in the variant with velocity measurements).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MotionModel {
    pub rule: GainRule,
    pub p: f64,
    pub q: f64,
    pub r: f64,
    pub p_vel: f64,
    pub q_vel: f64,
    pub r_vel: Option<f64>,
}

fn check_spread(value: f64, name: &str, zero_allowed: bool) -> Result<()> {
    let low_ok = if zero_allowed {
        value >= 0.0
    } else {
        value > 0.0
    };
    if value.is_finite() && low_ok && value <= MAX_SPREAD {
        return Ok(());
    }
    let kind = if zero_allowed {
        "non-negative"
    } else {
        "positive"
    };
    Err(FieldError::InvalidParameter(format!(
        "{name} must be {kind}, finite and at most {MAX_SPREAD:e}, got {value}"
    )))
}

impl MotionModel {
    /// Checks the spreads: P, Q, R (and R' when given) positive, P', Q' non-negative.
    pub fn new(
        rule: GainRule,
        p: f64,
        q: f64,
        r: f64,
        p_vel: f64,
        q_vel: f64,
        r_vel: Option<f64>,
    ) -> Result<Self> {
        check_spread(p, "P", false)?;
        check_spread(q, "Q", false)?;
        check_spread(r, "R", false)?;
        check_spread(p_vel, "P_vel", true)?;
        check_spread(q_vel, "Q_vel", true)?;
        if let Some(rv) = r_vel {
            check_spread(rv, "R_vel", false)?;
        }
        Ok(Self {
            rule,
            p,
            q,
            r,
            p_vel,
            q_vel,
            r_vel,
        })
    }

    /// The same spreads under another gain rule.
    pub fn with_rule(&self, rule: GainRule) -> Self {
        Self { rule, ..*self }
    }

    /// Whether velocities are measured (the variant of [K95 end]).
    pub fn measures_velocity(&self) -> bool {
        self.r_vel.is_some()
    }

    /// False for the 1-D filter (P' = Q' = 0, no velocity measurements): the velocity is then
    /// identically 0 and the start fits a constant instead of a line.
    pub fn has_velocity(&self) -> bool {
        self.p_vel > 0.0 || self.q_vel > 0.0 || self.r_vel.is_some()
    }
}
