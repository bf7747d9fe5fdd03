//! Filters or detectors of k series fed sample by sample (the streaming objects of the Python
//! API): one [`Lane`] per series, stepped together, saved as one flat state.

use super::model::{GainRule, MotionModel};
use super::series::SeriesFilter;
use super::state::{same_time, Reader, Writer};
use crate::{FieldError, Result};

/// One series' streaming state.
pub trait Lane: Clone + Sized {
    /// What every lane shares (the model, the detector's configuration).
    type Settings: Copy;
    /// What a step returns.
    type Out;
    fn fresh(settings: &Self::Settings) -> Self;
    /// Takes the sample (t, z, z') in (NaN = missing).
    fn advance(&mut self, settings: &Self::Settings, t: f64, z: f64, zv: f64) -> Result<Self::Out>;
    /// Numbers in [`Lane::save`]'s output.
    fn state_len(settings: &Self::Settings) -> usize;
    fn save(&self, w: &mut Writer);
    fn load(r: &mut Reader, settings: &Self::Settings) -> Result<Self>;
    /// Time of the last sample (NaN before the first).
    fn last_time(&self) -> f64;
}

impl Lane for SeriesFilter {
    type Settings = MotionModel;
    type Out = (f64, f64);
    fn fresh(_: &MotionModel) -> Self {
        SeriesFilter::new()
    }
    fn advance(&mut self, model: &MotionModel, t: f64, z: f64, zv: f64) -> Result<(f64, f64)> {
        self.step(model, t, z, zv)
    }
    fn state_len(_: &MotionModel) -> usize {
        SeriesFilter::STATE_LEN
    }
    fn save(&self, w: &mut Writer) {
        SeriesFilter::save(self, w)
    }
    fn load(r: &mut Reader, model: &MotionModel) -> Result<Self> {
        SeriesFilter::load(r, model.rule == GainRule::Kalman)
    }
    fn last_time(&self) -> f64 {
        SeriesFilter::last_time(self)
    }
}

/// k lanes sharing their settings.
#[derive(Clone, Debug, PartialEq)]
pub struct Bank<L: Lane> {
    pub settings: L::Settings,
    lanes: Vec<L>,
}

/// The streaming filter of k series.
pub type FilterBank = Bank<SeriesFilter>;

impl<L: Lane> Bank<L> {
    /// `series` lanes that have seen no sample.
    pub fn new(settings: L::Settings, series: usize) -> Self {
        Self {
            settings,
            lanes: vec![L::fresh(&settings); series],
        }
    }

    pub fn series(&self) -> usize {
        self.lanes.len()
    }

    /// Time of the last step (None before the first); every lane steps at the same times.
    pub fn last_time(&self) -> Option<f64> {
        self.lanes.first().map(L::last_time).filter(|t| !t.is_nan())
    }

    /// One sample per series at time `t`; nothing changes when an error is returned.
    pub fn step(&mut self, t: f64, z: &[f64], z_vel: Option<&[f64]>) -> Result<Vec<L::Out>> {
        let k = self.lanes.len();
        if z.len() != k || z_vel.is_some_and(|zv| zv.len() != k) {
            return Err(FieldError::Shape(format!(
                "a step needs one sample per series ({k})"
            )));
        }
        let mut next = self.lanes.clone();
        let out = next
            .iter_mut()
            .enumerate()
            .map(|(i, lane)| {
                let zv = z_vel.map_or(f64::NAN, |zv| zv[i]);
                lane.advance(&self.settings, t, z[i], zv)
            })
            .collect::<Result<Vec<_>>>()?;
        self.lanes = next;
        Ok(out)
    }

    /// The state of every series, concatenated.
    pub fn save(&self) -> Vec<f64> {
        let mut w = Writer::default();
        self.lanes.iter().for_each(|l| l.save(&mut w));
        w.0
    }

    /// Restores a state saved by [`Bank::save`] with the same settings (any series count).
    pub fn load(&mut self, state: &[f64]) -> Result<()> {
        let per = L::state_len(&self.settings);
        let mut r = Reader::new(state);
        if state.is_empty() || state.len() % per != 0 {
            return Err(r.corrupt());
        }
        let lanes = (0..state.len() / per)
            .map(|_| L::load(&mut r, &self.settings))
            .collect::<Result<Vec<_>>>()?;
        r.finish()?;
        let t = lanes[0].last_time();
        r.check(
            lanes.iter().all(|l| same_time(l.last_time(), t)),
            "series with different last times",
        )?;
        self.lanes = lanes;
        Ok(())
    }
}
