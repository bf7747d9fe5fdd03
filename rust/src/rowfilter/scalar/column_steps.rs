//! The per-column steps of the scalar row filter's passes (`rowfilter::scalar`, SPEC §2.3
//! generalised) over its interleaved state: column ℓ's n components at ℓn..ℓn + n. Each step
//! maps every column by a small matrix (the transition S, or Sᵀ), adds to it, and reads the
//! image row out by h.
//!
//! They run over blocks of K doubles (K/n whole columns; K = 8 for n = 1, 2, 4, two AVX2
//! vectors, and 12 for n = 3), written so that the compiler vectorises each block across its
//! columns, then column by column over the tail of the row. Every output is summed in the
//! same order either way, so the bits do not depend on the block length.

use crate::rowfilter::{pixel_in_range, StateMatrix};
use crate::simd::{block, block_mut};
use std::array::from_fn;
use std::ops::Range;

/// The longest block (n = 3).
const MAX_BLOCK: usize = 12;

/// Calls `$block::<N, K>(args)` (the args may use `$at`, the block's first entry) on each
/// block of K doubles of a `$len`-long state, then `$block::<N, N>` on each column of the
/// tail.
macro_rules! over_blocks {
    ($len:expr, $n:ident, $k:ident, |$at:ident| $block:ident($($arg:expr),*)) => {{
        let len = $len;
        let end = len / $k * $k;
        for $at in (0..end).step_by($k) {
            $block::<$n, $k>($($arg),*);
        }
        for $at in (end..len).step_by($n) {
            $block::<$n, $n>($($arg),*);
        }
    }};
}

/// Runs `$body` with `$n` the state order n (`$order`, 1..=4) and `$k` its block length, as
/// constants.
macro_rules! for_order {
    ($order:expr, |$n:ident, $k:ident| $body:expr) => {
        match $order {
            1 => {
                const $n: usize = 1;
                const $k: usize = 8;
                $body
            }
            2 => {
                const $n: usize = 2;
                const $k: usize = 8;
                $body
            }
            3 => {
                const $n: usize = 3;
                const $k: usize = 12;
                $body
            }
            _ => {
                const $n: usize = 4;
                const $k: usize = 8;
                $body
            }
        }
    };
}
pub(crate) use for_order;

/// The observation precision of each pixel: 1/σ_θ² everywhere, or per pixel (0 = missing).
pub(crate) trait PixelPrecision: Copy {
    /// (z_ℓ, r_ℓ); a missing pixel's value may be NaN: it gives (0, 0), a term 0, not NaN · 0.
    fn pixel(self, row: &[f64], column: usize) -> (f64, f64);
    /// The precisions of `columns` (indexed from 0 on), for a block.
    fn columns(self, columns: Range<usize>) -> Self;
    /// Whether the prediction checks the pixels for NaN and infinity (nominal precisions:
    /// weighted rows are checked when their systems are made).
    fn checks(self) -> bool;
}

/// 1/σ_θ² for every pixel.
#[derive(Clone, Copy)]
pub(crate) struct Nominal(pub f64);

/// Per-pixel 1/σ²_θ,ℓ of the row (0: missing pixel).
#[derive(Clone, Copy)]
pub(crate) struct PerPixel<'a>(pub &'a [f64]);

impl PixelPrecision for Nominal {
    #[inline(always)]
    fn pixel(self, row: &[f64], column: usize) -> (f64, f64) {
        (row[column], self.0)
    }

    fn columns(self, _columns: Range<usize>) -> Self {
        self
    }

    fn checks(self) -> bool {
        true
    }
}

impl PixelPrecision for PerPixel<'_> {
    #[inline(always)]
    fn pixel(self, row: &[f64], column: usize) -> (f64, f64) {
        let r = self.0[column];
        (if r > 0.0 { row[column] } else { 0.0 }, r)
    }

    fn columns(self, columns: Range<usize>) -> Self {
        Self(&self.0[columns])
    }

    fn checks(self) -> bool {
        false
    }
}

