//! The hot kernel: the means and log-likelihoods of L trajectories that share a schedule,
//! advanced together frame by frame, lane by lane (the arithmetic of each lane is the same
//! whatever L, so a trajectory gives the same bits alone or in a group). Compiled for AVX2
//! and FMA where the CPU has them; every multiply-add is fused (`mul_add`, one rounding), so
//! the bits do not depend on the CPU either.

use super::decision::DecisionRule;
use super::schedule::Schedule;
use crate::kalman::LinearGaussian;

/// A sparse matrix by rows: row i holds `entries[rows[i]..rows[i + 1]]`, (column, value).
#[derive(Clone, Debug)]
pub(crate) struct SparseRows {
    rows: Vec<usize>,
    entries: Vec<(usize, f64)>,
}

impl SparseRows {
    fn new(a: &nalgebra::DMatrix<f64>) -> Self {
        let mut rows = vec![0];
        let mut entries = Vec::new();
        for i in 0..a.nrows() {
            entries.extend(
                (0..a.ncols())
                    .filter(|&j| a[(i, j)] != 0.0)
                    .map(|j| (j, a[(i, j)])),
            );
            rows.push(entries.len());
        }
        Self { rows, entries }
    }

    #[inline(always)]
    fn row(&self, i: usize) -> &[(usize, f64)] {
        &self.entries[self.rows[i]..self.rows[i + 1]]
    }
}

/// The constant part of a model for the kernel: F and H by their non-zero entries.
#[derive(Clone, Debug)]
pub(crate) struct Dynamics {
    pub n: usize,
    pub m: usize,
    f: SparseRows,
    h: SparseRows,
}

impl Dynamics {
    pub(crate) fn new(model: &LinearGaussian) -> Self {
        Self {
            n: model.state_dim(),
            m: model.measurement_dim(),
            f: SparseRows::new(&model.f),
            h: SparseRows::new(&model.h),
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

/// Trajectories advanced together by the lane kernel.
pub(crate) const LANES: usize = 16;

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
    if crate::simd::fused_available() {
        // SAFETY: the CPU has FMA and AVX2.
        return unsafe { advance_avx2::<L>(dynamics, schedules, rule, lanes) };
    }
    advance_lanes::<L>(dynamics, schedules, rule, lanes)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "fma,avx2")]
unsafe fn advance_avx2<const L: usize>(
    dynamics: &[Dynamics],
    schedules: &[&Schedule],
    rule: &DecisionRule,
    lanes: &mut [Lane<'_>],
) {
    advance_lanes::<L>(dynamics, schedules, rule, lanes)
}

/// `acc + f x`, lane by lane, fused (one rounding: the same bits with or without FMA
/// instructions).
#[inline(always)]
fn add_scaled<const L: usize>(mut acc: [f64; L], f: f64, x: &[f64; L]) -> [f64; L] {
    // plain loops, not `array::from_fn`: its closure was left out of line, without the
    // FMA instructions of the caller (a library call per lane)
    for l in 0..L {
        acc[l] = f.mul_add(x[l], acc[l]);
    }
    acc
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
    // the measurements lane by lane: z[t m + a][l]
    let mut z = vec![[0.0f64; L]; frames * m];
    for (l, lane) in lanes.iter().enumerate() {
        for (i, v) in lane.state.means.iter().enumerate() {
            x[i][l] = *v;
        }
        for (i, v) in lane.state.log_lik.iter().enumerate() {
            ll[i][l] = *v;
        }
        decision[l] = lane.state.decision;
        for (row, v) in z.iter_mut().zip(lane.z) {
            row[l] = *v;
        }
    }
    let mut xp = vec![[0.0f64; L]; max_n];
    let mut nu = vec![[0.0f64; L]; m];
    for t in 0..frames {
        let mut offset = 0;
        for (k, (d, s)) in dynamics.iter().zip(schedules).enumerate() {
            let xs = &mut x[offset..offset + d.n];
            offset += d.n;
            for (i, p) in xp[..d.n].iter_mut().enumerate() {
                *p =
                    d.f.row(i)
                        .iter()
                        .fold([0.0; L], |acc, &(j, f)| add_scaled(acc, f, &xs[j]));
            }
            if !s.observed[t] {
                xs.copy_from_slice(&xp[..d.n]);
                continue;
            }
            for (a, v) in nu.iter_mut().enumerate() {
                *v =
                    d.h.row(a)
                        .iter()
                        .fold(z[t * m + a], |acc, &(j, h)| add_scaled(acc, -h, &xp[j]));
            }
            let gains = &s.gain[t * s.gain_pattern.len()..];
            let mut p = 0;
            for (i, xi) in xs.iter_mut().enumerate() {
                let mut acc = xp[i];
                while p < s.gain_pattern.len() && s.gain_pattern[p].0 == i {
                    acc = add_scaled(acc, gains[p], &nu[s.gain_pattern[p].1]);
                    p += 1;
                }
                *xi = acc;
            }
            let precisions = &s.precision[t * s.precision_pattern.len()..];
            let mut quad = [0.0f64; L];
            for (&(a, b), &w) in s.precision_pattern.iter().zip(precisions) {
                for l in 0..L {
                    quad[l] = (w * nu[a][l]).mul_add(nu[b][l], quad[l]);
                }
            }
            let c = s.offset[t];
            for l in 0..L {
                ll[k][l] = (-0.5f64).mul_add(quad[l] + c, ll[k][l]);
            }
        }
        rule.decide_lanes(&mut decision, &ll);
        for (l, lane) in lanes.iter_mut().enumerate() {
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
