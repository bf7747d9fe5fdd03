//! The batched filter: many series × samples at once (the hot kernel).
//!
//! Series are independent: rayon tasks take consecutive runs of series, so the result does not
//! depend on the thread count. With times shared by all series, the gains depend on the times
//! only, so they are computed once ([`gain_sequence`]) and a block of [`LANES`] series without
//! missing samples runs the correction of the source's form (7) as struct-of-arrays: the block
//! is transposed into a sample-major scratch buffer (L1-resident), filtered with the lanes
//! side by side (they vectorise; AVX2 when the CPU has it, without FMA) and transposed back.
//! Any other block (missing samples, per-series times, the last partial block) runs
//! [`SeriesFilter`] series by series; both paths do the same floating-point operations in the
//! same order, so they give the same bits.

use super::gain::Gain;
use super::gain_recursion::gain_sequence;
use super::model::MotionModel;
use super::series::{correct, correct_position, predict, SeriesFilter, MAX_SAMPLE};
use super::start::least_squares_start;
use crate::{FieldError, Result};
use rayon::prelude::*;

/// Series per vectorised block.
pub const LANES: usize = 8;
/// Series per rayon task.
const TASK_SERIES: usize = 32 * LANES;
/// Samples of a segment run by [`SeriesFilter`] before the shared gains take over.
const WARM_UP: usize = 3;

/// The sample times.
#[derive(Clone, Copy, Debug)]
pub enum Times<'a> {
    /// t_n = n for every series.
    Regular,
    /// One time per sample, shared by all series.
    Shared(&'a [f64]),
    /// One time per series and sample (series-major, like the samples).
    PerSeries(&'a [f64]),
}

/// A batch of series: samples `z` (series-major, NaN = missing), optional velocity samples.
#[derive(Clone, Copy, Debug)]
pub struct Batch<'a> {
    pub z: &'a [f64],
    pub z_vel: Option<&'a [f64]>,
    pub times: Times<'a>,
    pub n_series: usize,
    pub n_samples: usize,
}

impl Batch<'_> {
    /// Error unless every array has the batch's size.
    pub fn check_shapes(&self, model: &MotionModel) -> Result<()> {
        let size = self.n_series.checked_mul(self.n_samples);
        let shape = |what: &str, len: usize, want: Option<usize>| {
            if Some(len) == want {
                Ok(())
            } else {
                Err(FieldError::Shape(format!(
                    "{what} holds {len} values, the batch has {} series × {} samples",
                    self.n_series, self.n_samples
                )))
            }
        };
        shape("z", self.z.len(), size)?;
        match (self.z_vel, model.measures_velocity()) {
            (Some(zv), true) => shape("the velocity samples", zv.len(), size)?,
            (None, false) => {}
            (None, true) => {
                return Err(FieldError::InvalidParameter(
                    "the filter measures velocities (R_vel given): pass the velocity samples"
                        .into(),
                ))
            }
            (Some(_), false) => {
                return Err(FieldError::InvalidParameter(
                    "velocity samples were given but the filter has no R_vel".into(),
                ))
            }
        }
        match self.times {
            Times::Regular => Ok(()),
            Times::Shared(t) => shape("times", t.len() * self.n_series, size),
            Times::PerSeries(t) => shape("times", t.len(), size),
        }
    }

    /// Time of sample `n` of series `s`.
    #[inline]
    pub fn time(&self, s: usize, n: usize) -> f64 {
        match self.times {
            Times::Regular => n as f64,
            Times::Shared(t) => t[n],
            Times::PerSeries(t) => t[s * self.n_samples + n],
        }
    }

    /// The times shared by all series (None when they differ per series).
    fn shared_times(&self) -> Option<Vec<f64>> {
        match self.times {
            Times::Regular => Some((0..self.n_samples).map(|n| n as f64).collect()),
            Times::Shared(t) => Some(t.to_vec()),
            Times::PerSeries(_) => None,
        }
    }
}

/// Gains and time steps shared by all series.
struct SharedGains {
    times: Vec<f64>,
    taus: Vec<f64>,
    gains: Vec<Gain>,
}

impl SharedGains {
    /// The estimate at warm-up sample `k` of a series observed from its first sample: the
    /// operations of [`SeriesFilter`]'s warm-up with the gains read from the table.
    fn warm_up(&self, model: &MotionModel, k: usize, z: &[f64], zv: Option<&[f64]>) -> (f64, f64) {
        let (x0, v0) = least_squares_start(model.has_velocity(), &self.times[..=k], &z[..=k]);
        let nu_v = |i: usize, ve: f64| zv.map_or(0.0, |zv| zv[i] - ve);
        let (mut x, mut v) = correct(model, x0, v0, &self.gains[0], z[0] - x0, nu_v(0, v0));
        let steps = self.taus[1..=k]
            .iter()
            .zip(&self.gains[1..=k])
            .zip(&z[1..=k]);
        for (j, ((&tau, g), &zi)) in steps.enumerate() {
            let (xe, ve) = predict(x, v, tau);
            (x, v) = correct(model, xe, ve, g, zi - xe, nu_v(j + 1, ve));
        }
        (x, v)
    }