/// A small matrix m acting on every column: coef[b][k] = m[k mod n][b], so that entry k of a
/// block maps to Σ_b coef[b][k] x[k − k mod n + b].
struct ColumnMatrix<const N: usize> {
    coef: [[f64; MAX_BLOCK]; N],
}

impl<const N: usize> ColumnMatrix<N> {
    fn new(m: &StateMatrix) -> Self {
        Self {
            coef: from_fn(|b| from_fn(|k| m[(k % N, b)])),
        }
    }

    #[inline(always)]
    fn apply<const K: usize>(&self, x: &[f64; K]) -> [f64; K] {
        from_fn(|k| {
            let first = k - k % N;
            let mut sum = self.coef[0][k] * x[first];
            for b in 1..N {
                sum += self.coef[b][k] * x[first + b];
            }
            sum
        })
    }
}

/// out[c] = h · x_c for the K/n columns c of a block (`out` starts at its first column).
#[inline(always)]
fn read_block<const N: usize, const K: usize>(x: &[f64; K], h: &[f64; 4], out: &mut [f64]) {
    for (c, o) in out[..K / N].iter_mut().enumerate() {
        let mut sum = h[0] * x[c * N];
        for a in 1..N {
            sum += h[a] * x[c * N + a];
        }
        *o = sum;
    }
}

/// Asks the caches for `row` (a hint: no effect on results). The passes read each image
/// row once, straight from memory, in a burst between two row solves, when the hardware
/// prefetcher has stopped; fetched during the previous row's solve, the prediction pass
/// waits less ((1,1) causal 7–12 % faster at 2048²).
#[inline(always)]
pub(crate) fn prefetch(row: &[f64]) {
    #[cfg(target_arch = "x86_64")]
    for line in row.chunks(8) {
        // SAFETY: a prefetch only reads an address of `row`; it cannot fault.
        unsafe {
            std::arch::x86_64::_mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T1 }>(
                line.as_ptr().cast(),
            )
        };
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = row;
}

/// Prediction and innovation: state_ℓ ← S state_ℓ, gain_in_ℓ = ((z_ℓ − state_ℓ[0]) r_ℓ, 0, …)
/// (the innovation enters through state row 0 only). False when a pixel of the row is NaN,
/// infinite or beyond ±2^1000 (`pixel_in_range`; with nominal precisions only, see
/// `PixelPrecision::checks`).
#[inline(always)]
pub(crate) fn predict<const N: usize, const K: usize, P: PixelPrecision>(
    s: &StateMatrix,
    state: &mut [f64],
    row: &[f64],
    gain_in: &mut [f64],
    precision: P,
) -> bool {
    let m = ColumnMatrix::<N>::new(s);
    let mut finite = true;
    over_blocks!(state.len(), N, K, |at| predict_block(
        &m,
        at,
        state,
        row,
        gain_in,
        precision,
        &mut finite
    ));
    finite
}

#[inline(always)]
fn predict_block<const N: usize, const K: usize>(
    m: &ColumnMatrix<N>,
    at: usize,
    state: &mut [f64],
    row: &[f64],
    gain_in: &mut [f64],
    precision: impl PixelPrecision,
    finite: &mut bool,
) {
    let x = block_mut::<K>(state, at);
    let new = m.apply(x);
    *x = new;
    let columns = at / N..at / N + K / N;
    let (row, precision) = (&row[columns.clone()], precision.columns(columns));
    *block_mut::<K>(gain_in, at) = from_fn(|k| {
        if k % N == 0 {
            let (z, r) = precision.pixel(row, k / N);
            (z - new[k]) * r
        } else {
            0.0
        }
    });
    if precision.checks() {
        for z in row {
            *finite &= pixel_in_range(*z);
        }
    }
}

/// The filter's correction: target_ℓ += d_ℓ and out[ℓ] = h · target_ℓ, in one pass.
#[inline(always)]
pub(crate) fn correct<const N: usize, const K: usize>(
    d: &[f64],
    target: &mut [f64],
    h: &[f64; 4],
    out: &mut [f64],
) {
    over_blocks!(target.len(), N, K, |at| correct_block(
        at, d, target, h, out
    ));
}

