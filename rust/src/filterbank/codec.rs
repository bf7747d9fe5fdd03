//! The dynamic state of the identifier and of the IMM as bytes (the pickled form; the
//! configuration travels separately). Little-endian u64 and f64 words behind a magic tag and
//! the configuration's sizes, so bytes from another configuration or truncated ones are an
//! error, never a panic. The numbers are checked too (means within ±[`MAX_MEASUREMENT`],
//! covariances symmetric positive semi-definite, probabilities summing to 1): an altered state
//! is refused at load, not by a later frame.

use super::identifier::TypeIdentifier;
use super::imm::{ImmEstimator, ImmTrajectory};
use super::lanes::Trajectory;
use super::validation::MAX_MEASUREMENT;
use crate::kalman::Gaussian;
use crate::{FieldError, Result};
use nalgebra::{DMatrix, DVector, SymmetricEigen};

const BANK_MAGIC: u64 = u64::from_le_bytes(*b"KFBANK01");
const IMM_MAGIC: u64 = u64::from_le_bytes(*b"KFIMM001");

/// Largest |accumulated log-likelihood| restored: beyond it a frame's contribution is lost.
const MAX_LOG_LIKELIHOOD: f64 = 1e300;
/// Largest frame count restored (the Python side holds it as an int64).
const MAX_FRAME: u64 = i64::MAX as u64;

#[derive(Default)]
struct Writer(Vec<u8>);

impl Writer {
    fn u64(&mut self, v: u64) {
        self.0.extend_from_slice(&v.to_le_bytes());
    }
    fn f64s<'a>(&mut self, v: impl IntoIterator<Item = &'a f64>) {
        for x in v {
            self.0.extend_from_slice(&x.to_le_bytes());
        }
    }
    fn matrix(&mut self, a: &DMatrix<f64>) {
        self.f64s(a.iter());
    }
}

struct Reader<'a>(&'a [u8]);

fn corrupt() -> FieldError {
    FieldError::InvalidParameter(
        "the saved state is truncated or was saved by another version/configuration".into(),
    )
}

fn altered(what: &str) -> FieldError {
    FieldError::InvalidParameter(format!("the saved state is altered: {what}"))
}

/// A covariance matrix as a saved state may hold: finite entries within ±MAX_MEASUREMENT,
/// symmetric and positive semi-definite (both up to rounding).
fn is_covariance(a: &DMatrix<f64>) -> bool {
    if !a.iter().all(|v| v.abs() <= MAX_MEASUREMENT) {
        return false;
    }
    let scale = a.diagonal().iter().fold(0.0_f64, |m, &d| m.max(d));
    let tol = 1e-9 * scale;
    if !(a - a.transpose()).iter().all(|d| d.abs() <= tol) {
        return false;
    }
    let eigenvalues = SymmetricEigen::new((a + a.transpose()) * 0.5).eigenvalues;
    eigenvalues.iter().all(|&e| e >= -1e-9 * scale)
}

impl Reader<'_> {
    fn word(&mut self) -> Result<[u8; 8]> {
        if self.0.len() < 8 {
            return Err(corrupt());
        }
        let (head, tail) = self.0.split_at(8);
        self.0 = tail;
        Ok(head.try_into().unwrap())
    }
    fn u64(&mut self) -> Result<u64> {
        Ok(u64::from_le_bytes(self.word()?))
    }
    fn expect(&mut self, v: u64) -> Result<()> {
        if self.u64()? != v {
            return Err(corrupt());
        }
        Ok(())
    }
    fn f64s(&mut self, n: usize) -> Result<Vec<f64>> {
        if self.0.len() / 8 < n {
            return Err(corrupt());
        }
        (0..n)
            .map(|_| Ok(f64::from_le_bytes(self.word()?)))
            .collect()
    }
    fn matrix(&mut self, n: usize) -> Result<DMatrix<f64>> {
        Ok(DMatrix::from_column_slice(n, n, &self.f64s(n * n)?))
    }
    /// n values within ±`bound` (`what` names them in the error).
    fn bounded(&mut self, n: usize, bound: f64, what: &str) -> Result<Vec<f64>> {
        let v = self.f64s(n)?;
        if !v.iter().all(|x| x.abs() <= bound) {
            return Err(altered(&format!("{what} not finite or beyond ±{bound:e}")));
        }
        Ok(v)
    }
    /// A state estimate of n values.
    fn mean(&mut self, n: usize) -> Result<Vec<f64>> {
        self.bounded(n, MAX_MEASUREMENT, "a state estimate")
    }
    /// An n × n covariance (see [`is_covariance`]).
    fn covariance(&mut self, n: usize) -> Result<DMatrix<f64>> {
        let a = self.matrix(n)?;
        if !is_covariance(&a) {
            return Err(altered(
                "a covariance that is not symmetric positive semi-definite within ±1e150",
            ));
        }
        Ok(a)
    }
    /// k probabilities summing to 1.
    fn probabilities(&mut self, k: usize) -> Result<Vec<f64>> {
        let p = self.f64s(k)?;
        let sum: f64 = p.iter().sum();
        if !(p.iter().all(|v| (0.0..=1.0).contains(v)) && (sum - 1.0).abs() <= 1e-6) {
            return Err(altered(
                "mode probabilities outside [0, 1] or not summing to 1",
            ));
        }
        Ok(p)
    }
    /// The frame counter.
    fn frame(&mut self) -> Result<u64> {
        let frame = self.u64()?;
        if frame > MAX_FRAME {
            return Err(altered("a frame count beyond int64"));
        }
        Ok(frame)
    }
    fn end(&self) -> Result<()> {
        if !self.0.is_empty() {
            return Err(corrupt());
        }
        Ok(())
    }
}

