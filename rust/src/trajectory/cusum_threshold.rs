//! The CUSUM threshold h for a false-alarm level: the mean run length of the one-sided CUSUM
//! g_n = max(0, g_{n-1} + u_n - k) of independent N(0, 1) increments, from g_0 = 0 to the
//! first g > h, solves Page's integral equation
//!
//!   L(x) = 1 + L(0) Φ(k - x) + ∫_0^h L(y) φ(y + k - x) dy,   0 ≤ x ≤ h,
//!
//! here by Nyström's method on Gauss–Legendre nodes (the point mass at 0 is the unknown L(0)).
//! The two-sided CUSUM with reference ±k alarms at the rate 1/ARL = 2/L(0)
//! (Van Dobben de Bruyn's combination of the sides, exact when they never are positive
//! together and very close otherwise); h is the root of 2/L(0) = 1 - confidence.

use crate::{FieldError, Result};
use nalgebra::{DMatrix, DVector};
use statrs::distribution::{Continuous, ContinuousCDF, Normal};

/// Nodes per unit of h (Gauss–Legendre; the kernel φ is smooth on the unit scale).
const NODES_PER_UNIT: f64 = 12.0;
const MIN_NODES: usize = 32;
const MAX_NODES: usize = 480;
/// The largest threshold searched.
pub const MAX_THRESHOLD: f64 = 40.0;
/// The longest one-sided mean run length computed: the linear system's conditioning grows
/// like the run length, so beyond ~1e9 samples its relative error exceeds ~1e-6.
pub const MAX_RUN_LENGTH: f64 = 1e9;

/// Gauss–Legendre nodes and weights on [0, h] (Newton on the Legendre polynomial).
fn gauss_legendre(n: usize, h: f64) -> (Vec<f64>, Vec<f64>) {
    let mut nodes = vec![0.0; n];
    let mut weights = vec![0.0; n];
    let nf = n as f64;
    for i in 0..n {
        let mut x = (std::f64::consts::PI * (i as f64 + 0.75) / (nf + 0.5)).cos();
        let mut dp = 1.0;
        for _ in 0..100 {
            let (mut p0, mut p1) = (1.0, x);
            for j in 2..=n {
                let jf = j as f64;
                (p0, p1) = (p1, ((2.0 * jf - 1.0) * x * p1 - (jf - 1.0) * p0) / jf);
            }
            dp = nf * (x * p1 - p0) / (x * x - 1.0);
            let dx = p1 / dp;
            x -= dx;
            if dx.abs() < 1e-15 {
                break;
            }
        }
        nodes[i] = 0.5 * h * (1.0 - x);
        weights[i] = h / ((1.0 - x * x) * dp * dp);
    }
    (nodes, weights)
}

fn nodes_for(h: f64) -> usize {
    ((NODES_PER_UNIT * h).ceil() as usize).clamp(MIN_NODES, MAX_NODES)
}

/// L(0) with `n` nodes.
fn arl_with(h: f64, k: f64, n: usize) -> f64 {
    let normal = Normal::standard();
    if h <= 0.0 {
        return 1.0 / normal.sf(k);
    }
    let (y, w) = gauss_legendre(n, h);
    let points: Vec<f64> = std::iter::once(0.0).chain(y.iter().copied()).collect();
    let m = n + 1;
    let mut a = DMatrix::<f64>::zeros(m, m);
    for (i, &x) in points.iter().enumerate() {
        a[(i, i)] += 1.0;
        a[(i, 0)] -= normal.cdf(k - x);
        for j in 0..n {
            a[(i, j + 1)] -= w[j] * normal.pdf(y[j] + k - x);
        }
    }
    let ones = DVector::<f64>::from_element(m, 1.0);
    a.lu().solve(&ones).map_or(f64::NAN, |l| l[0])
}

/// The mean run length (in samples) of the one-sided CUSUM with reference `k` and threshold
/// `h` on independent N(0, 1) increments, from a zero start.
pub fn cusum_arl(h: f64, k: f64) -> Result<f64> {
    check_drift(k)?;
    if !(h.is_finite() && (0.0..=MAX_THRESHOLD).contains(&h)) {
        return Err(FieldError::InvalidParameter(format!(
            "the CUSUM threshold must lie in [0, {MAX_THRESHOLD}], got {h}"
        )));
    }
    let arl = arl_with(h, k, nodes_for(h));
    if arl.is_finite() && arl > 0.0 && arl <= MAX_RUN_LENGTH {
        Ok(arl)
    } else {
        Err(FieldError::InvalidParameter(format!(
            "the run length of h = {h}, k = {k} exceeds {MAX_RUN_LENGTH:e} samples, beyond \
             the accurate range of the computation"
        )))
    }
}

fn check_drift(k: f64) -> Result<()> {
    if k.is_finite() && k > 0.0 && k <= 10.0 {
        Ok(())
    } else {
        Err(FieldError::InvalidParameter(format!(
            "the CUSUM drift must lie in (0, 10], got {k}"
        )))
    }
}

/// h such that the two-sided CUSUM with reference ±k alarms once per 1/(1 - confidence)
/// tested samples of independent N(0, 1) innovations on average.
pub fn cusum_threshold(confidence: f64, k: f64) -> Result<f64> {
    check_drift(k)?;
    if !(confidence > 0.0 && confidence < 1.0) {
        return Err(FieldError::InvalidParameter(format!(
            "confidence must lie strictly between 0 and 1, got {confidence}"
        )));
    }
    // one side's mean run length: twice the two-sided one
    let run_length = 2.0 / (1.0 - confidence);
    if run_length > MAX_RUN_LENGTH / 10.0 {
        return Err(FieldError::InvalidParameter(format!(
            "confidence {confidence} is too close to 1 for the CUSUM: its mean run length \
             between false alarms is computed up to {:e} samples (confidence ≤ 1 - 2e-8)",
            MAX_RUN_LENGTH / 20.0
        )));
    }
    let target = run_length.ln();
    let mut hi = 1.0;
    while arl_with(hi, k, nodes_for(hi)).ln() < target {
        hi *= 2.0;
        if hi > MAX_THRESHOLD {
            return Err(FieldError::InvalidParameter(format!(
                "confidence {confidence} needs a CUSUM threshold beyond {MAX_THRESHOLD} \
                 with drift {k}: lower the confidence or raise the drift"
            )));
        }
    }
    let n = nodes_for(hi);
    let f = |h: f64| arl_with(h, k, n).ln() - target;
    let (mut lo, mut f_lo, mut f_hi) = (0.0, f(0.0), f(hi));
    if f_lo >= 0.0 {
        return Err(FieldError::InvalidParameter(format!(
            "confidence {confidence} is too low for drift {k}: even h = 0 alarms less often"
        )));
    }
    // Illinois regula falsi: ln ARL is nearly linear in h
    let mut side = 0;
    for _ in 0..200 {
        let h = (lo * f_hi - hi * f_lo) / (f_hi - f_lo);
        let fh = f(h);
        if !fh.is_finite() {
            return Err(FieldError::NonFinite(format!(
                "the CUSUM run length of h = {h}, k = {k} could not be computed"
            )));
        }
        if fh.abs() < 1e-13 || hi - lo < 1e-13 {
            return Ok(h);
        }
        if fh < 0.0 {
            (lo, f_lo) = (h, fh);
            if side == -1 {
                f_hi *= 0.5;
            }
            side = -1;
        } else {
            (hi, f_hi) = (h, fh);
            if side == 1 {
                f_lo *= 0.5;
            }
            side = 1;
        }
    }
    Ok(0.5 * (lo + hi))
}
