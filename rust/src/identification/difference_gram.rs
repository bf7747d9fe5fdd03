//! Gram matrix of the successive differences along an axis: the sufficient statistic of the
//! multiple-root identification (SPEC §1.6).
//!
//! With δ = 1 - ρ and D = 1 - z⁻¹, the whitening operator of one axis is
//! (1 - ρ z⁻¹)ⁿ = (δ + ρ D)ⁿ = Σ_m C(n,m) ρ^m δ^{n-m} D^m, so the one-step prediction error
//! of every candidate (n, ρ) is a positive combination of D⁰x … Dⁿx at the same pixel and its
//! sum of squares is wᵀ G w with G_ab = Σ_i Dᵃx_i Dᵇx_i. Unlike a quadratic form in the
//! autocovariances of x, this one does not cancel catastrophically when ρ → 1.

use crate::error::{FieldError, Result};
use crate::field::{AxisLines, LaneBlock};

/// Highest difference order of the kernel (identification tries multiplicities up to it).
pub const MAX_DIFFERENCE_ORDER: usize = 8;

/// G_ab = Σ_i Dᵃx_i Dᵇx_i over the positions where Dᴹx_i is defined and finite.
#[derive(Debug, Clone, PartialEq)]
pub struct DifferenceGram {
    /// Highest difference order M.
    pub max_order: usize,
    /// (M+1)×(M+1), row-major.
    pub gram: Vec<f64>,
    /// Number of positions summed.
    pub count: u64,
}

impl DifferenceGram {
    fn zero(max_order: usize) -> Self {
        Self {
            max_order,
            gram: vec![0.0; (max_order + 1) * (max_order + 1)],
            count: 0,
        }
    }

    fn add(&mut self, other: &Self) {
        self.gram
            .iter_mut()
            .zip(&other.gram)
            .for_each(|(a, b)| *a += b);
        self.count += other.count;
    }
}

/// The difference Gram of `data` (C order, `shape`) along `axis`, differences of order 0..=M.
/// Non-finite values are missing data: every difference touching one is skipped.
pub fn difference_gram(
    data: &[f64],
    shape: &[usize],
    axis: usize,
    max_order: usize,
) -> Result<DifferenceGram> {
    if max_order == 0 || max_order > MAX_DIFFERENCE_ORDER {
        return Err(FieldError::InvalidParameter(format!(
            "max_order must lie in 1..={MAX_DIFFERENCE_ORDER}, got {max_order}"
        )));
    }
    let lines = AxisLines::new(shape, axis, data.len())?;
    Ok(lines.sum_blocks(
        DifferenceGram::zero(max_order),
        |block| block_gram(data, block, lines.len(), max_order),
        DifferenceGram::add,
    ))
}

fn block_gram(data: &[f64], block: &LaneBlock, len: usize, max_order: usize) -> DifferenceGram {
    // A fixed width lets the compiler keep the differences and sums in registers.
    match max_order {
        1 => block_gram_fixed::<2>(data, block, len),
        2 => block_gram_fixed::<3>(data, block, len),
        3 => block_gram_fixed::<4>(data, block, len),
        4 => block_gram_fixed::<5>(data, block, len),
        5 => block_gram_fixed::<6>(data, block, len),
        6 => block_gram_fixed::<7>(data, block, len),
        7 => block_gram_fixed::<8>(data, block, len),
        _ => block_gram_fixed::<9>(data, block, len),
    }
}

fn block_gram_fixed<const W: usize>(data: &[f64], block: &LaneBlock, len: usize) -> DifferenceGram {
    let mut gram = [[0.0f64; W]; W];
    let mut count = 0u64;
    // previous[j] = D⁰x … D^{W-1}x at the previous position of lane j; NaN before the start,
    // so the first W-1 positions of every line come out undefined.
    let mut previous = vec![[f64::NAN; W]; block.lanes];
    for i in 0..len {
        for (j, before) in previous.iter_mut().enumerate() {
            let mut diffs = [0.0f64; W];
            diffs[0] = data[block.at(i, j)];
            for m in 1..W {
                diffs[m] = diffs[m - 1] - before[m - 1];
            }
            *before = diffs;
            if diffs[W - 1].is_finite() {
                for a in 0..W {
                    for b in a..W {
                        gram[a][b] += diffs[a] * diffs[b];
                    }
                }
                count += 1;
            }
        }
    }
    DifferenceGram {
        max_order: W - 1,
        gram: gram.iter().flatten().copied().collect(),
        count,
    }
}