impl TypeIdentifier {
    fn dims(&self) -> Vec<usize> {
        self.models.iter().map(|b| b.state_dim()).collect()
    }

    /// The dynamic state as bytes.
    pub fn state_bytes(&self) -> Vec<u8> {
        let mut w = Writer::default();
        w.u64(BANK_MAGIC);
        w.u64(self.models.len() as u64);
        w.u64(self.m as u64);
        self.dims().iter().for_each(|&n| w.u64(n as u64));
        w.u64(self.frame);
        w.u64(self.trajectories.len() as u64);
        self.shared_cov.iter().for_each(|c| w.matrix(c));
        for t in &self.trajectories {
            w.f64s(&t.means);
            w.f64s(&t.log_lik);
            w.u64(t.decision as u64);
            w.u64(u64::from(t.own_cov.is_some()));
            t.own_cov.iter().flatten().for_each(|c| w.matrix(c));
        }
        w.0
    }

    /// Restores a state saved by [`TypeIdentifier::state_bytes`] with the same models.
    pub fn load_state(&mut self, bytes: &[u8]) -> Result<()> {
        let mut r = Reader(bytes);
        let dims = self.dims();
        let k = dims.len();
        r.expect(BANK_MAGIC)?;
        r.expect(k as u64)?;
        r.expect(self.m as u64)?;
        dims.iter().try_for_each(|&n| r.expect(n as u64))?;
        let frame = r.frame()?;
        let n_traj = r.u64()? as usize;
        let shared: Vec<_> = dims
            .iter()
            .map(|&n| r.covariance(n))
            .collect::<Result<_>>()?;
        let total: usize = dims.iter().sum();
        let mut trajectories = Vec::new();
        for _ in 0..n_traj {
            let means = r.mean(total)?;
            let log_lik = r.bounded(k, MAX_LOG_LIKELIHOOD, "a log-likelihood")?;
            let decision = r.u64()? as i64;
            if !(-1..k as i64).contains(&decision) {
                return Err(corrupt());
            }
            let own_cov = match r.u64()? {
                0 => None,
                1 => Some(
                    dims.iter()
                        .map(|&n| r.covariance(n))
                        .collect::<Result<_>>()?,
                ),
                _ => return Err(corrupt()),
            };
            trajectories.push(Trajectory {
                means,
                log_lik,
                decision,
                own_cov,
            });
        }
        r.end()?;
        self.frame = frame;
        self.shared_cov = shared;
        self.trajectories = trajectories;
        Ok(())
    }
}

impl ImmEstimator {
    /// The dynamic state as bytes.
    pub fn state_bytes(&self) -> Vec<u8> {
        let mut w = Writer::default();
        w.u64(IMM_MAGIC);
        for v in [self.models.len(), self.n, self.m] {
            w.u64(v as u64);
        }
        w.u64(self.frame);
        w.u64(self.trajectories.len() as u64);
        for t in &self.trajectories {
            w.f64s(&t.mu);
            for e in &t.estimates {
                w.f64s(e.mean.iter());
                w.matrix(&e.cov);
            }
        }
        w.0
    }

    /// Restores a state saved by [`ImmEstimator::state_bytes`] with the same models.
    pub fn load_state(&mut self, bytes: &[u8]) -> Result<()> {
        let mut r = Reader(bytes);
        let (k, n) = (self.models.len(), self.n);
        r.expect(IMM_MAGIC)?;
        for v in [k, n, self.m] {
            r.expect(v as u64)?;
        }
        let frame = r.frame()?;
        let n_traj = r.u64()? as usize;
        let mut trajectories = Vec::new();
        for _ in 0..n_traj {
            let mu = r.probabilities(k)?;
            let estimates = (0..k)
                .map(|_| {
                    let mean = DVector::from_vec(r.mean(n)?);
                    Ok(Gaussian {
                        mean,
                        cov: r.covariance(n)?,
                    })
                })
                .collect::<Result<_>>()?;
            trajectories.push(ImmTrajectory { estimates, mu });
        }
        r.end()?;
        self.frame = frame;
        self.trajectories = trajectories;
        Ok(())
    }
}
