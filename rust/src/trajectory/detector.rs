//! Change-point detection that restarts the filter [K95 8–10]: the fuzzy test, the
//! sliding-window χ² and the two-sided CUSUM of the normalised Kalman innovations.
//!
//! Each method runs its own filter of the same spreads for the test (the fuzzy filter for
//! "fuzzy", the diffuse-start Kalman filter for "chi2" and "cusum") next to the filter whose
//! estimates are returned. At an alarm at t_n both restart and the statistics reset: z_n is the
//! first sample of the estimator's new segment (t_0 = t_n, a new least-squares start)
//! [K95 10, step 3], and of the fuzzy test's filter; the Kalman filter of the χ² and CUSUM
//! tests starts from z_{n+1} instead, which keeps their false-alarm levels exact after
//! restarts.

use super::bank::{Bank, Lane};
use super::batch::Batch;
use super::chi2_test::Chi2Test;
use super::cusum_test::CusumTest;
use super::cusum_threshold::cusum_threshold;
use super::fuzzy_test::FuzzyTest;
use super::model::{GainRule, MotionModel};
use super::series::{check_sample, SeriesFilter};
use super::state::{same_time, Reader, Writer};
use super::time_step;
use crate::identification::chi_squared_quantile;
use crate::{FieldError, Result};
use rayon::prelude::*;

/// The longest χ² window.
pub const MAX_WINDOW: usize = 1024;

/// The test of a detector.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Method {
    Fuzzy,
    Chi2,
    Cusum,
}

impl Method {
    /// "fuzzy", "chi2" or "cusum".
    pub fn parse(name: &str) -> Result<Self> {
        match name {
            "fuzzy" => Ok(Self::Fuzzy),
            "chi2" => Ok(Self::Chi2),
            "cusum" => Ok(Self::Cusum),
            _ => Err(FieldError::InvalidParameter(format!(
                "method must be 'fuzzy', 'chi2' or 'cusum', got {name:?}"
            ))),
        }
    }
}

/// A detector's settings and its threshold.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DetectorConfig {
    pub method: Method,
    pub confidence: f64,
    /// W of the χ² test
    pub window: usize,
    /// k of the CUSUM
    pub drift: f64,
    /// -ln(1 - μ) (fuzzy), χ²_W(confidence) (chi2) or h (cusum)
    pub threshold: f64,
}

impl DetectorConfig {
    /// Checks the settings and computes the threshold.
    pub fn new(method: Method, confidence: f64, window: usize, drift: f64) -> Result<Self> {
        if !(confidence > 0.0 && confidence < 1.0) {
            return Err(FieldError::InvalidParameter(format!(
                "confidence must lie strictly between 0 and 1, got {confidence}"
            )));
        }
        if !(1..=MAX_WINDOW).contains(&window) {
            return Err(FieldError::InvalidParameter(format!(
                "window must lie in 1..={MAX_WINDOW}, got {window}"
            )));
        }
        let threshold = match method {
            Method::Fuzzy => -(-confidence).ln_1p(),
            Method::Chi2 => chi_squared_quantile(confidence, window as f64)?,
            Method::Cusum => cusum_threshold(confidence, drift)?,
        };
        Ok(Self {
            method,
            confidence,
            window,
            drift,
            threshold,
        })
    }

    fn state_len(&self) -> usize {
        SeriesFilter::STATE_LEN
            + match self.method {
                Method::Fuzzy => FuzzyTest::STATE_LEN,
                Method::Chi2 => Chi2Test::state_len(self.window),
                Method::Cusum => CusumTest::STATE_LEN,
            }
    }
}

#[derive(Clone, Debug, PartialEq)]
enum Test {
    Fuzzy(FuzzyTest),
    Chi2(Chi2Test),
    Cusum(CusumTest),
}

/// What one sample gave.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Outcome {
    pub x: f64,
    pub v: f64,
    pub alarm: bool,
    /// the test statistic over its threshold (alarm when > 1), NaN when untested
    pub ratio: f64,
}

/// A statistic over its threshold alarms when it exceeds 1 (NaN: untested).
fn alarms(ratio: f64) -> bool {
    ratio > 1.0
}

/// One series' detector: the estimating filter and the test.
#[derive(Clone, Debug, PartialEq)]
pub struct DetectorLane {
    estimator: SeriesFilter,
    test: Test,
}

impl DetectorLane {
    pub fn new(cfg: &DetectorConfig) -> Self {
        let test = match cfg.method {
            Method::Fuzzy => Test::Fuzzy(FuzzyTest::new()),
            Method::Chi2 => Test::Chi2(Chi2Test::new(cfg.window)),
            Method::Cusum => Test::Cusum(CusumTest::new()),
        };
        Self {
            estimator: SeriesFilter::new(),
            test,
        }
    }

    fn restart(&mut self) {
        self.estimator.restart();
        match &mut self.test {
            Test::Fuzzy(t) => t.restart(),
            Test::Chi2(t) => t.restart(),
            Test::Cusum(t) => t.restart(),
        }
    }

    /// Error unless (t, z, z') is a valid next sample (checked before anything changes).
    fn check(&self, model: &MotionModel, t: f64, z: f64, zv: f64) -> Result<()> {
        time_step(self.estimator.last_time(), t)?;
        check_sample(z, "a sample")?;
        if model.measures_velocity() {
            check_sample(zv, "a velocity sample")?;
        }
        Ok(())
    }

