//! Sums of lagged products along an axis: the sample autocovariance of every line, pooled
//! (SPEC §1.6 diagnostics, residual whiteness).

use crate::error::Result;
use crate::field::{AxisLines, LaneBlock};

/// S_h = Σ x_i x_{i+h} and the number of pairs N_h, h = 0..=max_lag, over all lines.
#[derive(Debug, Clone, PartialEq)]
pub struct LagProducts {
    pub sums: Vec<f64>,
    pub counts: Vec<u64>,
}

impl LagProducts {
    fn zero(max_lag: usize) -> Self {
        Self {
            sums: vec![0.0; max_lag + 1],
            counts: vec![0; max_lag + 1],
        }
    }

    fn add(&mut self, other: &Self) {
        self.sums
            .iter_mut()
            .zip(&other.sums)
            .for_each(|(a, b)| *a += b);
        self.counts
            .iter_mut()
            .zip(&other.counts)
            .for_each(|(a, b)| *a += b);
    }

    /// Unbiased autocovariance estimate S_h / N_h (NaN where no pair exists).
    pub fn autocovariance(&self) -> Vec<f64> {
        self.sums
            .iter()
            .zip(&self.counts)
            .map(|(s, &n)| if n == 0 { f64::NAN } else { s / n as f64 })
            .collect()
    }
}

/// Lagged products of `data` (C order, `shape`) along `axis`. Pairs with a non-finite member
/// are missing data and are skipped. Lags beyond the line length get zero pairs.
pub fn lag_products(
    data: &[f64],
    shape: &[usize],
    axis: usize,
    max_lag: usize,
) -> Result<LagProducts> {
    let lines = AxisLines::new(shape, axis, data.len())?;
    Ok(lines.sum_blocks(
        LagProducts::zero(max_lag),
        |block| block_products(data, block, lines.len(), max_lag),
        LagProducts::add,
    ))
}

fn block_products(data: &[f64], block: &LaneBlock, len: usize, max_lag: usize) -> LagProducts {
    let mut out = LagProducts::zero(max_lag);
    if block.elem_step == 1 {
        // contiguous lines: one line at a time
        for j in 0..block.lanes {
            let line = &data[block.at(0, j)..block.at(0, j) + len];
            for h in 0..=max_lag.min(len - 1) {
                add_products(&mut out, h, &line[..len - h], &line[h..]);
            }
        }
    } else {
        // interleaved lines (lane_step == 1): row i against row i + h, lanes side by side
        let row = |i: usize| &data[block.at(i, 0)..block.at(i, 0) + block.lanes];
        for i in 0..len {
            for h in 0..=max_lag.min(len - 1 - i) {
                add_products(&mut out, h, row(i), row(i + h));
            }
        }
    }
    out
}

/// S_h += Σ a_i b_i over the finite products, N_h += their number.
#[inline(always)]
fn add_products(out: &mut LagProducts, h: usize, a: &[f64], b: &[f64]) {
    // Eight independent partial sums: the adds overlap instead of waiting on each other.
    const LANES: usize = 8;
    let (mut sum, mut count) = ([0.0f64; LANES], [0u64; LANES]);
    let (a_chunks, b_chunks) = (a.chunks_exact(LANES), b.chunks_exact(LANES));
    let (a_rest, b_rest) = (a_chunks.remainder(), b_chunks.remainder());
    for (x, y) in a_chunks.zip(b_chunks) {
        for k in 0..LANES {
            let p = x[k] * y[k];
            let ok = p.is_finite();
            sum[k] += if ok { p } else { 0.0 };
            count[k] += ok as u64;
        }
    }
    for (x, y) in a_rest.iter().zip(b_rest) {
        let p = x * y;
        if p.is_finite() {
            sum[0] += p;
            count[0] += 1;
        }
    }
    out.sums[h] += sum.iter().sum::<f64>();
    out.counts[h] += count.iter().sum::<u64>();
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn matches_direct_sums_along_both_axes() {
        let (rows, cols) = (7usize, 300usize);
        let data: Vec<f64> = (0..rows * cols).map(|i| ((i % 13) as f64).cos()).collect();
        let got = lag_products(&data, &[rows, cols], 0, 3).unwrap();
        for h in 0..=3 {
            let mut s = 0.0;
            for r in 0..rows - h {
                for c in 0..cols {
                    s += data[r * cols + c] * data[(r + h) * cols + c];
                }
            }
            assert!((got.sums[h] - s).abs() < 1e-9 * s.abs().max(1.0));
            assert_eq!(got.counts[h], ((rows - h) * cols) as u64);
        }
        let along = lag_products(&data, &[rows, cols], 1, 2).unwrap();
        assert_eq!(along.counts[2], (rows * (cols - 2)) as u64);
    }

    #[test]
    fn missing_values_and_long_lags() {
        let data = [1.0, f64::NAN, 2.0, 3.0];
        let got = lag_products(&data, &[4], 0, 5).unwrap();
        assert_eq!(got.counts, vec![3, 1, 1, 1, 0, 0]);
        assert_eq!(got.sums[..4], [14.0, 6.0, 2.0, 3.0]);
        assert!(got.autocovariance()[5].is_nan());
    }
}