#[inline(always)]
fn correct_block<const N: usize, const K: usize>(
    at: usize,
    d: &[f64],
    target: &mut [f64],
    h: &[f64; 4],
    out: &mut [f64],
) {
    let dk = block::<K>(d, at);
    let x = block_mut::<K>(target, at);
    *x = from_fn(|k| x[k] + dk[k]);
    read_block::<N, K>(x, h, &mut out[at / N..]);
}

/// out[ℓ] = h · state_ℓ.
#[inline(always)]
pub(crate) fn readout<const N: usize, const K: usize>(
    state: &[f64],
    h: &[f64; 4],
    out: &mut [f64],
) {
    over_blocks!(state.len(), N, K, |at| readout_block(at, state, h, out));
}

#[inline(always)]
fn readout_block<const N: usize, const K: usize>(
    at: usize,
    state: &[f64],
    h: &[f64; 4],
    out: &mut [f64],
) {
    read_block::<N, K>(block::<K>(state, at), h, &mut out[at / N..]);
}

/// One row of the RTS pass: δ_t on entry (overwritten by d_{t−1}), the carried d_t, the
/// image row z_t, and `out`, the filtered estimate h · ŷ_t on entry, the smoothed one on exit.
pub(crate) struct RtsRow<'a> {
    pub delta: &'a mut [f64],
    pub carried: &'a mut [f64],
    pub row: &'a [f64],
    pub out: &'a mut [f64],
}

/// out = h · ŷˢ_t = h · ŷ_t + h₀ δ_t[0] (h = h₀ e₀ after the start: row 0 of the lower
/// triangular L), and the next right-hand side
/// d_{t−1} = (I ⊗ Sᵀ) Λ_t (ŷˢ_t − ŷ_e,t) = (I ⊗ Sᵀ) (d_t + e₀ r_t (z_t − h · ŷˢ_t)) into `carried`
/// and `delta` (see `ScalarRowFilter::smooth_row`). Only h · ŷ_t of the filtered state is
/// read, so the forward pass keeps no store of its states.
#[inline(always)]
pub(crate) fn smooth<const N: usize, const K: usize>(
    s: &StateMatrix,
    h0: f64,
    precision: impl PixelPrecision,
    row: RtsRow,
) {
    let st = ColumnMatrix::<N>::new(&s.transpose());
    let RtsRow {
        delta,
        carried,
        row,
        out,
    } = row;
    over_blocks!(carried.len(), N, K, |at| smooth_block(
        &st,
        at,
        h0,
        precision,
        RtsRow {
            delta: &mut *delta,
            carried: &mut *carried,
            row,
            out: &mut *out,
        }
    ));
}

