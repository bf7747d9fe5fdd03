//! The recursive fuzzy change-point test [K95 8–10].
//!
//! Δ_n = z_n - x̂^e_n (the residual of the fuzzy filter of the same spreads),
//! s_n = s_{n-1} + γ_n (Δ_n² - s_{n-1}), D_n = D_{n-1} + γ_n ((Q_n + R)² - D_{n-1}),
//! s = D = 0 at a segment's start; alarm when s_n > -D_n ln(1 - μ). γ_n is the gain of the 1-D
//! fuzzy filter of the "difference" model: measurement spread R_Δ = P_{n-1} + P'_{n-1}τ_n + R
//! (P_{n-1} + R with velocity measurements), process spread 2Q. Its start (silent in the
//! source) is uninformative: γ = 1 at a segment's first residual (prior spread → ∞, so
//! P^Δ = R_Δ), then Q^Δ = P^Δ + 2Q, (P^Δ)² = R_Δ²(Q^Δ)²/(R_Δ² + (Q^Δ)²), γ = (P^Δ)²/R_Δ².
//! A missing sample leaves s and D unchanged and predicts P^Δ ← P^Δ + 2Q.

use super::fuzzy_gains::predicted_spread;
use super::model::{GainRule, MotionModel};
use super::series::SeriesFilter;
use super::state::{square_statistic, within, Reader, Writer};
use crate::Result;

/// The statistics after a tested sample (applied unless it alarms).
#[derive(Clone, Copy, Debug)]
pub(crate) struct FuzzyPending {
    s: f64,
    d: f64,
    p_diff: f64,
}

/// The fuzzy filter of the test and the averages s, D.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct FuzzyTest {
    filter: SeriesFilter,
    s: f64,
    d: f64,
    p_diff: f64,
    /// a residual has been averaged in this segment
    tested: bool,
}

impl FuzzyTest {
    pub(crate) const STATE_LEN: usize = SeriesFilter::STATE_LEN + 4;

    pub(crate) fn new() -> Self {
        Self {
            filter: SeriesFilter::new(),
            s: 0.0,
            d: 0.0,
            p_diff: 0.0,
            tested: false,
        }
    }

    pub(crate) fn restart(&mut self) {
        let mut filter = self.filter.clone();
        filter.restart();
        *self = Self {
            filter,
            ..Self::new()
        };
    }

    /// (s_n / (-D_n ln(1 - μ)), new statistics) of a sample, None when untested.
    /// `threshold` = -ln(1 - μ).
    pub(crate) fn assess(
        &self,
        model: &MotionModel,
        threshold: f64,
        t: f64,
        z: f64,
    ) -> Result<Option<(f64, FuzzyPending)>> {
        let Some((xe, _, tau)) = self.filter.prediction(t)? else {
            return Ok(None);
        };
        if z.is_nan() {
            return Ok(None);
        }
        let fuzzy = model.with_rule(GainRule::Fuzzy);
        let spread = self.filter.spread();
        let q_n = predicted_spread(&fuzzy, spread, tau);
        let r_delta = if model.measures_velocity() {
            spread[0] + model.r
        } else {
            spread[0] + spread[1] * tau + model.r
        };
        let (gamma, p_diff) = if self.tested {
            let q_diff = self.p_diff + 2.0 * model.q;
            let (r2, q2) = (r_delta * r_delta, q_diff * q_diff);
            let p_sq = r2 * q2 / (r2 + q2);
            (p_sq / r2, p_sq.sqrt())
        } else {
            (1.0, r_delta)
        };
        let delta = z - xe;
        let s = self.s + gamma * (delta * delta - self.s);
        let spread_delta = q_n + model.r;
        let d = self.d + gamma * (spread_delta * spread_delta - self.d);
        Ok(Some((s / (d * threshold), FuzzyPending { s, d, p_diff })))
    }

    /// Takes the sample in (`pending` from [`FuzzyTest::assess`]).
    pub(crate) fn commit(
        &mut self,
        model: &MotionModel,
        t: f64,
        z: f64,
        zv: f64,
        pending: Option<FuzzyPending>,
    ) -> Result<()> {
        self.filter
            .step(&model.with_rule(GainRule::Fuzzy), t, z, zv)?;
        match pending {
            Some(p) => {
                (self.s, self.d, self.p_diff) = (p.s, p.d, p.p_diff);
                self.tested = true;
            }
            None if self.tested => self.p_diff += 2.0 * model.q,
            None => {}
        }
        Ok(())
    }

    /// Time of the last sample (NaN before the first).
    pub(crate) fn last_time(&self) -> f64 {
        self.filter.last_time()
    }

    pub(crate) fn save(&self, w: &mut Writer) {
        self.filter.save(w);
        w.f64s(&[self.s, self.d, self.p_diff]);
        w.flag(self.tested);
    }

    pub(crate) fn load(r: &mut Reader) -> Result<Self> {
        let test = Self {
            filter: SeriesFilter::load(r, false)?,
            s: r.f64()?,
            d: r.f64()?,
            p_diff: r.f64()?,
            tested: r.flag()?,
        };
        let averages = [test.s, test.d].into_iter().all(square_statistic);
        r.check(
            averages && within(test.p_diff) && test.p_diff >= 0.0,
            "the fuzzy test's averages or spread negative, not finite or too large",
        )?;
        Ok(test)
    }
}
