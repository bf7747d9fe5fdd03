//! The hot kernel: the means and log-likelihoods of L trajectories that share a schedule,
//! advanced together frame by frame, lane by lane (the arithmetic of each lane is the same
//! whatever L, so a trajectory gives the same bits alone or in a group). Compiled for AVX2
//! where the CPU has it (no fused multiply-add: the bits do not depend on the CPU).

use super::decision::DecisionRule;
use super::schedule::Schedule;
use crate::kalman::LinearGaussian;

/// The constant part of a model for the kernel: the non-zero entries of F and H.
#[derive(Clone, Debug)]
pub(crate) struct Dynamics {
    pub n: usize,
    pub m: usize,
    f: Vec<(usize, usize, f64)>,
    h: Vec<(usize, usize, f64)>,
}

fn nonzero(a: &nalgebra::DMatrix<f64>) -> Vec<(usize, usize, f64)> {
    (0..a.nrows())
        .flat_map(|i| (0..a.ncols()).map(move |j| (i, j)))
        .filter(|&(i, j)| a[(i, j)] != 0.0)
        .map(|(i, j)| (i, j, a[(i, j)]))
        .collect()
}

impl Dynamics {
    pub(crate) fn new(model: &LinearGaussian) -> Self {
        Self {
            n: model.state_dim(),
            m: model.measurement_dim(),
            f: nonzero(&model.f),
            h: nonzero(&model.h),
        }
    }
}

/// The per-trajectory state of a bank run.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Trajectory {
    /// The models' posterior means, model after model (Σ n_i values).
    pub means: Vec<f64>,
    /// Accumulated log-likelihood per model.
    pub log_lik: Vec<f64>,
    /// The current decision.
    pub decision: i64,
    /// Own covariances per model once a frame was missed (None: the shared ones).
    pub own_cov: Option<Vec<nalgebra::DMatrix<f64>>>,
}

/// One trajectory's view in a run: its state, its measurements (frames × m), its per-frame
/// decisions (frames) and optionally its per-frame log-likelihoods (frames × K).
pub(crate) struct Lane<'a> {
    pub state: &'a mut Trajectory,
    pub z: &'a [f64],
    pub decisions: &'a mut [i64],
    pub log_lik: Option<&'a mut [f64]>,
}

/// Advances `lanes` (L of them, one schedule per model shared by all) over the schedules'
/// frames.
pub(crate) fn advance<const L: usize>(
    dynamics: &[Dynamics],
    schedules: &[&Schedule],
    rule: &DecisionRule,
    lanes: &mut [Lane<'_>],
) {
    assert_eq!(lanes.len(), L);
    #[cfg(target_arch = "x86_64")]
    if crate::banded::fused_available() {
        // SAFETY: the CPU has AVX2.
        return unsafe { advance_avx2::<L>(dynamics, schedules, rule, lanes) };
    }
    advance_lanes::<L>(dynamics, schedules, rule, lanes)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn advance_avx2<const L: usize>(
    dynamics: &[Dynamics],
    schedules: &[&Schedule],
    rule: &DecisionRule,
    lanes: &mut [Lane<'_>],
) {
    advance_lanes::<L>(dynamics, schedules, rule, lanes)
}

#[inline(always)]
fn advance_lanes<const L: usize>(
    dynamics: &[Dynamics],
    schedules: &[&Schedule],
    rule: &DecisionRule,
    lanes: &mut [Lane<'_>],
) {
    let k_models = dynamics.len();
    let total: usize = dynamics.iter().map(|d| d.n).sum();
    let max_n = dynamics.iter().map(|d| d.n).max().unwrap_or(0);
    let m = dynamics[0].m;
    let frames = schedules[0].observed.len();
    let mut x = vec![[0.0f64; L]; total];
    let mut ll = vec![[0.0f64; L]; k_models];
    let mut decision = [0i64; L];
    for (l, lane) in lanes.iter().enumerate() {
        for (i, v) in lane.state.means.iter().enumerate() {
            x[i][l] = *v;
        }
        for (i, v) in lane.state.log_lik.iter().enumerate() {
            ll[i][l] = *v;
        }
        decision[l] = lane.state.decision;
    }
    let mut xp = vec![[0.0f64; L]; max_n];
    let mut nu = vec![[0.0f64; L]; m];
    for t in 0..frames {
        let mut offset = 0;
        for (k, (d, s)) in dynamics.iter().zip(schedules).enumerate() {
            let xs = &mut x[offset..offset + d.n];
            offset += d.n;
            xp[..d.n].iter_mut().for_each(|v| *v = [0.0; L]);
            for &(i, j, f) in &d.f {
                for l in 0..L {
                    xp[i][l] += f * xs[j][l];
                }
            }
            xs.copy_from_slice(&xp[..d.n]);
            if !s.observed[t] {
                continue;
            }
            for (a, row) in nu.iter_mut().enumerate() {
                for (l, lane) in lanes.iter().enumerate() {
                    row[l] = lane.z[t * m + a];
                }
            }
            for &(a, j, h) in &d.h {
                for l in 0..L {
                    nu[a][l] -= h * xp[j][l];
                }
            }
            let gains = &s.gain[t * s.gain_pattern.len()..];
            for (&(i, a), &g) in s.gain_pattern.iter().zip(gains) {
                for l in 0..L {
                    xs[i][l] += g * nu[a][l];
                }
            }
            let precisions = &s.precision[t * s.precision_pattern.len()..];
            let mut quad = [0.0f64; L];
            for (&(a, b), &p) in s.precision_pattern.iter().zip(precisions) {
                for l in 0..L {
                    quad[l] += p * (nu[a][l] * nu[b][l]);
                }
            }
            let c = s.offset[t];
            for l in 0..L {
                ll[k][l] += -0.5 * (quad[l] + c);
            }
        }
        for (l, lane) in lanes.iter_mut().enumerate() {
            decision[l] = rule.decide(decision[l], |i| ll[i][l]);
            lane.decisions[t] = decision[l];
            if let Some(out) = lane.log_lik.as_deref_mut() {
                for (i, row) in ll.iter().enumerate() {
                    out[t * k_models + i] = row[l];
                }
            }
        }
    }
    for (l, lane) in lanes.iter_mut().enumerate() {
        for (i, v) in lane.state.means.iter_mut().enumerate() {
            *v = x[i][l];
        }
        for (i, v) in lane.state.log_lik.iter_mut().enumerate() {
            *v = ll[i][l];
        }
        lane.state.decision = decision[l];
    }
}
