//! The filter of one series, sample by sample [K95 5–7], with its segment start.
//!
//! A segment begins at the first observed sample (after construction or a restart). Its first
//! three samples are the warm-up: at each of them the start x̄_0, x̄'_0 is refitted on the
//! samples seen so far ([`least_squares_start`]) and the recursion is rerun from the segment's
//! first sample, so the estimate at t_n uses z_0..z_n only; from the third sample on every
//! estimate is that of the source's recursion started from the fit on z_0, z_1, z_2. A missing
//! sample (NaN) skips the correction: the estimate is the prediction.

use super::gain::{Gain, Seen, Spread};
use super::gain_recursion;
use super::model::MotionModel;
use super::start::least_squares_start;
use super::state::{is_spread, nan_or_within, within, Reader, Writer};
use super::time_step;
use crate::{FieldError, Result};

/// x̂^e_n = x̂_{n-1} + x̂'_{n-1}τ_n, x̂'^e_n = x̂'_{n-1}  [K95 7].
#[inline(always)]
pub(crate) fn predict(x: f64, v: f64, tau: f64) -> (f64, f64) {
    (x + v * tau, v)
}

/// The correction with position measurements only: x̂ = x̂^e + α ν, x̂' = x̂'^e + (β/τ) ν.
#[inline(always)]
pub(crate) fn correct_position(xe: f64, ve: f64, g_xx: f64, g_vx: f64, nu: f64) -> (f64, f64) {
    (xe + g_xx * nu, ve + g_vx * nu)
}

/// The correction of either variant (ν, ν' = 0 for a missing channel).
#[inline(always)]
pub(crate) fn correct(
    model: &MotionModel,
    xe: f64,
    ve: f64,
    g: &Gain,
    nu: f64,
    nu_v: f64,
) -> (f64, f64) {
    if model.measures_velocity() {
        (xe + g.xx * nu + g.xv * nu_v, ve + g.vx * nu + g.vv * nu_v)
    } else {
        correct_position(xe, ve, g.xx, g.vx, nu)
    }
}

/// Innovations of a sample: (ν, ν', which channels were seen).
#[inline(always)]
fn innovations(model: &MotionModel, xe: f64, ve: f64, z: f64, zv: f64) -> (f64, f64, Seen) {
    let seen = Seen {
        pos: !z.is_nan(),
        vel: model.measures_velocity() && !zv.is_nan(),
    };
    let nu = if seen.pos { z - xe } else { 0.0 };
    let nu_v = if seen.vel { zv - ve } else { 0.0 };
    (nu, nu_v, seen)
}

/// The largest |sample| accepted: the detectors square differences of samples.
pub const MAX_SAMPLE: f64 = 1e150;

pub(crate) fn check_sample(value: f64, what: &str) -> Result<()> {
    if value.is_nan() || value.abs() <= MAX_SAMPLE {
        Ok(())
    } else {
        Err(FieldError::InvalidParameter(format!(
            "{what} must be NaN (missing) or within ±{MAX_SAMPLE:e}, got {value}"
        )))
    }
}

/// Samples of the warm-up kept for refitting the start.
const WARM_UP: usize = 3;

/// One series' filter state (the streaming object; see the module documentation).
#[derive(Clone, Debug, PartialEq)]
pub struct SeriesFilter {
    t_last: f64,
    started: bool,
    /// samples since the segment's first one
    step: u64,
    x: f64,
    v: f64,
    spread: Spread,
    warm_t: [f64; WARM_UP],
    warm_z: [f64; WARM_UP],
    warm_zv: [f64; WARM_UP],
}

impl Default for SeriesFilter {
    fn default() -> Self {
        Self::new()
    }
}

impl SeriesFilter {
    /// Numbers in [`SeriesFilter::save`]'s output.
    pub const STATE_LEN: usize = 8 + 3 * WARM_UP;

    /// A filter that has seen no sample.
    pub fn new() -> Self {
        Self {
            t_last: f64::NAN,
            started: false,
            step: 0,
            x: f64::NAN,
            v: f64::NAN,
            spread: [0.0; 3],
            warm_t: [f64::NAN; WARM_UP],
            warm_z: [f64::NAN; WARM_UP],
            warm_zv: [f64::NAN; WARM_UP],
        }
    }

    /// The next observed sample begins a new segment (the time order is kept).
    pub fn restart(&mut self) {
        let t_last = self.t_last;
        *self = Self::new();
        self.t_last = t_last;
    }

    /// Whether a segment has begun.
    pub fn started(&self) -> bool {
        self.started
    }

    /// The current estimates (x̂, x̂'); NaN before the first observed sample.
    pub fn estimate(&self) -> (f64, f64) {
        (self.x, self.v)
    }

    /// The recursion's spreads (fuzzy) or covariances (Kalman) after the last sample.
    pub fn spread(&self) -> &Spread {
        &self.spread
    }

    /// Time of the last sample (NaN before the first).
    pub fn last_time(&self) -> f64 {
        self.t_last
    }

    /// τ to a sample at `t` (error unless `t` is finite and later than the last sample).
    pub fn step_to(&self, t: f64) -> Result<f64> {
        time_step(self.t_last, t)
    }

