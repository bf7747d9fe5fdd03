//! The sliding-window χ² test of the normalised Kalman innovations.
//!
//! The sum of the last W squared normalised innovations u² of [`InnovationFilter`] is χ²_W
//! under the Gaussian model, so a test with threshold χ²_W(confidence) alarms with
//! probability exactly 1 - confidence on a jump-free segment. Tests start once W innovations
//! exist in the segment; a missing sample adds no innovation.

use super::innovation_filter::InnovationFilter;
use super::model::MotionModel;
use super::state::{square_statistic, Reader, Writer};
use crate::Result;

/// The innovation filter and the last W squared innovations.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Chi2Test {
    filter: InnovationFilter,
    /// squared innovations, oldest first (at most W)
    window: Vec<f64>,
    width: usize,
}

impl Chi2Test {
    pub(crate) fn state_len(width: usize) -> usize {
        InnovationFilter::STATE_LEN + 1 + width
    }

    pub(crate) fn new(width: usize) -> Self {
        Self {
            filter: InnovationFilter::new(),
            window: Vec::with_capacity(width),
            width,
        }
    }

    pub(crate) fn restart(&mut self) {
        self.filter.restart();
        self.window.clear();
    }

    /// (Σ u² / threshold or NaN while the window fills, u²), None when untested.
    pub(crate) fn assess(
        &self,
        model: &MotionModel,
        threshold: f64,
        t: f64,
        z: f64,
    ) -> Result<Option<(f64, f64)>> {
        let Some(u) = self.filter.normalised_innovation(model, t, z)? else {
            return Ok(None);
        };
        let u2 = u * u;
        if self.window.len() + 1 < self.width {
            return Ok(Some((f64::NAN, u2)));
        }
        let skip = self.window.len() + 1 - self.width;
        let sum = self.window[skip..].iter().sum::<f64>() + u2;
        Ok(Some((sum / threshold, u2)))
    }

    pub(crate) fn commit(
        &mut self,
        model: &MotionModel,
        t: f64,
        z: f64,
        zv: f64,
        u2: Option<f64>,
    ) -> Result<()> {
        self.filter.step(model, t, z, zv)?;
        if let Some(u2) = u2 {
            if self.window.len() == self.width {
                self.window.remove(0);
            }
            self.window.push(u2);
        }
        Ok(())
    }

    /// Time of the last sample (NaN before the first).
    pub(crate) fn last_time(&self) -> f64 {
        self.filter.last_time()
    }

    pub(crate) fn save(&self, w: &mut Writer) {
        self.filter.save(w);
        w.count(self.window.len() as u64);
        w.f64s(&self.window);
        w.f64s(&vec![0.0; self.width - self.window.len()]);
    }

    pub(crate) fn load(r: &mut Reader, width: usize) -> Result<Self> {
        let filter = InnovationFilter::load(r)?;
        let len = r.count()? as usize;
        if len > width {
            return Err(r.corrupt());
        }
        let mut all = vec![0.0; width];
        r.fill(&mut all)?;
        all.truncate(len);
        r.check(
            all.iter().all(|&u2| square_statistic(u2)),
            "squared innovations negative, not finite or too large",
        )?;
        Ok(Self {
            filter,
            window: all,
            width,
        })
    }
}
