//! Configuration of the stage-2 grouping tracker (SPEC §3.4): the keywords of
//! `kalmanfield.detect_moving_objects` that reach Rust.

use crate::identification::chi_squared_quantile;
use crate::{FieldError, Result};

/// Highest centroid motion order ν (1 = nearly constant velocity, 2 = acceleration).
pub const MAX_ORDER: usize = 2;

/// Most index increments a sequence keeps (`memory`, N of SPEC §3.2).
pub(crate) const MAX_MEMORY: usize = 64;

/// Largest scale (std, speed, margin, time step) accepted: the filters square them.
const MAX_SCALE: f64 = 1e100;

/// Degrees of freedom of one increment: the centroid (2) and, once joined, the features (2).
pub(crate) const CENTROID_DOF: usize = 2;
pub(crate) const FEATURE_DOF: usize = 2;

/// Everything that configures stage 2 (meanings on the method page, §3.4).
#[derive(Debug, Clone, PartialEq)]
pub struct GroupConfig {
    /// Centroid motion order ν (1..=MAX_ORDER).
    pub order: usize,
    /// Time between frames τ.
    pub dt: f64,
    /// Std R^½ of a fragment centroid (px, per axis).
    pub position_std: f64,
    /// Std of the ν-th derivative's increment per frame (the model of §3.5, w_ν).
    pub process_std: f64,
    /// Std of a fragment's mean amplitude (feature 3).
    pub amplitude_std: f64,
    /// Std of the natural log of a fragment's area (feature 4).
    pub log_area_std: f64,
    /// Std of the features' random walk per frame, as a fraction of their measurement std.
    pub feature_drift: f64,
    /// β of the χ² test.
    pub confidence: f64,
    /// N: increments in the sliding index (N + 1 observations).
    pub memory: usize,
    /// Prior std of a new sequence's own velocity (px per time unit) and of a new group's.
    pub initial_speed_std: f64,
    /// A new segment joins a group iff its centroid lies in the group's box grown by this (px).
    pub gate_margin: f64,
    /// Merge rule: a member's own speed must exceed this (px per time unit).
    pub min_speed: f64,
    /// Merge rule: |v_sequence − v_group| at most this (px per time unit); also the group merge.
    pub velocity_tolerance: f64,
    /// Group merge: co-moving groups join when the gap between their boxes is at most this
    /// many times the smaller one's extent (the fragments of one object lie about their own
    /// size apart); 0 = only boxes within `gate_margin`.
    pub cohesion: f64,
    /// Frames a group survives without any confirmed sequence.
    pub max_misses: usize,
    /// Whether segments outside every gate start new groups (mode "extended").
    pub seed_groups: bool,
}

fn invalid(message: String) -> FieldError {
    FieldError::InvalidParameter(message)
}

fn check_scale(value: f64, name: &str, zero_ok: bool) -> Result<()> {
    let ok = value.is_finite() && (value > 0.0 || (zero_ok && value == 0.0)) && value <= MAX_SCALE;
    if ok {
        Ok(())
    } else {
        let what = if zero_ok { "non-negative" } else { "positive" };
        Err(invalid(format!(
            "{name} must be {what}, finite and at most {MAX_SCALE:e}, got {value}"
        )))
    }
}

impl GroupConfig {
    /// Checks every field; the message names the first one out of range.
    pub fn validate(&self) -> Result<()> {
        if !(1..=MAX_ORDER).contains(&self.order) {
            return Err(invalid(format!(
                "order must be 1..={MAX_ORDER}, got {}",
                self.order
            )));
        }
        for (value, name) in [
            (self.dt, "dt"),
            (self.position_std, "position_std"),
            (self.amplitude_std, "amplitude_std"),
            (self.log_area_std, "log_area_std"),
            (self.initial_speed_std, "initial_speed_std"),
        ] {
            check_scale(value, name, false)?;
        }
        for (value, name) in [
            (self.process_std, "process_std"),
            (self.feature_drift, "feature_drift"),
            (self.gate_margin, "gate_margin"),
            (self.min_speed, "min_speed"),
            (self.velocity_tolerance, "velocity_tolerance"),
            (self.cohesion, "cohesion"),
        ] {
            check_scale(value, name, true)?;
        }
        if !(self.confidence > 0.0 && self.confidence < 1.0) {
            return Err(invalid(format!(
                "confidence must lie strictly between 0 and 1, got {}",
                self.confidence
            )));
        }
        if !(1..=MAX_MEMORY).contains(&self.memory) {
            return Err(invalid(format!(
                "memory must be 1..={MAX_MEMORY}, got {}",
                self.memory
            )));
        }
        if self.max_misses > 1 << 20 {
            return Err(invalid(format!(
                "max_misses must be at most 2**20, got {}",
                self.max_misses
            )));
        }
        Ok(())
    }

    /// α for every total of degrees of freedom a window can hold: `table[dof]`.
    pub(crate) fn thresholds(&self) -> Result<Vec<f64>> {
        let most = self.memory * (CENTROID_DOF + FEATURE_DOF);
        let mut table = vec![f64::INFINITY; most + 1];
        for (dof, alpha) in table.iter_mut().enumerate().skip(1) {
            *alpha = chi_squared_quantile(self.confidence, dof as f64)?;
        }
        Ok(table)
    }
}
