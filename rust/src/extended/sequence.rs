//! One segment sequence (a fragment of an object, SPEC §3.4): per axis its own Kalman state
//! (3.1), the features (amplitude, log area; ν = 0) that join the index after ν + 1
//! observations (step 9), and the sliding window of index increments (§3.2).

// Index loops over axes and parameters mirror the formulas and the NumPy twin.
#![allow(clippy::needless_range_loop)]

use super::config::{GroupConfig, CENTROID_DOF, FEATURE_DOF};
use super::motion::{apply, propagate, Matrix, Vector, DIM};

/// The measurement of one segment: centroid, features, bounding box.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Measurement {
    pub x: f64,
    pub y: f64,
    pub amplitude: f64,
    pub area: f64,
    /// bbox x0, y0, x1, y1 (inclusive).
    pub bbox: [f64; 4],
}

impl Measurement {
    pub(crate) fn position(&self) -> [f64; 2] {
        [self.x, self.y]
    }
    pub(crate) fn features(&self) -> [f64; 2] {
        [self.amplitude, self.area.ln()]
    }
}

/// A fragment's sequence.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Sequence {
    pub id: u64,
    /// Per axis: (position, velocity, acceleration) of this sequence.
    pub state: [Vector; 2],
    pub cov: [Matrix; 2],
    /// Features: running sum before joining, then the Kalman estimate.
    pub feature: [f64; 2],
    pub feature_var: [f64; 2],
    /// Box of its last segment.
    pub bbox: [f64; 4],
    /// Observations so far.
    pub length: usize,
    /// Index increments and their degrees of freedom, oldest first (at most N).
    pub window: Vec<(f64, usize)>,
    /// Segment of the current frame, if confirmed in it.
    pub segment: Option<usize>,
    /// Its centroid minus its group's centre, recorded while it is a member.
    pub offset: Option<[f64; 2]>,
}

/// The gate values of a sequence for the current frame: predicted centroid (with the group's
/// shared derivatives, (3.3)), innovation variances, and the predicted features if joined.
pub(crate) struct Prediction {
    pub centre: [f64; 2],
    pub centroid_var: [f64; 2],
    pub feature_var: Option<[f64; 2]>,
    pub window_index: f64,
    pub window_dof: usize,
}

pub(crate) struct Filters<'a> {
    pub config: &'a GroupConfig,
    pub f: Matrix,
    pub q: Matrix,
}

