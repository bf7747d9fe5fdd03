//! The Kalman filter whose normalised innovations the χ² and CUSUM detectors test.
//!
//! It starts diffuse (no prior on the state), so under the Gaussian model with variances Q²,
//! Q'², R² (R'²) its normalised position innovations u_n = ν_n / √S_n are independent N(0, 1)
//! from the first one on — the false-alarm levels of the detectors are then exact:
//! - 1-D model: x̂ = z_a, Σ = R² at the first observed sample a;
//! - velocities measured and z'_a observed: x̂ = (z_a, z'_a), Σ = diag(R², R'²);
//! - otherwise, at the next observed sample b (T = t_b - t_a, e the process noise accumulated
//!   from a to b): x̂_b = z_b, x̂'_b = (z_b - z_a)/T, Σ_xx = R², Σ_xv = R²/T,
//!   Σ_vv = (2R² + E_xx - 2T E_xv + T² E_vv)/T² with E = Cov(e) (plus a velocity correction
//!   when z'_b is observed).

use super::gain::{Seen, Spread};
use super::kalman_gains;
use super::model::{GainRule, MotionModel};
use super::state::{is_spread, within, Reader, Writer};
use super::time_step;
use crate::Result;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Phase {
    Empty,
    /// one observed position (z_a at t_a), velocity still unknown
    Half,
    Proper,
}

/// The diffuse-start Kalman filter of the detectors (see the module documentation).
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct InnovationFilter {
    phase: Phase,
    t_last: f64,
    x: f64,
    v: f64,
    cov: Spread,
    /// z_a, t_a of the half phase
    anchor: [f64; 2],
    /// covariance of the process noise accumulated since t_a
    drift: Spread,
}

impl InnovationFilter {
    pub(crate) const STATE_LEN: usize = 12;

    pub(crate) fn new() -> Self {
        Self {
            phase: Phase::Empty,
            t_last: f64::NAN,
            x: f64::NAN,
            v: f64::NAN,
            cov: [0.0; 3],
            anchor: [f64::NAN; 2],
            drift: [0.0; 3],
        }
    }

    /// Forgets the state (the time order is kept).
    pub(crate) fn restart(&mut self) {
        let t_last = self.t_last;
        *self = Self::new();
        self.t_last = t_last;
    }

    fn kalman(model: &MotionModel) -> MotionModel {
        model.with_rule(GainRule::Kalman)
    }

    /// u = ν/√S of a sample at (t, z), None when untested (start, missing z).
    pub(crate) fn normalised_innovation(
        &self,
        model: &MotionModel,
        t: f64,
        z: f64,
    ) -> Result<Option<f64>> {
        let tau = time_step(self.t_last, t)?;
        if self.phase != Phase::Proper || z.is_nan() {
            return Ok(None);
        }
        let predicted = kalman_gains::predict(&Self::kalman(model), &self.cov, tau);
        let s = predicted[0] + model.r * model.r;
        Ok(Some((z - (self.x + self.v * tau)) / s.sqrt()))
    }

    /// Takes the sample (t, z, z') in.
    pub(crate) fn step(&mut self, model: &MotionModel, t: f64, z: f64, zv: f64) -> Result<()> {
        let tau = time_step(self.t_last, t)?;
        let km = Self::kalman(model);
        let r2 = model.r * model.r;
        let seen_vel = model.measures_velocity() && !zv.is_nan();
        match self.phase {
            Phase::Empty if !z.is_nan() => {
                self.x = z;
                if !model.has_velocity() {
                    self.v = 0.0;
                    self.cov = [r2, 0.0, 0.0];
                    self.phase = Phase::Proper;
                } else if let (true, Some(rv)) = (seen_vel, model.r_vel) {
                    self.v = zv;
                    self.cov = [r2, 0.0, rv * rv];
                    self.phase = Phase::Proper;
                } else {
                    self.anchor = [z, t];
                    self.drift = [0.0; 3];
                    self.phase = Phase::Half;
                }
            }
            Phase::Empty => {}
            Phase::Half => {
                self.drift = kalman_gains::predict(&km, &self.drift, tau);
                if !z.is_nan() {
                    let [za, ta] = self.anchor;
                    let span = t - ta;
                    let [exx, exv, evv] = self.drift;
                    self.x = z;
                    self.v = (z - za) / span;
                    let vv =
                        (2.0 * r2 + exx - 2.0 * span * exv + span * span * evv) / (span * span);
                    self.cov = [r2, r2 / span, vv];
                    self.phase = Phase::Proper;
                    if seen_vel {
                        self.correct(
                            &km,
                            z,
                            zv,
                            Seen {
                                pos: false,
                                vel: true,
                            },
                        );
                    }
                }
            }
            Phase::Proper => {
                self.x += self.v * tau;
                self.cov = kalman_gains::predict(&km, &self.cov, tau);
                let seen = Seen {
                    pos: !z.is_nan(),
                    vel: seen_vel,
                };
                self.correct(&km, z, zv, seen);
            }
        }
        self.t_last = t;
        Ok(())
    }

    fn correct(&mut self, km: &MotionModel, z: f64, zv: f64, seen: Seen) {
        let nu = if seen.pos { z - self.x } else { 0.0 };
        let nu_v = if seen.vel { zv - self.v } else { 0.0 };
        let g = kalman_gains::correct(km, &mut self.cov, seen);
        self.x += g.xx * nu + g.xv * nu_v;
        self.v += g.vx * nu + g.vv * nu_v;
    }

    /// Time of the last sample (NaN before the first).
    pub(crate) fn last_time(&self) -> f64 {
        self.t_last
    }

    pub(crate) fn save(&self, w: &mut Writer) {
        w.count(self.phase as u64);
        w.f64(self.t_last);
        w.f64(self.x);
        w.f64(self.v);
        w.f64s(&self.cov);
        w.f64s(&self.anchor);
        w.f64s(&self.drift);
    }

    pub(crate) fn load(r: &mut Reader) -> Result<Self> {
        let phase = match r.count()? {
            0 => Phase::Empty,
            1 => Phase::Half,
            2 => Phase::Proper,
            _ => return Err(r.corrupt()),
        };
        let mut f = Self {
            phase,
            t_last: r.time()?,
            x: r.f64()?,
            v: r.f64()?,
            ..Self::new()
        };
        r.fill(&mut f.cov)?;
        r.fill(&mut f.anchor)?;
        r.fill(&mut f.drift)?;
        match f.phase {
            Phase::Empty => {
                return Ok(Self {
                    t_last: f.t_last,
                    ..Self::new()
                })
            }
            Phase::Half => {
                let [za, ta] = f.anchor;
                r.check(
                    within(za) && ta.is_finite() && ta <= f.t_last,
                    "the detector's first sample not finite, too large or after the last time",
                )?;
                r.check(
                    is_spread(&f.drift, true),
                    "a process-noise covariance that is not one",
                )?;
            }
            Phase::Proper => {
                r.check(
                    f.t_last.is_finite() && within(f.x) && within(f.v),
                    "the detector's estimate or time not finite or beyond ±1e150",
                )?;
                r.check(is_spread(&f.cov, true), "a covariance that is not one")?;
            }
        }
        Ok(f)
    }
}
