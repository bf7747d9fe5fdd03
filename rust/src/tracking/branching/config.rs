//! Configuration of the branching tracker (the keywords of the Python class).

use super::motion::MAX_MOTION_ORDER;
use crate::error::{FieldError, Result};
use crate::identification::chi_squared_quantile;

/// Most index increments a sequence keeps (`memory`; 3–10 in use, SPEC §3.2), and most
/// measurements that identify a sequence's future (`merge_depth`; 2–5 in use).
pub(crate) const MAX_MEMORY: usize = 256;

/// Largest noise std, speed and default time step accepted: the filters square them (and
/// the start's velocity variance is (10·max_speed)²), so 1e100 keeps every covariance and
/// the saved state finite with room to spare.
pub(crate) const MAX_SCALE: f64 = 1e100;

/// Largest |time| accepted (the measurements' bound, `MAX_MEASUREMENT` of the Python class).
pub(crate) const MAX_TIME: f64 = 1e150;

/// Default `max_children`: twice the default `max_per_tree`.
pub(crate) const DEFAULT_MAX_CHILDREN: usize = 16;

/// Ranking of the final answer (SPEC §3.3 step 3).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Selection {
    /// Decreasing score, with the shared-measurement relaxation (default).
    Llr,
    /// The literal rule: increasing final index per degree of freedom, whole sequences.
    IndexPerDof,
    /// The literal rule ranked by the χ² p-value of the final index.
    PValue,
}

impl Selection {
    /// Its name: "llr", "index_per_dof" or "pvalue".
    pub fn name(self) -> &'static str {
        match self {
            Selection::Llr => "llr",
            Selection::IndexPerDof => "index_per_dof",
            Selection::PValue => "pvalue",
        }
    }

    /// Parses "llr", "index_per_dof" or "pvalue".
    pub fn parse(name: &str) -> Result<Self> {
        match name {
            "llr" => Ok(Selection::Llr),
            "index_per_dof" => Ok(Selection::IndexPerDof),
            "pvalue" => Ok(Selection::PValue),
            _ => Err(invalid(format!(
                "selection must be 'llr', 'index_per_dof' or 'pvalue', got {name:?}"
            ))),
        }
    }
}

/// Everything that configures a tracker (see the reference's class docstring for meanings).
#[derive(Debug, Clone)]
pub struct TrackerConfig {
    pub order: Vec<usize>,
    pub process_std: Vec<f64>,
    pub measurement_std: Vec<f64>,
    pub n_spatial: usize,
    pub confidence: f64,
    pub memory: usize,
    pub max_misses: usize,
    pub dt: f64,
    pub p_detect: f64,
    pub clutter_density: Option<f64>,
    pub max_speed: f64,
    pub n_confirm: usize,
    pub confirm_llr: f64,
    pub confirm_window: usize,
    /// Sequential deletion: an unconfirmed sequence whose score falls below it dies.
    pub delete_llr: Option<f64>,
    pub max_per_tree: usize,
    pub max_hypotheses: usize,
    pub max_seeds: usize,
    /// Most measurements a sequence branches on per frame and variant (the nearest in its
    /// gate); `None` = every one, the literal [K93] rule.
    pub max_children: Option<usize>,
    pub merge_depth: usize,
    pub maneuver_std: Option<Vec<f64>>,
    pub maneuver_prob: f64,
    pub min_hits: usize,
    pub final_llr: f64,
    pub max_shared: usize,
    pub selection: Selection,
    pub seed: u64,
}

fn invalid(message: String) -> FieldError {
    FieldError::InvalidParameter(message)
}

fn check_positive(value: f64, name: &str) -> Result<()> {
    if value.is_finite() && value > 0.0 {
        Ok(())
    } else {
        Err(invalid(format!(
            "{name} must be positive and finite, got {value}"
        )))
    }
}

/// A positive scale (std, speed, time step) of at most [`MAX_SCALE`].
fn check_scale(value: f64, name: &str) -> Result<()> {
    check_positive(value, name)?;
    if value > MAX_SCALE {
        return Err(invalid(format!(
            "{name} must be at most {MAX_SCALE:e} (the filters square it; rescale the \
             parameters), got {value}"
        )));
    }
    Ok(())
}

impl TrackerConfig {
    /// The defaults of the Python class for k parameters, the first min(k, 2) spatial: order 1
    /// (nearly constant velocity), process std 0.1, measurement std 0.5, β = 0.99, N = 4, at most
    /// 2 misses, P_d = 0.9, clutter density estimated, 4 hits to confirm, deletion below −5.
    pub fn with_defaults(k: usize) -> TrackerConfig {
        let (n_confirm, max_misses) = (4, 2);
        TrackerConfig {
            order: vec![1; k],
            process_std: vec![0.1; k],
            measurement_std: vec![0.5; k],
            n_spatial: k.min(2),
            confidence: 0.99,
            memory: 4,
            max_misses,
            dt: 1.0,
            p_detect: 0.9,
            clutter_density: None,
            max_speed: 6.0,
            n_confirm,
            confirm_llr: 0.0,
            confirm_window: n_confirm + max_misses + 1,
            delete_llr: Some(-5.0),
            max_per_tree: 8,
            max_hypotheses: 20_000,
            max_seeds: 2_000,
            max_children: Some(DEFAULT_MAX_CHILDREN),
            merge_depth: 3,
            maneuver_std: None,
            maneuver_prob: 0.01,
            min_hits: n_confirm,
            final_llr: 5.0,
            max_shared: 2,
            selection: Selection::Llr,
            seed: 0,
        }
    }