    /// Tests the sample, restarts at an alarm, filters the sample.
    pub fn step(
        &mut self,
        model: &MotionModel,
        cfg: &DetectorConfig,
        t: f64,
        z: f64,
        zv: f64,
    ) -> Result<Outcome> {
        self.check(model, t, z, zv)?;
        let thr = cfg.threshold;
        let ratio = match &mut self.test {
            Test::Fuzzy(test) => {
                let a = test.assess(model, thr, t, z)?;
                let ratio = a.map_or(f64::NAN, |(r, _)| r);
                if !alarms(ratio) {
                    test.commit(model, t, z, zv, a.map(|(_, p)| p))?;
                }
                ratio
            }
            Test::Chi2(test) => {
                let a = test.assess(model, thr, t, z)?;
                let ratio = a.map_or(f64::NAN, |(r, _)| r);
                if !alarms(ratio) {
                    test.commit(model, t, z, zv, a.map(|(_, u2)| u2))?;
                }
                ratio
            }
            Test::Cusum(test) => {
                let a = test.assess(model, cfg.drift, thr, t, z)?;
                let ratio = a.map_or(f64::NAN, |(r, _)| r);
                if !alarms(ratio) {
                    test.commit(model, t, z, zv, a.map(|(_, g)| g))?;
                }
                ratio
            }
        };
        let alarm = alarms(ratio);
        if alarm {
            self.restart();
            match &mut self.test {
                Test::Fuzzy(test) => test.commit(model, t, z, zv, None)?,
                // the alarm selected this sample's noise: the Kalman filter of the χ² and
                // CUSUM tests starts afresh from the next sample, so that their innovations
                // stay independent of the past (with z_n, +14 % false alarms measured)
                Test::Chi2(test) => test.commit(model, t, f64::NAN, f64::NAN, None)?,
                Test::Cusum(test) => test.commit(model, t, f64::NAN, f64::NAN, None)?,
            }
        }
        let (x, v) = self.estimator.step(model, t, z, zv)?;
        Ok(Outcome { x, v, alarm, ratio })
    }

    fn save(&self, w: &mut Writer) {
        self.estimator.save(w);
        match &self.test {
            Test::Fuzzy(t) => t.save(w),
            Test::Chi2(t) => t.save(w),
            Test::Cusum(t) => t.save(w),
        }
    }

    fn load(r: &mut Reader, model: &MotionModel, cfg: &DetectorConfig) -> Result<Self> {
        let estimator = SeriesFilter::load(r, model.rule == GainRule::Kalman)?;
        let test = match cfg.method {
            Method::Fuzzy => Test::Fuzzy(FuzzyTest::load(r)?),
            Method::Chi2 => Test::Chi2(Chi2Test::load(r, cfg.window)?),
            Method::Cusum => Test::Cusum(CusumTest::load(r)?),
        };
        let test_time = match &test {
            Test::Fuzzy(t) => t.last_time(),
            Test::Chi2(t) => t.last_time(),
            Test::Cusum(t) => t.last_time(),
        };
        r.check(
            same_time(test_time, estimator.last_time()),
            "the detector's test and estimator disagree on the last time",
        )?;
        Ok(Self { estimator, test })
    }
}

/// What the lanes of a [`DetectorBank`] share.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DetectorSettings {
    pub model: MotionModel,
    pub config: DetectorConfig,
}

impl Lane for DetectorLane {
    type Settings = DetectorSettings;
    type Out = Outcome;
    fn fresh(s: &DetectorSettings) -> Self {
        DetectorLane::new(&s.config)
    }
    fn advance(&mut self, s: &DetectorSettings, t: f64, z: f64, zv: f64) -> Result<Outcome> {
        self.step(&s.model, &s.config, t, z, zv)
    }
    fn state_len(s: &DetectorSettings) -> usize {
        s.config.state_len()
    }
    fn save(&self, w: &mut Writer) {
        DetectorLane::save(self, w)
    }
    fn load(r: &mut Reader, s: &DetectorSettings) -> Result<Self> {
        DetectorLane::load(r, &s.model, &s.config)
    }
    fn last_time(&self) -> f64 {
        self.estimator.last_time()
    }
}

/// Detectors of k series fed sample by sample (the streaming object).
pub type DetectorBank = Bank<DetectorLane>;

/// Outputs of [`detect_batch`], series-major like the samples.
pub struct Detections<'a> {
    pub pos: &'a mut [f64],
    pub vel: &'a mut [f64],
    pub alarm: &'a mut [bool],
    pub ratio: &'a mut [f64],
}

/// Runs a detector over every series of `batch` (rayon over series; deterministic).
pub fn detect_batch(
    model: &MotionModel,
    cfg: &DetectorConfig,
    batch: &Batch,
    out: Detections,
) -> Result<()> {
    batch.check_shapes(model)?;
    let n = batch.n_samples;
    let size = batch.z.len();
    if [
        out.pos.len(),
        out.vel.len(),
        out.alarm.len(),
        out.ratio.len(),
    ] != [size; 4]
    {
        return Err(FieldError::Shape(
            "the outputs must have the size of z".into(),
        ));
    }
    if n == 0 {
        return Ok(());
    }
    out.pos
        .par_chunks_mut(n)
        .zip(out.vel.par_chunks_mut(n))
        .zip(out.alarm.par_chunks_mut(n))
        .zip(out.ratio.par_chunks_mut(n))
        .enumerate()
        .try_for_each(|(s, (((pos, vel), alarm), ratio))| {
            let mut lane = DetectorLane::new(cfg);
            for k in 0..n {
                let i = s * n + k;
                let zv = batch.z_vel.map_or(f64::NAN, |zv| zv[i]);
                let o = lane.step(model, cfg, batch.time(s, k), batch.z[i], zv)?;
                (pos[k], vel[k], alarm[k], ratio[k]) = (o.x, o.v, o.alarm, o.ratio);
            }
            Ok(())
        })
}