    /// The prediction (x̂^e, x̂'^e, τ) at `t`, None before a segment has begun.
    pub fn prediction(&self, t: f64) -> Result<Option<(f64, f64, f64)>> {
        let tau = self.step_to(t)?;
        Ok(self.started.then(|| {
            let (xe, ve) = predict(self.x, self.v, tau);
            (xe, ve, tau)
        }))
    }

    /// Filters the sample (t, z, z') (NaN = missing; z' is ignored without velocity
    /// measurements) and returns (x̂, x̂').
    pub fn step(&mut self, model: &MotionModel, t: f64, z: f64, zv: f64) -> Result<(f64, f64)> {
        let tau = self.step_to(t)?;
        check_sample(z, "a sample")?;
        if model.measures_velocity() {
            check_sample(zv, "a velocity sample")?;
        }
        if !self.started {
            if !z.is_nan() {
                self.started = true;
                self.step = 0;
                self.warm_up(model, t, z, zv);
            }
        } else if self.step + 1 < WARM_UP as u64 {
            self.step += 1;
            self.warm_up(model, t, z, zv);
        } else {
            self.step += 1;
            self.advance(model, tau, z, zv);
        }
        self.t_last = t;
        if self.started
            && !(self.x.is_finite()
                && self.v.is_finite()
                && self.spread.iter().all(|s| s.is_finite()))
        {
            return Err(gain_recursion::overflow());
        }
        Ok((self.x, self.v))
    }

    /// One regular step n ≥ 1 (gains from the spread recursion).
    fn advance(&mut self, model: &MotionModel, tau: f64, z: f64, zv: f64) {
        let (xe, ve) = predict(self.x, self.v, tau);
        let (nu, nu_v, seen) = innovations(model, xe, ve, z, zv);
        let g = gain_recursion::advance(model, &mut self.spread, tau, seen);
        (self.x, self.v) = correct(model, xe, ve, &g, nu, nu_v);
    }

    /// Stores warm-up sample `self.step`, refits the start and reruns the segment.
    fn warm_up(&mut self, model: &MotionModel, t: f64, z: f64, zv: f64) {
        let k = self.step as usize;
        self.warm_t[k] = t;
        self.warm_z[k] = z;
        self.warm_zv[k] = zv;
        let (wt, wz, wzv) = (self.warm_t, self.warm_z, self.warm_zv);
        let (t, z, zv) = (&wt[..=k], &wz[..=k], &wzv[..=k]);
        let (x0, v0) = least_squares_start(model.has_velocity(), t, z);
        let (nu, nu_v, seen) = innovations(model, x0, v0, z[0], zv[0]);
        let (spread, g) = gain_recursion::start(model, seen.vel);
        self.spread = spread;
        (self.x, self.v) = correct(model, x0, v0, &g, nu, nu_v);
        for i in 1..=k {
            let (ti, zi, zvi) = (t[i], z[i], zv[i]);
            self.advance(model, ti - t[i - 1], zi, zvi);
        }
    }

    /// Appends the state to `w` ([`SeriesFilter::STATE_LEN`] numbers).
    pub(crate) fn save(&self, w: &mut Writer) {
        w.f64(self.t_last);
        w.flag(self.started);
        w.count(self.step);
        w.f64(self.x);
        w.f64(self.v);
        w.f64s(&self.spread);
        w.f64s(&self.warm_t);
        w.f64s(&self.warm_z);
        w.f64s(&self.warm_zv);
    }

    /// Reads a state written by [`SeriesFilter::save`] for a recursion of the Kalman rule
    /// (`kalman`) or the fuzzy one, checking its numbers.
    pub(crate) fn load(r: &mut Reader, kalman: bool) -> Result<Self> {
        let mut f = Self {
            t_last: r.time()?,
            started: r.flag()?,
            step: r.count()?,
            x: r.f64()?,
            v: r.f64()?,
            ..Self::new()
        };
        r.fill(&mut f.spread)?;
        r.fill(&mut f.warm_t)?;
        r.fill(&mut f.warm_z)?;
        r.fill(&mut f.warm_zv)?;
        if !f.started {
            // nothing but the time is read before the next segment begins
            return Ok(Self {
                t_last: f.t_last,
                ..Self::new()
            });
        }
        r.check(f.t_last.is_finite(), "a started filter without a last time")?;
        r.check(
            within(f.x) && within(f.v),
            "an estimate not finite or beyond ±1e150",
        )?;
        r.check(
            is_spread(&f.spread, kalman),
            "spreads that no recursion gives",
        )?;
        if f.step + 1 < WARM_UP as u64 {
            let k = f.step as usize;
            let t = &f.warm_t[..=k];
            let ordered = t.iter().all(|t| t.is_finite())
                && t.windows(2).all(|w| w[0] < w[1])
                && t[k] <= f.t_last;
            r.check(ordered, "warm-up times out of order")?;
            let samples = within(f.warm_z[0])
                && f.warm_z[1..=k].iter().all(|&z| nan_or_within(z))
                && f.warm_zv[..=k].iter().all(|&z| nan_or_within(z));
            r.check(samples, "warm-up samples not finite or beyond ±1e150")?;
        }
        Ok(f)
    }
}