#[inline(always)]
fn smooth_block<const N: usize, const K: usize>(
    st: &ColumnMatrix<N>,
    at: usize,
    h0: f64,
    precision: impl PixelPrecision,
    row: RtsRow,
) {
    let columns = at / N..at / N + K / N;
    let (z, precision) = (
        &row.row[columns.clone()],
        precision.columns(columns.clone()),
    );
    let delta = block_mut::<K>(row.delta, at);
    let out = &mut row.out[columns];
    // the smoothed estimate of each column and its residual r (z − h₀ ŷˢ[0])
    let mut residual = [0.0; K];
    for (c, estimate) in out.iter_mut().enumerate() {
        *estimate += h0 * delta[c * N];
        let (zc, r) = precision.pixel(z, c);
        residual[c] = r * (zc - *estimate);
    }
    let c = block_mut::<K>(row.carried, at);
    let next = st.apply(&from_fn(|k| {
        if k % N == 0 {
            c[k] + residual[k / N]
        } else {
            c[k]
        }
    }));
    *c = next;
    *delta = next;
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Per-column reference of the steps, one column at a time with plain loops.
    fn column_apply(m: &StateMatrix, v: &[f64]) -> Vec<f64> {
        let n = v.len();
        (0..n)
            .map(|a| (0..n).map(|b| m[(a, b)] * v[b]).sum())
            .collect()
    }

    fn small(n: usize) -> StateMatrix {
        let mut m = StateMatrix::zeros();
        for a in 0..n {
            for b in 0..n {
                m[(a, b)] = 0.3 + 0.17 * a as f64 - 0.11 * (b * b) as f64;
            }
        }
        m
    }

    fn check_all<const N: usize, const K: usize>(width: usize) {
        let m = small(N);
        let len = width * N;
        let x0: Vec<f64> = (0..len).map(|i| (i as f64 * 0.61).sin()).collect();
        let row: Vec<f64> = (0..width).map(|l| (l as f64 * 0.23).cos()).collect();
        let weights: Vec<f64> = (0..width).map(|l| (l % 3) as f64 * 0.7).collect();
        let h = [1.0, -0.4, 0.25, 0.1];
        // prediction
        let (mut state, mut gain_in) = (x0.clone(), vec![1.0; len]);
        assert!(predict::<N, K, _>(
            &m,
            &mut state,
            &row,
            &mut gain_in,
            PerPixel(&weights)
        ));
        for l in 0..width {
            let want = column_apply(&m, &x0[l * N..(l + 1) * N]);
            assert_eq!(&state[l * N..(l + 1) * N], &want[..], "N {N} column {l}");
            let r = weights[l];
            let z = if r > 0.0 { row[l] } else { 0.0 };
            assert_eq!(gain_in[l * N], (z - want[0]) * r);
            assert!(gain_in[l * N + 1..(l + 1) * N].iter().all(|&g| g == 0.0));
        }
        let mut bad = row.clone();
        bad[width - 1] = f64::NAN;
        assert!(!predict::<N, K, _>(
            &m,
            &mut state,
            &bad,
            &mut gain_in,
            Nominal(2.0)
        ));
        // correction and readout
        let d: Vec<f64> = (0..len).map(|i| (i as f64 * 0.37).cos()).collect();
        let (mut target, mut out) = (x0.clone(), vec![0.0; width]);
        correct::<N, K>(&d, &mut target, &h, &mut out);
        let mut read = vec![0.0; width];
        readout::<N, K>(&target, &h, &mut read);
        for l in 0..width {
            let v: Vec<f64> = (0..N).map(|a| x0[l * N + a] + d[l * N + a]).collect();
            let want: f64 = (0..N).map(|a| h[a] * v[a]).sum();
            assert_eq!(&target[l * N..(l + 1) * N], &v[..]);
            assert_eq!((out[l], read[l]), (want, want));
        }
        // an RTS row: out ← out + h₀ δ[0], d ← Sᵀ (d + e₀ r (z − out)); a missing pixel's
        // value (NaN, weight 0) adds nothing
        let delta0: Vec<f64> = (0..len).map(|i| (i as f64 * 0.71).sin()).collect();
        let (mut delta, mut carried) = (delta0.clone(), d.clone());
        let mut image_row = out.clone();
        let with_gaps: Vec<f64> = (0..width)
            .map(|l| if weights[l] > 0.0 { row[l] } else { f64::NAN })
            .collect();
        let rts = RtsRow {
            delta: &mut delta,
            carried: &mut carried,
            row: &with_gaps,
            out: &mut image_row,
        };
        let h0 = 1.3;
        smooth::<N, K>(&m, h0, PerPixel(&weights), rts);
        for l in 0..width {
            let col = l * N..(l + 1) * N;
            let estimate = out[l] + h0 * delta0[l * N];
            assert_eq!(image_row[l], estimate);
            let z = if weights[l] > 0.0 { row[l] } else { 0.0 };
            let mut u = d[col.clone()].to_vec();
            u[0] += weights[l] * (z - estimate);
            let want = column_apply(&m.transpose(), &u);
            assert_eq!(&carried[col.clone()], &want[..], "N {N} column {l}");
        }
        assert_eq!(carried, delta);
    }

    #[test]
    fn block_steps_equal_the_column_steps() {
        // widths with and without a tail after the last whole block
        for width in [1, 2, 3, 5, 8, 13, 64] {
            check_all::<1, 8>(width);
            check_all::<2, 8>(width);
            check_all::<3, 12>(width);
            check_all::<4, 8>(width);
        }
    }
}
