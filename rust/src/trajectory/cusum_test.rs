//! The two-sided CUSUM of the normalised Kalman innovations (the classical baseline):
//! g⁺_n = max(0, g⁺_{n-1} + u_n - k), g⁻_n = max(0, g⁻_{n-1} - u_n - k), g = 0 at a segment's
//! start; alarm when max(g⁺, g⁻) > h. The threshold h comes from [`cusum_threshold`]
//! (mean run length between false alarms 1/(1 - confidence) tested samples).
//!
//! [`cusum_threshold`]: super::cusum_threshold::cusum_threshold

use super::innovation_filter::InnovationFilter;
use super::model::MotionModel;
use super::state::{square_statistic, Reader, Writer};
use crate::Result;

/// The innovation filter and the two cumulative sums.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct CusumTest {
    filter: InnovationFilter,
    up: f64,
    down: f64,
}

impl CusumTest {
    pub(crate) const STATE_LEN: usize = InnovationFilter::STATE_LEN + 2;

    pub(crate) fn new() -> Self {
        Self {
            filter: InnovationFilter::new(),
            up: 0.0,
            down: 0.0,
        }
    }

    pub(crate) fn restart(&mut self) {
        self.filter.restart();
        (self.up, self.down) = (0.0, 0.0);
    }

    /// (max(g⁺, g⁻)/h, (g⁺, g⁻)), None when untested.
    pub(crate) fn assess(
        &self,
        model: &MotionModel,
        drift: f64,
        threshold: f64,
        t: f64,
        z: f64,
    ) -> Result<Option<(f64, [f64; 2])>> {
        let Some(u) = self.filter.normalised_innovation(model, t, z)? else {
            return Ok(None);
        };
        let up = (self.up + u - drift).max(0.0);
        let down = (self.down - u - drift).max(0.0);
        Ok(Some((up.max(down) / threshold, [up, down])))
    }

    pub(crate) fn commit(
        &mut self,
        model: &MotionModel,
        t: f64,
        z: f64,
        zv: f64,
        sums: Option<[f64; 2]>,
    ) -> Result<()> {
        self.filter.step(model, t, z, zv)?;
        if let Some([up, down]) = sums {
            (self.up, self.down) = (up, down);
        }
        Ok(())
    }

    /// Time of the last sample (NaN before the first).
    pub(crate) fn last_time(&self) -> f64 {
        self.filter.last_time()
    }

    pub(crate) fn save(&self, w: &mut Writer) {
        self.filter.save(w);
        w.f64s(&[self.up, self.down]);
    }

    pub(crate) fn load(r: &mut Reader) -> Result<Self> {
        let test = Self {
            filter: InnovationFilter::load(r)?,
            up: r.f64()?,
            down: r.f64()?,
        };
        r.check(
            square_statistic(test.up) && square_statistic(test.down),
            "CUSUM sums negative, not finite or too large",
        )?;
        Ok(test)
    }
}