impl DifferenceGram {
    /// The full symmetric matrix (the kernels accumulate the upper triangle only).
    pub fn symmetric(&self) -> Vec<f64> {
        let w = self.max_order + 1;
        let mut g = self.gram.clone();
        for a in 0..w {
            for b in 0..a {
                g[a * w + b] = g[b * w + a];
            }
        }
        g
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn naive(line: &[f64], m_max: usize) -> Vec<f64> {
        let mut d = vec![line.to_vec()];
        for m in 1..=m_max {
            let p = &d[m - 1];
            d.push(p.windows(2).map(|w| w[1] - w[0]).collect());
        }
        let n = line.len() - m_max;
        let w = m_max + 1;
        let mut g = vec![0.0; w * w];
        for a in 0..w {
            for b in 0..w {
                let da = &d[a][d[a].len() - n..];
                let db = &d[b][d[b].len() - n..];
                g[a * w + b] = da.iter().zip(db).map(|(x, y)| x * y).sum();
            }
        }
        g
    }

    #[test]
    fn matches_naive_differences_on_every_axis() {
        let shape = [6usize, 9];
        let data: Vec<f64> = (0..54).map(|i| ((i * 37 % 11) as f64).sin()).collect();
        let g = difference_gram(&data, &shape, 1, 3).unwrap();
        let mut want = vec![0.0; 16];
        for r in 0..6 {
            let n = naive(&data[r * 9..(r + 1) * 9], 3);
            want.iter_mut().zip(&n).for_each(|(a, b)| *a += b);
        }
        let got = g.symmetric();
        for (a, b) in got.iter().zip(&want) {
            assert!((a - b).abs() < 1e-12, "{a} vs {b}");
        }
        assert_eq!(g.count, 6 * 6);
        let g0 = difference_gram(&data, &shape, 0, 2).unwrap();
        let mut want0 = vec![0.0; 9];
        for c in 0..9 {
            let col: Vec<f64> = (0..6).map(|r| data[r * 9 + c]).collect();
            let n = naive(&col, 2);
            want0.iter_mut().zip(&n).for_each(|(a, b)| *a += b);
        }
        for (a, b) in g0.symmetric().iter().zip(&want0) {
            assert!((a - b).abs() < 1e-12);
        }
    }

    #[test]
    fn missing_values_drop_every_difference_that_touches_them() {
        let mut data: Vec<f64> = (0..20).map(|i| i as f64 * 0.5).collect();
        data[10] = f64::NAN;
        let g = difference_gram(&data, &[20], 0, 2).unwrap();
        // positions 2..20 minus those whose window (i-2..=i) holds index 10
        assert_eq!(g.count, 18 - 3);
        // on a ramp D⁰x_i = i/2, D¹x = 1/2, D²x = 0, summed over the positions kept
        let kept: Vec<f64> = (2..20)
            .filter(|i| !(10..=12).contains(i))
            .map(|i| i as f64)
            .collect();
        let want = [
            [
                kept.iter().map(|i| 0.25 * i * i).sum(),
                kept.iter().map(|i| 0.25 * i).sum(),
                0.0,
            ],
            [
                kept.iter().map(|i| 0.25 * i).sum(),
                0.25 * kept.len() as f64,
                0.0,
            ],
            [0.0; 3],
        ];
        for (got, want) in g.symmetric().iter().zip(want.iter().flatten()) {
            assert!(
                (got - want).abs() <= 1e-12 * want.abs().max(1.0),
                "{got} vs {want}"
            );
        }
    }

    #[test]
    fn bad_order_is_an_error() {
        assert!(difference_gram(&[1.0; 10], &[10], 0, 0).is_err());
        assert!(difference_gram(&[1.0; 10], &[10], 0, MAX_DIFFERENCE_ORDER + 1).is_err());
    }
}