    /// Number of parameters k per measurement.
    pub fn k(&self) -> usize {
        self.order.len()
    }

    /// State length per parameter, d_q = ν_q + 1.
    pub fn dims(&self) -> Vec<usize> {
        self.order.iter().map(|o| o + 1).collect()
    }

    /// ν_max.
    pub fn nu_max(&self) -> usize {
        self.order.iter().copied().max().unwrap_or(0)
    }

    /// χ² thresholds α(k n) for n = 0..N (α(0) = 0), SPEC §3.2.
    pub fn thresholds(&self) -> Result<Vec<f64>> {
        let mut alpha = vec![0.0];
        for n in 1..=self.memory {
            alpha.push(chi_squared_quantile(
                self.confidence,
                (self.k() * n) as f64,
            )?);
        }
        Ok(alpha)
    }

    /// Checks every value; the message names the offending keyword.
    pub fn validate(&self) -> Result<()> {
        let k = self.k();
        if k == 0 {
            return Err(invalid("a measurement needs at least one parameter".into()));
        }
        if self.process_std.len() != k || self.measurement_std.len() != k {
            return Err(invalid(format!(
                "process_std and measurement_std need {k} values (one per parameter)"
            )));
        }
        if let Some(o) = self.order.iter().find(|&&o| o > MAX_MOTION_ORDER) {
            return Err(invalid(format!(
                "order must be at most {MAX_MOTION_ORDER}, got {o}"
            )));
        }
        if self.n_spatial == 0 || self.n_spatial > k {
            return Err(invalid(format!(
                "n_spatial must be between 1 and {k}, got {}",
                self.n_spatial
            )));
        }
        for (&v, name) in self
            .process_std
            .iter()
            .zip(std::iter::repeat("process_std"))
        {
            if !(v.is_finite() && v >= 0.0) {
                return Err(invalid(format!("{name} must be finite and >= 0, got {v}")));
            }
            if v > 0.0 {
                check_scale(v, name)?;
            }
        }
        for &v in &self.measurement_std {
            check_scale(v, "measurement_std")?;
        }
        if !(self.confidence > 0.0 && self.confidence < 1.0) {
            return Err(invalid(format!(
                "confidence must lie strictly between 0 and 1, got {}",
                self.confidence
            )));
        }
        if self.memory == 0 || self.memory > MAX_MEMORY {
            // each live sequence keeps `memory` increments per parameter
            return Err(invalid(format!(
                "memory must lie in 1..={MAX_MEMORY}, got {}",
                self.memory
            )));
        }
        check_scale(self.dt, "dt")?;
        if !(self.p_detect > 0.0 && self.p_detect < 1.0) {
            return Err(invalid(format!(
                "p_detect must lie strictly between 0 and 1, got {}",
                self.p_detect
            )));
        }
        if let Some(lam) = self.clutter_density {
            check_positive(lam, "clutter_density")?;
        }
        check_scale(self.max_speed, "max_speed")?;
        if self.merge_depth > MAX_MEMORY {
            return Err(invalid(format!(
                "merge_depth must lie in 1..={MAX_MEMORY}, got {}",
                self.merge_depth
            )));
        }
        for (value, name) in [
            (self.n_confirm, "n_confirm"),
            (self.confirm_window, "confirm_window"),
            (self.max_per_tree, "max_per_tree"),
            (self.max_hypotheses, "max_hypotheses"),
            (self.max_seeds, "max_seeds"),
            (self.merge_depth, "merge_depth"),
            (self.min_hits, "min_hits"),
        ] {
            if value == 0 {
                return Err(invalid(format!("{name} must be at least 1")));
            }
        }
        if self.max_children == Some(0) {
            return Err(invalid("max_children must be at least 1 (or None)".into()));
        }
        if let Some(man) = &self.maneuver_std {
            if man.len() != k {
                return Err(invalid(format!("maneuver_std needs {k} values")));
            }
            for &v in man {
                check_scale(v, "maneuver_std")?;
            }
            if !(self.maneuver_prob > 0.0 && self.maneuver_prob < 1.0) {
                return Err(invalid(format!(
                    "maneuver_prob must lie strictly between 0 and 1, got {}",
                    self.maneuver_prob
                )));
            }
        }
        for (v, name) in [
            (self.confirm_llr, "confirm_llr"),
            (self.final_llr, "final_llr"),
        ] {
            if !v.is_finite() {
                return Err(invalid(format!("{name} must be finite, got {v}")));
            }
        }
        if let Some(v) = self.delete_llr {
            if !v.is_finite() {
                return Err(invalid(format!("delete_llr must be finite, got {v}")));
            }
        }
        Ok(())
    }
}