    fn new(model: &MotionModel, times: Vec<f64>) -> Result<Self> {
        let gains = gain_sequence(model, &times)?;
        let mut taus = vec![f64::NAN; times.len()];
        for n in 1..times.len() {
            taus[n] = times[n] - times[n - 1];
        }
        Ok(Self { times, taus, gains })
    }
}

/// Filters every series of `batch` into `pos` and `vel` (series-major, like `z`).
pub fn filter_batch(
    model: &MotionModel,
    batch: &Batch,
    pos: &mut [f64],
    vel: &mut [f64],
) -> Result<()> {
    batch.check_shapes(model)?;
    let n = batch.n_samples;
    if pos.len() != batch.z.len() || vel.len() != batch.z.len() {
        return Err(FieldError::Shape(
            "the outputs must have the size of z".into(),
        ));
    }
    if n == 0 || batch.n_series == 0 {
        return Ok(());
    }
    let shared = batch
        .shared_times()
        .map(|t| SharedGains::new(model, t))
        .transpose()?;
    let task = TASK_SERIES * n;
    pos.par_chunks_mut(task)
        .zip(vel.par_chunks_mut(task))
        .enumerate()
        .try_for_each(|(c, (pos, vel))| {
            let mut scratch = Scratch::new(n);
            let first = c * TASK_SERIES;
            let count = pos.len() / n;
            for b in (0..count).step_by(LANES) {
                let lanes = LANES.min(count - b);
                let rows = b * n..(b + lanes) * n;
                let block = Block {
                    first: first + b,
                    lanes,
                };
                let (p, v) = (&mut pos[rows.clone()], &mut vel[rows]);
                let done = match &shared {
                    Some(g) => block.fast(model, batch, g, &mut scratch, p, v)?,
                    None => false,
                };
                if !done {
                    block.series_by_series(model, batch, p, v)?;
                }
            }
            Ok(())
        })
}

/// Sample-major buffers of one block.
struct Scratch {
    z: Vec<f64>,
    z_vel: Vec<f64>,
    pos: Vec<f64>,
    vel: Vec<f64>,
}

impl Scratch {
    fn new(n: usize) -> Self {
        let len = n.saturating_sub(WARM_UP) * LANES;
        Self {
            z: vec![0.0; len],
            z_vel: vec![0.0; len],
            pos: vec![0.0; len],
            vel: vec![0.0; len],
        }
    }
}

/// `lanes` consecutive series starting at series `first`.
struct Block {
    first: usize,
    lanes: usize,
}

impl Block {
    fn series_by_series(
        &self,
        model: &MotionModel,
        batch: &Batch,
        pos: &mut [f64],
        vel: &mut [f64],
    ) -> Result<()> {
        let n = batch.n_samples;
        for l in 0..self.lanes {
            let s = self.first + l;
            let mut f = SeriesFilter::new();
            for k in 0..n {
                let i = s * n + k;
                let zv = batch.z_vel.map_or(f64::NAN, |zv| zv[i]);
                let (x, v) = f.step(model, batch.time(s, k), batch.z[i], zv)?;
                pos[l * n + k] = x;
                vel[l * n + k] = v;
            }
        }
        Ok(())
    }

    /// The shared-gains path; Ok(false) when the block cannot take it (a missing or invalid
    /// sample, a partial block), and then the block runs series by series.
    fn fast(
        &self,
        model: &MotionModel,
        batch: &Batch,
        shared: &SharedGains,
        scratch: &mut Scratch,
        pos: &mut [f64],
        vel: &mut [f64],
    ) -> Result<bool> {
        let n = batch.n_samples;
        if self.lanes < LANES && n > WARM_UP {
            return Ok(false);
        }
        let warm = n.min(WARM_UP);
        let observed = |row: &[f64]| row[..warm].iter().all(|z| z.abs() <= MAX_SAMPLE);
        let mut state = Lanes {
            x: [0.0; LANES],
            v: [0.0; LANES],
        };
        for l in 0..self.lanes {
            let s = self.first + l;
            let z = &batch.z[s * n..(s + 1) * n];
            let zv = batch.z_vel.map(|zv| &zv[s * n..(s + 1) * n]);
            if !observed(z) || !zv.is_none_or(observed) {
                return Ok(false);
            }
            for k in 0..warm {
                let (a, b) = shared.warm_up(model, k, z, zv);
                (pos[l * n + k], vel[l * n + k]) = (a, b);
                (state.x[l], state.v[l]) = (a, b);
            }
        }
        if n <= WARM_UP {
            return Ok(true);
        }
        let rows = self.first * n..(self.first + LANES) * n;
        let z_vel = batch.z_vel.map(|zv| &zv[rows.clone()]);
        let run = BlockRun {
            model,
            shared,
            n,
            z: &batch.z[rows],
            z_vel,
        };
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU has AVX2. The arithmetic is the plain multiply/add of the
            // portable build (Rust never contracts to FMA): the same bits.
            return unsafe { run.avx2(&mut state, scratch, pos, vel) };
        }
        run.portable(&mut state, scratch, pos, vel)
    }
}

