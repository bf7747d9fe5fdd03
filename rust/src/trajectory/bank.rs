//! Filters of k series fed sample by sample (the streaming object of the Python API).

use super::model::MotionModel;
use super::series::SeriesFilter;
use super::state::{Reader, Writer};
use crate::error::{FieldError, Result};

/// k [`SeriesFilter`]s sharing a model.
#[derive(Clone, Debug, PartialEq)]
pub struct FilterBank {
    pub model: MotionModel,
    lanes: Vec<SeriesFilter>,
}

impl FilterBank {
    /// `series` filters that have seen no sample.
    pub fn new(model: MotionModel, series: usize) -> Self {
        Self {
            model,
            lanes: vec![SeriesFilter::new(); series],
        }
    }

    pub fn series(&self) -> usize {
        self.lanes.len()
    }

    /// One sample per series at time `t` → (x̂, x̂') per series; nothing changes when an
    /// error is returned.
    pub fn step(&mut self, t: f64, z: &[f64], z_vel: Option<&[f64]>) -> Result<Vec<(f64, f64)>> {
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
            .map(|(i, f)| f.step(&self.model, t, z[i], z_vel.map_or(f64::NAN, |zv| zv[i])))
            .collect::<Result<Vec<_>>>()?;
        self.lanes = next;
        Ok(out)
    }

    /// The state of every series, concatenated.
    pub fn save(&self) -> Vec<f64> {
        let mut w = Writer::default();
        self.lanes.iter().for_each(|f| f.save(&mut w));
        w.0
    }

    /// Restores a state saved by [`FilterBank::save`].
    pub fn load(&mut self, state: &[f64]) -> Result<()> {
        let per = SeriesFilter::STATE_LEN;
        let mut r = Reader::new(state);
        if state.is_empty() || state.len() % per != 0 {
            return Err(r.corrupt());
        }
        let lanes = (0..state.len() / per)
            .map(|_| SeriesFilter::load(&mut r))
            .collect::<Result<Vec<_>>>()?;
        r.finish()?;
        self.lanes = lanes;
        Ok(())
    }
}
