//! The per-column steps of the scalar row filter's passes (`scalar_row_filter`, SPEC §2.3
//! generalised) over its interleaved state: column ℓ's n components at ℓn..ℓn + n. Each step
//! maps every column by a small matrix (the transition S, or Sᵀ), adds to it, and reads the
//! image row out by h.
//!
//! They run over blocks of K doubles (K/n whole columns; K = 8 for n = 1, 2, 4, two AVX2
//! vectors, and 12 for n = 3), written so that the compiler vectorises each block across its
//! columns, then column by column over the tail of the row. Every output is summed in the
//! same order either way, so the bits do not depend on the block length.

use crate::vector_row_filter::Small;
use std::array::from_fn;

/// The longest block (n = 3).
const MAX_BLOCK: usize = 12;

/// Runs `$body` (a call generic over `<N, K>` with `$at` in scope) over the blocks of K
/// doubles of a `$len`-long state, then over the tail one column (K = N) at a time.
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
    fn new(m: &Small) -> Self {
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

#[inline(always)]
fn block<const K: usize>(v: &[f64], at: usize) -> &[f64; K] {
    v[at..at + K].try_into().unwrap()
}

#[inline(always)]
fn block_mut<const K: usize>(v: &mut [f64], at: usize) -> &mut [f64; K] {
    (&mut v[at..at + K]).try_into().unwrap()
}

/// out[c] = h · x_c for the K/n columns of a block starting at column `column`.
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

/// Prediction and innovation: state_ℓ ← S state_ℓ, gain_in_ℓ = ((z_ℓ − state_ℓ[0]) r_ℓ, 0, …)
/// (the innovation enters through state row 0 only). False when a pixel of the row is NaN
/// or infinite (with nominal precisions only, see `PixelPrecision::checks`).
#[inline(always)]
pub(crate) fn predict<const N: usize, const K: usize, P: PixelPrecision>(
    s: &Small,
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
    let column = at / N;
    *block_mut::<K>(gain_in, at) = from_fn(|k| {
        if k % N == 0 {
            let (z, r) = precision.pixel(row, column + k / N);
            (z - new[k]) * r
        } else {
            0.0
        }
    });
    if precision.checks() {
        for z in &row[column..column + K / N] {
            *finite &= z.is_finite();
        }
    }
}

/// The filter's correction (`base` None: target_ℓ += d_ℓ) or the RTS step (target_ℓ = base_ℓ
/// + d_ℓ), and out[ℓ] = h · target_ℓ, in one pass.
#[inline(always)]
pub(crate) fn correct<const N: usize, const K: usize>(
    base: Option<&[f64]>,
    d: &[f64],
    target: &mut [f64],
    h: &[f64; 4],
    out: &mut [f64],
) {
    match base {
        None => over_blocks!(target.len(), N, K, |at| update_block(at, d, target, h, out)),
        Some(base) => over_blocks!(target.len(), N, K, |at| correct_block(
            at, base, d, target, h, out
        )),
    }
}

#[inline(always)]
fn update_block<const N: usize, const K: usize>(
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

#[inline(always)]
fn correct_block<const N: usize, const K: usize>(
    at: usize,
    base: &[f64],
    d: &[f64],
    target: &mut [f64],
    h: &[f64; 4],
    out: &mut [f64],
) {
    let (bk, dk) = (block::<K>(base, at), block::<K>(d, at));
    let x = block_mut::<K>(target, at);
    *x = from_fn(|k| bk[k] + dk[k]);
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

/// The RTS pass's right-hand side (see `ScalarRowFilter::smoothing_rhs`):
/// carried_ℓ = d_ℓ = Sᵀ (carried_ℓ + e₀ r_ℓ (z_ℓ − smoothed_ℓ[0])).
#[inline(always)]
pub(crate) fn smoothing_rhs<const N: usize, const K: usize, P: PixelPrecision>(
    s: &Small,
    row: &[f64],
    precision: P,
    smoothed: &[f64],
    carried: &mut [f64],
    d: &mut [f64],
) {
    let st = ColumnMatrix::<N>::new(&s.transpose());
    over_blocks!(carried.len(), N, K, |at| rhs_block(
        &st, at, row, precision, smoothed, carried, d
    ));
}

#[inline(always)]
fn rhs_block<const N: usize, const K: usize>(
    st: &ColumnMatrix<N>,
    at: usize,
    row: &[f64],
    precision: impl PixelPrecision,
    smoothed: &[f64],
    carried: &mut [f64],
    d: &mut [f64],
) {
    let (column, sm) = (at / N, block::<K>(smoothed, at));
    let c = block_mut::<K>(carried, at);
    let u: [f64; K] = from_fn(|k| {
        if k % N == 0 {
            let (z, r) = precision.pixel(row, column + k / N);
            c[k] + r * (z - sm[k])
        } else {
            c[k]
        }
    });
    *c = st.apply(&u);
    *block_mut::<K>(d, at) = *c;
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Per-column reference of the steps, one column at a time with plain loops.
    fn column_apply(m: &Small, v: &[f64]) -> Vec<f64> {
        let n = v.len();
        (0..n)
            .map(|a| (0..n).map(|b| m[(a, b)] * v[b]).sum())
            .collect()
    }

    fn small(n: usize) -> Small {
        let mut m = Small::zeros();
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
        // correction, RTS step and readout
        let d: Vec<f64> = (0..len).map(|i| (i as f64 * 0.37).cos()).collect();
        let (mut target, mut out) = (x0.clone(), vec![0.0; width]);
        correct::<N, K>(None, &d, &mut target, &h, &mut out);
        let mut fresh = vec![0.0; len];
        let mut again = vec![0.0; width];
        correct::<N, K>(Some(&x0), &d, &mut fresh, &h, &mut again);
        let mut read = vec![0.0; width];
        readout::<N, K>(&target, &h, &mut read);
        for l in 0..width {
            let v: Vec<f64> = (0..N).map(|a| x0[l * N + a] + d[l * N + a]).collect();
            let want: f64 = (0..N).map(|a| h[a] * v[a]).sum();
            assert_eq!(&target[l * N..(l + 1) * N], &v[..]);
            assert_eq!(&fresh[l * N..(l + 1) * N], &v[..]);
            assert_eq!((out[l], again[l], read[l]), (want, want, want));
        }
        // the RTS right-hand side
        let (mut carried, mut rhs) = (d.clone(), vec![0.0; len]);
        smoothing_rhs::<N, K, _>(&m, &row, Nominal(2.0), &x0, &mut carried, &mut rhs);
        for l in 0..width {
            let mut u = d[l * N..(l + 1) * N].to_vec();
            u[0] += 2.0 * (row[l] - x0[l * N]);
            let want = column_apply(&m.transpose(), &u);
            assert_eq!(&rhs[l * N..(l + 1) * N], &want[..], "N {N} column {l}");
        }
        assert_eq!(carried, rhs);
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