/// The lanes' estimates.
struct Lanes {
    x: [f64; LANES],
    v: [f64; LANES],
}

/// Samples WARM_UP.. of a full block with the shared gains.
struct BlockRun<'a> {
    model: &'a MotionModel,
    shared: &'a SharedGains,
    n: usize,
    /// the block's LANES series, series-major
    z: &'a [f64],
    z_vel: Option<&'a [f64]>,
}

impl BlockRun<'_> {
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn avx2(
        &self,
        state: &mut Lanes,
        scratch: &mut Scratch,
        pos: &mut [f64],
        vel: &mut [f64],
    ) -> Result<bool> {
        self.run(state, scratch, pos, vel)
    }

    fn portable(
        &self,
        state: &mut Lanes,
        scratch: &mut Scratch,
        pos: &mut [f64],
        vel: &mut [f64],
    ) -> Result<bool> {
        self.run(state, scratch, pos, vel)
    }

    /// Transposes the block sample-major (lanes contiguous), runs the recursion lane-parallel,
    /// transposes the estimates back. Ok(false) when a sample is missing or out of range.
    #[inline(always)]
    fn run(
        &self,
        state: &mut Lanes,
        scratch: &mut Scratch,
        pos: &mut [f64],
        vel: &mut [f64],
    ) -> Result<bool> {
        let n = self.n;
        if !gather(self.z, n, &mut scratch.z) {
            return Ok(false);
        }
        if let Some(zv) = self.z_vel {
            if !gather(zv, n, &mut scratch.z_vel) {
                return Ok(false);
            }
        }
        // the lanes' estimates in local arrays: straight-line lane-wise code vectorises
        let (mut x, mut v) = (state.x, state.v);
        let (model, shared) = (self.model, self.shared);
        let steps = (WARM_UP..n).zip(scratch.z.chunks_exact(LANES));
        let outs = scratch
            .pos
            .chunks_exact_mut(LANES)
            .zip(scratch.vel.chunks_exact_mut(LANES));
        if self.z_vel.is_some() {
            let zvs = scratch.z_vel.chunks_exact(LANES);
            for (((k, z), zv), (p, q)) in steps.zip(zvs).zip(outs) {
                let (g, tau) = (&shared.gains[k], shared.taus[k]);
                for l in 0..LANES {
                    let (xe, ve) = predict(x[l], v[l], tau);
                    (x[l], v[l]) = correct(model, xe, ve, g, z[l] - xe, zv[l] - ve);
                }
                p.copy_from_slice(&x);
                q.copy_from_slice(&v);
            }
        } else {
            for ((k, z), (p, q)) in steps.zip(outs) {
                let (g, tau) = (&shared.gains[k], shared.taus[k]);
                let z: &[f64; LANES] = z.try_into().expect("LANES");
                let mut xe = [0.0; LANES];
                let mut ve = [0.0; LANES];
                for l in 0..LANES {
                    (xe[l], ve[l]) = predict(x[l], v[l], tau);
                }
                for l in 0..LANES {
                    (x[l], v[l]) = correct_position(xe[l], ve[l], g.xx, g.vx, z[l] - xe[l]);
                }
                p.copy_from_slice(&x);
                q.copy_from_slice(&v);
            }
        }
        // a non-finite value never becomes finite again in this recursion
        if !(x.iter().all(|x| x.is_finite()) && v.iter().all(|v| v.is_finite())) {
            return Err(super::gain_recursion::overflow());
        }
        scatter(&scratch.pos, n, pos);
        scatter(&scratch.vel, n, vel);
        Ok(true)
    }
}

/// Samples WARM_UP.. of the block's series into `dst`, sample-major; false when one is
/// missing or out of range.
#[inline(always)]
fn gather(src: &[f64], n: usize, dst: &mut [f64]) -> bool {
    let m = n - WARM_UP;
    assert!(src.len() == LANES * n && dst.len() == LANES * m);
    let mut ok = true;
    for k in 0..m {
        for l in 0..LANES {
            let z = src[l * n + WARM_UP + k];
            ok &= z.abs() <= MAX_SAMPLE;
            dst[k * LANES + l] = z;
        }
    }
    ok
}

/// The inverse of [`gather`] into the block's output rows.
#[inline(always)]
fn scatter(src: &[f64], n: usize, dst: &mut [f64]) {
    let m = n - WARM_UP;
    assert!(dst.len() == LANES * n && src.len() == LANES * m);
    for l in 0..LANES {
        for k in 0..m {
            dst[l * n + WARM_UP + k] = src[k * LANES + l];
        }
    }
}