impl Filters<'_> {
    fn d(&self) -> usize {
        self.config.order + 1
    }

    fn feature_std(&self) -> [f64; 2] {
        [self.config.amplitude_std, self.config.log_area_std]
    }

    /// A new sequence at measurement `z` with derivatives `shared` (step 4 and 8).
    pub fn start(&self, id: u64, z: &Measurement, shared: &[Vector; 2]) -> Sequence {
        let r = self.config.position_std.powi(2);
        let mut state = *shared;
        let mut cov = [[[0.0; DIM]; DIM]; 2];
        for axis in 0..2 {
            state[axis][0] = z.position()[axis];
            cov[axis][0][0] = r;
            for (k, row) in cov[axis].iter_mut().enumerate().take(self.d()).skip(1) {
                row[k] =
                    (self.config.initial_speed_std / self.config.dt.powi(k as i32 - 1)).powi(2);
            }
        }
        Sequence {
            id,
            state,
            cov,
            feature: z.features(),
            feature_var: [0.0; 2],
            bbox: z.bbox,
            length: 1,
            window: Vec::new(),
            segment: None,
            offset: None,
        }
    }

    /// Variance added per axis to the centroid of a *partial* segment: its box kept one edge
    /// of the sequence's last box moved by the sequence's velocity (within one pixel) while its
    /// extent changed by Δ — a fragment vanished or reappeared at the other edge, which moves
    /// the centroid by up to Δ/2 while the object does not move: (Δ/2)² (method page, §3.4).
    pub fn partial_var(&self, s: &Sequence, z: &Measurement) -> [f64; 2] {
        [0, 1].map(|axis| {
            let shift = s.state[axis][1] * self.config.dt;
            let lo = z.bbox[axis] - s.bbox[axis] - shift;
            let hi = z.bbox[axis + 2] - s.bbox[axis + 2] - shift;
            if lo.abs().min(hi.abs()) <= 1.0 {
                (0.5 * (hi - lo)).powi(2)
            } else {
                0.0
            }
        })
    }

    fn joined(&self, s: &Sequence) -> bool {
        s.length > self.config.order
    }

    pub fn predict(&self, s: &Sequence, shared: &[Vector; 2]) -> Prediction {
        let d = self.d();
        let r = self.config.position_std.powi(2);
        let mut centre = [0.0; 2];
        let mut centroid_var = [0.0; 2];
        for axis in 0..2 {
            let mut x = shared[axis];
            x[0] = s.state[axis][0];
            centre[axis] = apply(&self.f, &x, d)[0];
            centroid_var[axis] = propagate(&self.f, &s.cov[axis], &self.q, d)[0][0] + r;
        }
        let feature_var = self.joined(s).then(|| {
            let std = self.feature_std();
            [0, 1].map(|q| {
                s.feature_var[q] + (1.0 + self.config.feature_drift.powi(2)) * std[q].powi(2)
            })
        });
        let (mut window_index, mut window_dof) = (0.0, 0);
        let skip = usize::from(s.window.len() >= self.config.memory);
        for &(value, dof) in &s.window[skip..] {
            window_index += value;
            window_dof += dof;
        }
        Prediction {
            centre,
            centroid_var,
            feature_var,
            window_index,
            window_dof,
        }
    }

    /// Kalman prediction without an update, with the sequence's own derivatives (its segment
    /// measures it no more: merged with another object's, or the object is hidden); its box
    /// moves by its velocity. Length and index window stay.
    pub fn coast(&self, s: &mut Sequence) {
        let d = self.d();
        for axis in 0..2 {
            let shift = s.state[axis][1] * self.config.dt;
            s.bbox[axis] += shift;
            s.bbox[axis + 2] += shift;
            s.state[axis] = apply(&self.f, &s.state[axis], d);
            s.cov[axis] = propagate(&self.f, &s.cov[axis], &self.q, d);
        }
    }

    /// The index increment of measurement `z` and its degrees of freedom ((3.4) + (3.6)).
    pub fn increment(&self, s: &Sequence, p: &Prediction, z: &Measurement) -> (f64, usize) {
        let pos = z.position();
        let partial = self.partial_var(s, z);
        let mut value = 0.0;
        for axis in 0..2 {
            value += (pos[axis] - p.centre[axis]).powi(2) / (p.centroid_var[axis] + partial[axis]);
        }
        let mut dof = CENTROID_DOF;
        if let Some(var) = p.feature_var {
            let f = z.features();
            for q in 0..2 {
                value += (f[q] - s.feature[q]).powi(2) / var[q];
            }
            dof += FEATURE_DOF;
        }
        (value, dof)
    }

    /// Kalman update (3.1) with the sequence's own state, the increment pushed to the window,
    /// the features accumulated (least squares) until they join, filtered after.
    pub fn update(&self, s: &mut Sequence, z: &Measurement, increment: (f64, usize)) {
        let d = self.d();
        let r = self.config.position_std.powi(2);
        let pos = z.position();
        let partial = self.partial_var(s, z);
        for axis in 0..2 {
            let x = apply(&self.f, &s.state[axis], d);
            let p = propagate(&self.f, &s.cov[axis], &self.q, d);
            let innovation = pos[axis] - x[0];
            let dvar = p[0][0] + r + partial[axis];
            let mut state = [0.0; DIM];
            let mut cov = [[0.0; DIM]; DIM];
            for i in 0..d {
                state[i] = x[i] + p[i][0] / dvar * innovation;
                for j in 0..d {
                    cov[i][j] = p[i][j] - p[i][0] * p[0][j] / dvar;
                }
            }
            s.state[axis] = state;
            s.cov[axis] = cov;
        }
        let f = z.features();
        let std = self.feature_std();
        if self.joined(s) {
            for q in 0..2 {
                let prior = s.feature_var[q] + (self.config.feature_drift * std[q]).powi(2);
                let gain = prior / (prior + std[q] * std[q]);
                s.feature[q] += gain * (f[q] - s.feature[q]);
                s.feature_var[q] = (1.0 - gain) * prior;
            }
        } else {
            for q in 0..2 {
                s.feature[q] += f[q];
            }
            if s.length + 1 > self.config.order {
                let n = (s.length + 1) as f64;
                for q in 0..2 {
                    s.feature[q] /= n;
                    s.feature_var[q] = std[q] * std[q] / n;
                }
            }
        }
        if s.window.len() >= self.config.memory {
            s.window.remove(0);
        }
        s.window.push(increment);
        s.bbox = z.bbox;
        s.length += 1;
    }
}
