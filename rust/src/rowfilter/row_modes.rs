//! The modes on which the quasi-optimal row filter computes the band of the optimal
//! prediction-error covariance P_e (SPEC §2.3 generalised).
//!
//! Every matrix of the row-state filter is a Kronecker product with V_x = σ² Toeplitz(R_x)
//! (SPEC §2.2), so P_e = Σ_j u_j u_jᵀ ⊗ v_j M_j over the modes (u_j, v_j) of V_x, each mode
//! running its own n_y-dimensional Riccati (M_j in units of v_j). Three mode sets:
//! - `Exact`: the eigenbasis of Toeplitz(R_x) on the W points of the row (faer, O(W³) once),
//!   edges included;
//! - `Toeplitz`: the Fourier modes of the infinite row. The band is then Toeplitz,
//!   C_d = (1/π) ∫₀^π cos(dω) v(ω) M(ω) dω with v(ω) = σ² S_x(ω),
//!   S_x(ω) ∝ (1 − 2ρ_x cos ω + ρ_x²)^(−n_x) the spectral density of the x axis [P 2.11]:
//!   trapezoid rule on G + 1 frequencies (exponentially accurate for a periodic analytic
//!   integrand; G ≥ 24/(1 − ρ_x)), O(G) per row and no O(W³) step. Exact in the interior of
//!   wide rows; near the ends of a row the true P_e is larger (fewer neighbours), which this
//!   set ignores (the loss is measured in the benchmarks).
//! - `Ends`: both, spliced. The ends of a row of W points see the row's far end only through
//!   terms that decay with the distance (measured: faster than R_x itself), so the first
//!   and last W'/2 columns take the band of the exact eigenbasis of a row of W' < W points
//!   (its left and right halves) and the columns in between the Toeplitz band. The
//!   scalar filter picks W' so that the W'-row's band 3W'/8 from its end is within
//!   [`SPLICE_TOLERANCE`] (plus a multiple of the bands' rounding floor) of the Toeplitz
//!   band on every row of its plan (`ScalarRowFilter::splice_holds`); O(W'³) once instead
//!   of O(W³), the exact band to that tolerance.

use super::StateMatrix;
use crate::error::Result;
use crate::field::{AxisModel, AxisModes};
use crate::simd::{self, Arith, Kernel};
use faer::Mat;
use std::ops::Range;

/// Fewest and most trapezoid intervals of the Toeplitz mode set.
const MIN_INTERVALS: usize = 256;
const MAX_INTERVALS: usize = 1 << 16;
/// Largest entry difference, relative to the Toeplitz band's largest entry, allowed between
/// the exact band 3W'/8 from the end of the ends' row and the Toeplitz band, above the
/// bands' rounding floor (about the exact band's own rounding at W' = 1024–2048, which sums
/// over W' modes).
pub(crate) const SPLICE_TOLERANCE: f64 = 1e-11;
/// Smallest row of the exact ends, W'.
const MIN_SPAN: usize = 256;

/// Which modes give the band of P_e.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ModeSet {
    /// The eigenbasis of the whole row.
    Exact,
    /// The eigenbasis of a shorter row for both ends, the Fourier modes in between.
    Ends,
    /// The Fourier modes of the infinite row.
    Toeplitz,
}

/// The Fourier modes of the infinite row, on the trapezoid nodes ω_g = πg/G.
#[derive(Debug, Clone)]
pub(crate) struct Fourier {
    /// Normalised spectral density λ_g = S_x(ω_g) (trapezoid mean 1).
    values: Vec<f64>,
    /// Trapezoid weights 1/G (1/(2G) at both ends).
    weights: Vec<f64>,
    /// cos(πk/G) for k = 0..2G: cos(d ω_g) = cosines[dg mod 2G] (the band's lags are walked
    /// on every row of a plan; libm's cos was a tenth of a one-image plan).
    cosines: Vec<f64>,
}

impl Fourier {
    fn new(axis: &AxisModel) -> Self {
        Self::with_intervals(axis, quadrature_intervals(axis.rho()))
    }

    /// The same integral on twice the nodes: its band differs from the usual one by the
    /// rounding of the per-mode covariances only (both quadratures have converged).
    pub fn finer(axis: &AxisModel) -> Self {
        Self::with_intervals(axis, 2 * quadrature_intervals(axis.rho()))
    }

    fn with_intervals(axis: &AxisModel, intervals: usize) -> Self {
        let step = std::f64::consts::PI / intervals as f64;
        let weights: Vec<f64> = (0..=intervals)
            .map(|g| {
                let end = g == 0 || g == intervals;
                if end {
                    0.5 / intervals as f64
                } else {
                    1.0 / intervals as f64
                }
            })
            .collect();
        let (rho, order) = (axis.rho(), axis.order() as i32);
        let raw: Vec<f64> = (0..=intervals)
            .map(|g| (1.0 - 2.0 * rho * (step * g as f64).cos() + rho * rho).powi(-order))
            .collect();
        let mean: f64 = raw.iter().zip(&weights).map(|(s, w)| s * w).sum();
        Self {
            values: raw.iter().map(|s| s / mean).collect(),
            weights,
            cosines: (0..2 * intervals)
                .map(|k| (step * k as f64).cos())
                .collect(),
        }
    }

    /// λ_g of every node.
    pub fn values(&self) -> &[f64] {
        &self.values
    }

    /// The band's block C_d (the same at every column) for d = 0..=lags.
    pub fn blocks(&self, modal: &[StateMatrix], lags: usize) -> Vec<StateMatrix> {
        let period = self.cosines.len();
        (0..=lags)
            .map(|d| {
                let (mut block, mut k, stride) = (StateMatrix::zeros(), 0, d % period);
                for (m, wg) in modal.iter().zip(&self.weights) {
                    block += m * (wg * self.cosines[k]);
                    k += stride; // k = dg mod 2G
                    if k >= period {
                        k -= period;
                    }
                }
                block
            })
            .collect()
    }
}

/// A mode set of one row width.
#[derive(Debug, Clone)]
pub(crate) enum RowModes {
    /// Eigenbasis of Toeplitz(R_x) on the row.
    Exact(AxisModes),
    /// Fourier modes of the infinite row.
    Toeplitz {
        /// Row width W.
        width: usize,
        fourier: Fourier,
    },
    /// The eigenbasis of a row of W' points for both ends, the Fourier modes in between.
    Ends {
        /// Row width W.
        width: usize,
        /// The modes of the W'-point row (its first W' values in `values`).
        ends: AxisModes,
        fourier: Fourier,
        /// λ of the ends' modes, then of the Fourier modes.
        values: Vec<f64>,
    },
}

impl RowModes {
    /// The eigenbasis of the `axis` correlation on `width` points.
    pub fn exact(axis: &AxisModel, width: usize) -> Result<Self> {
        Ok(Self::Exact(AxisModes::new(axis, width)?))
    }

    /// The Fourier modes of the infinite row of the `axis` model, for rows of `width` points.
    pub fn toeplitz(axis: &AxisModel, width: usize) -> Self {
        Self::Toeplitz {
            width,
            fourier: Fourier::new(axis),
        }
    }

    /// The exact ends of a row of `span` points spliced to the Fourier modes (`span` even,
    /// at most `width` / 2).
    pub fn ends(axis: &AxisModel, width: usize, span: usize) -> Result<Self> {
        debug_assert!(span % 2 == 0 && 2 * span <= width);
        let ends = AxisModes::new(axis, span)?;
        let fourier = Fourier::new(axis);
        let values = ends.values.iter().chain(&fourier.values).copied().collect();
        Ok(Self::Ends {
            width,
            ends,
            fourier,
            values,
        })
    }

    /// The first W' to try for the ends of `axis` rows of `width` points (None: the row is
    /// too short to split, use the whole row): the smallest power of two ≥ [`MIN_SPAN`]
    /// with |R_x| < 1e-4 beyond 3W'/8 (the splice's defect has been found far below R_x at
    /// the same distance; `ScalarRowFilter` checks it there).
    pub fn first_span(axis: &AxisModel, width: usize) -> Option<usize> {
        let reach = (0..width)
            .rev()
            .find(|&d| axis.correlation(d as f64).abs() >= 1e-4)
            .map_or(0, |d| d + 1);
        let span = (8 * reach).div_ceil(3).next_power_of_two().max(MIN_SPAN);
        (2 * span <= width).then_some(span)
    }

    /// W' of the exact ends (None: not spliced).
    pub fn span(&self) -> Option<usize> {
        match self {
            Self::Ends { ends, .. } => Some(ends.size()),
            _ => None,
        }
    }

    /// The columns ℓ whose band blocks (ℓ, ℓ + d) are the Toeplitz ones.
    pub fn toeplitz_columns(&self) -> Range<usize> {
        match self {
            Self::Exact(_) => 0..0,
            Self::Toeplitz { width, .. } => 0..*width,
            Self::Ends { width, ends, .. } => ends.size() / 2..width - ends.size() / 2,
        }
    }

    /// Row width W.
    pub fn width(&self) -> usize {
        match self {
            Self::Exact(modes) => modes.size(),
            Self::Toeplitz { width, .. } | Self::Ends { width, .. } => *width,
        }
    }

    /// λ_j of every mode (mode variance σ² λ_j).
    pub fn values(&self) -> &[f64] {
        match self {
            Self::Exact(modes) => &modes.values,
            Self::Toeplitz { fourier, .. } => &fourier.values,
            Self::Ends { values, .. } => values,
        }
    }

    /// Band blocks of Σ_j u_j u_jᵀ ⊗ M_j for the lags d = 0..=max_lag: block (ℓ, ℓ + d) is row
    /// ℓ of the d-th matrix ((W − d) × n², row-major n×n blocks); `modal` = M_j per mode.
    pub fn band(&self, modal: &[StateMatrix], n: usize, max_lag: usize) -> Vec<Mat<f64>> {
        let (w, last) = (self.width(), max_lag.min(self.width() - 1));
        match self {
            Self::Exact(modes) => exact_band(modes, BandQuery::new(modal, n, last, 0..w)),
            Self::Toeplitz { fourier, .. } => {
                let blocks = fourier.blocks(modal, last);
                (0..=last)
                    .map(|d| Mat::from_fn(w - d, n * n, |_, ab| blocks[d][(ab / n, ab % n)]))
                    .collect()
            }
            Self::Ends { ends, fourier, .. } => {
                let span = ends.size();
                let exact = exact_band(ends, BandQuery::new(&modal[..span], n, last, 0..span));
                let blocks = fourier.blocks(&modal[span..], last);
                let interior = self.toeplitz_columns();
                // the left half of the W'-row for ℓ < W'/2, its right half for ℓ ≥ W − W'/2
                let entry = |d: usize, l: usize, ab: usize| match l {
                    l if interior.contains(&l) => blocks[d][(ab / n, ab % n)],
                    l if l < span => exact[d][(l, ab)],
                    l => exact[d][(l + span - w, ab)],
                };
                (0..=last)
                    .map(|d| Mat::from_fn(w - d, n * n, |l, ab| entry(d, l, ab)))
                    .collect()
            }
        }
    }

    /// For `Ends`: the largest entry difference between the exact band on a slab of
    /// [`BAND_ROWS`] columns 3W'/8 from the W'-row's left end and the Toeplitz band, and
    /// between the Toeplitz band and `finer`'s (its rounding floor; `finer_modal`: the
    /// covariances of `finer`'s modes), both relative to the Toeplitz band's largest entry.
    /// None for the other sets.
    pub fn splice_defect(
        &self,
        modal: &[StateMatrix],
        finer: &Fourier,
        finer_modal: &[StateMatrix],
        n: usize,
        max_lag: usize,
    ) -> Option<(f64, f64)> {
        let Self::Ends { ends, fourier, .. } = self else {
            return None;
        };
        let span = ends.size();
        let slab = 3 * span / 8..3 * span / 8 + BAND_ROWS;
        let exact = exact_band(ends, BandQuery::new(&modal[..span], n, max_lag, slab));
        let blocks = fourier.blocks(&modal[span..], max_lag);
        let check = finer.blocks(finer_modal, max_lag);
        let scale = blocks[0].amax();
        let mut defect = 0.0f64;
        let mut floor = 0.0f64;
        for ((lag, block), other) in exact.iter().zip(&blocks).zip(&check) {
            floor = floor.max((block - other).amax());
            for l in 0..lag.nrows() {
                for ab in 0..n * n {
                    defect = defect.max((lag[(l, ab)] - block[(ab / n, ab % n)]).abs());
                }
            }
        }
        Some((defect / scale, floor / scale))
    }
}

/// Rows ℓ of the band accumulated at once by [`exact_band`] (their sums stay in L1).
const BAND_ROWS: usize = 32;

/// [`RowModes::band`] of the eigenbasis: block (ℓ, ℓ + d) = Σ_j u_ℓj u_(ℓ+d)j M_j. Rows ℓ
/// in groups of [`BAND_ROWS`], the modes j in order: column j of U is contiguous, the
/// group's sums stay in L1, and nothing W × W is formed (a matrix product through the W × W
/// products u_ℓj u_(ℓ+d)j per lag made and faulted in 32 MB per lag at W = 2048, ~3/4 of
/// building a plan).
fn exact_band(modes: &AxisModes, query: BandQuery) -> Vec<Mat<f64>> {
    simd::dispatch(ExactBand { modes, query })
}

/// The arguments of [`exact_band_with`], a [`Kernel`] of `simd::dispatch`.
struct ExactBand<'a> {
    modes: &'a AxisModes,
    query: BandQuery<'a>,
}

impl Kernel for ExactBand<'_> {
    type Output = Vec<Mat<f64>>;
    #[inline(always)]
    fn run<A: Arith>(self) -> Vec<Mat<f64>> {
        exact_band_with::<A>(self.modes, self.query)
    }
}

/// What [`exact_band`] sums: the per-mode n×n covariances `modal`, lags 0..=`lags`, the rows
/// ℓ in `rows` (row i of each lag's matrix is ℓ = rows.start + i).
#[derive(Clone)]
struct BandQuery<'a> {
    modal: &'a [StateMatrix],
    n: usize,
    lags: usize,
    rows: Range<usize>,
}

impl<'a> BandQuery<'a> {
    fn new(modal: &'a [StateMatrix], n: usize, lags: usize, rows: Range<usize>) -> Self {
        Self {
            modal,
            n,
            lags,
            rows,
        }
    }
}

#[inline(always)]
fn exact_band_with<A: Arith>(modes: &AxisModes, query: BandQuery) -> Vec<Mat<f64>> {
    let BandQuery {
        modal,
        n,
        lags,
        rows,
    } = query;
    let (u, w, blocks) = (&modes.vectors, modes.size(), n * n);
    let end = |d: usize| rows.end.min(w - d);
    let mut band: Vec<Mat<f64>> = (0..=lags)
        .map(|d| Mat::zeros(end(d).saturating_sub(rows.start), blocks))
        .collect();
    // sums[d · n² + ab][k] for row start + k; pairs[d][k] = u_(start+k)j u_(start+k+d)j
    let mut sums = vec![[0.0; BAND_ROWS]; (lags + 1) * blocks];
    let mut pairs = vec![[0.0; BAND_ROWS]; lags + 1];
    for start in rows.clone().step_by(BAND_ROWS) {
        sums.fill([0.0; BAND_ROWS]);
        for (j, m) in modal.iter().enumerate() {
            let column = u.col_as_slice(j);
            for (d, pair) in pairs.iter_mut().enumerate() {
                pair_products(column, start, d, pair);
            }
            for (d, pair) in pairs.iter().enumerate() {
                let rows = sums[d * blocks..(d + 1) * blocks].iter_mut();
                for (ab, sum) in rows.enumerate() {
                    add_scaled::<A>(sum, m[(ab / n, ab % n)], pair);
                }
            }
        }
        for (d, lag) in band.iter_mut().enumerate() {
            for l in start..(start + BAND_ROWS).min(end(d)) {
                for ab in 0..blocks {
                    lag[(l - rows.start, ab)] = sums[d * blocks + ab][l - start];
                }
            }
        }
    }
    band
}

/// pair[k] = u_ℓ u_(ℓ+d) for ℓ = start + k (0 past the end of the column).
#[inline(always)]
fn pair_products(column: &[f64], start: usize, d: usize, pair: &mut [f64; BAND_ROWS]) {
    if let Some(run) = column.get(start..start + BAND_ROWS + d) {
        for (k, p) in pair.iter_mut().enumerate() {
            *p = run[k] * run[k + d];
        }
    } else {
        for (k, p) in pair.iter_mut().enumerate() {
            let l = start + k;
            *p = if l + d < column.len() {
                column[l] * column[l + d]
            } else {
                0.0
            };
        }
    }
}

/// sum += c · pair, entry by entry.
#[inline(always)]
fn add_scaled<A: Arith>(sum: &mut [f64; BAND_ROWS], c: f64, pair: &[f64; BAND_ROWS]) {
    // a local accumulator: updated in place, LLVM keeps the loop scalar
    let mut acc = *sum;
    for (s, p) in acc.iter_mut().zip(pair) {
        *s = A::add_product(*s, c, *p);
    }
    *sum = acc;
}

/// Trapezoid intervals G for ρ_x: the error decays like ρ_x^(2G), so G = 24/(1 − ρ_x)
/// leaves ~e^(−48).
fn quadrature_intervals(rho: f64) -> usize {
    ((24.0 / (1.0 - rho)).ceil() as usize).clamp(MIN_INTERVALS, MAX_INTERVALS)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exact_band_is_the_sum_over_the_modes() {
        // widths around the row groups (one short group, a tail), whole rows and a middle
        // range (the splice check's), both arithmetic builds
        let axis = AxisModel::new(0.8, 2).unwrap();
        let cases = [
            (7usize, 1usize, 2usize, 0..7),
            (33, 2, 3, 0..33),
            (70, 4, 4, 0..70),
            (70, 2, 3, 26..44),
        ];
        for (w, n, lags, rows) in cases {
            let RowModes::Exact(modes) = RowModes::exact(&axis, w).unwrap() else {
                unreachable!()
            };
            let modal: Vec<StateMatrix> = (0..w)
                .map(|j| StateMatrix::from_fn(|a, b| ((j + 3 * a + 7 * b) as f64 * 0.37).sin()))
                .collect();
            let want = |d: usize, l: usize, ab: usize| -> f64 {
                (0..w)
                    .map(|j| {
                        let u = &modes.vectors;
                        u[(l, j)] * u[(l + d, j)] * modal[j][(ab / n, ab % n)]
                    })
                    .sum()
            };
            let query = BandQuery::new(&modal, n, lags, rows.clone());
            let kernel = |query| ExactBand {
                modes: &modes,
                query,
            };
            let mut builds = vec![simd::run_plain(kernel(query.clone()))];
            if simd::fused_available() {
                builds.push(simd::dispatch(kernel(query)));
            }
            for band in builds {
                assert_eq!(band.len(), lags + 1);
                for (d, lag) in band.iter().enumerate() {
                    let end = rows.end.min(w - d);
                    assert_eq!((lag.nrows(), lag.ncols()), (end - rows.start, n * n));
                    for l in rows.start..end {
                        for ab in 0..n * n {
                            let err = (lag[(l - rows.start, ab)] - want(d, l, ab)).abs();
                            assert!(err < 1e-13, "w {w} d {d} l {l} ab {ab}: {err:e}");
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn spliced_ends_give_the_whole_rows_band() {
        // a nonlinear function of the mode variance, as the Riccati's P_e is: its band has
        // edge effects, which the ends' row must carry
        let axis = AxisModel::new(0.8, 2).unwrap();
        let (w, span, n, lags) = (700usize, 256usize, 2usize, 3usize);
        let shape = [[1.0, 0.3], [0.3, 0.5]];
        let covariance = |v: f64| {
            StateMatrix::from_fn(|a, b| {
                if a < n && b < n {
                    v / (1.0 + v) * shape[a][b]
                } else {
                    0.0
                }
            })
        };
        let modal = |values: &[f64]| values.iter().map(|&v| covariance(v)).collect::<Vec<_>>();
        let whole = RowModes::exact(&axis, w).unwrap();
        let ends = RowModes::ends(&axis, w, span).unwrap();
        assert_eq!(
            (ends.span(), ends.toeplitz_columns()),
            (Some(span), 128..572)
        );
        let want = whole.band(&modal(whole.values()), n, lags);
        let got = ends.band(&modal(ends.values()), n, lags);
        let scale = want[0].norm_max();
        for (d, (a, b)) in want.iter().zip(&got).enumerate() {
            assert_eq!((b.nrows(), b.ncols()), (w - d, n * n));
            let most = (a - b).norm_max();
            assert!(most < 1e-12 * scale, "lag {d}: {most:e}");
        }
        // the edge effects are real: the first column's variance is far from the middle's
        assert!((want[0][(0, 0)] - want[0][(w / 2, 0)]).abs() > 1e-3 * scale);
        let finer = Fourier::finer(&axis);
        let finer_modal = modal(finer.values());
        let (defect, floor) = ends
            .splice_defect(&modal(ends.values()), &finer, &finer_modal, n, lags)
            .unwrap();
        assert!(defect < 1e-12 && floor < 1e-13, "{defect:e} {floor:e}");
        assert!(whole
            .splice_defect(&modal(whole.values()), &finer, &finer_modal, n, lags)
            .is_none());
    }

    #[test]
    fn first_span_covers_the_correlation_and_leaves_short_rows_whole() {
        for (rho, order) in [(0.5, 1), (0.9, 2), (0.95, 4)] {
            let axis = AxisModel::new(rho, order).unwrap();
            let span = RowModes::first_span(&axis, 1 << 14).unwrap();
            assert!(span.is_power_of_two() && span >= MIN_SPAN);
            assert!(
                axis.correlation((3 * span / 8) as f64).abs() < 1e-4,
                "{rho} {order}"
            );
        }
        let axis = AxisModel::new(0.5, 1).unwrap();
        assert_eq!(RowModes::first_span(&axis, 511), None);
        assert_eq!(RowModes::first_span(&axis, 512), Some(256));
    }

    #[test]
    fn toeplitz_band_of_the_prior_is_the_correlation() {
        for (rho, order) in [(0.5, 1), (0.9, 2), (0.95, 4), (0.99, 1)] {
            let axis = AxisModel::new(rho, order).unwrap();
            let modes = RowModes::toeplitz(&axis, 40);
            let identity = vec![StateMatrix::identity(); modes.values().len()];
            let scaled: Vec<StateMatrix> = identity
                .iter()
                .zip(modes.values())
                .map(|(m, v)| m * *v)
                .collect();
            let band = modes.band(&scaled, 1, 6);
            for (d, lag) in band.iter().enumerate() {
                let want = axis.correlation(d as f64);
                for l in 0..lag.nrows() {
                    assert!((lag[(l, 0)] - want).abs() < 1e-12, "{rho} {order} {d}");
                }
            }
        }
    }

    #[test]
    fn exact_band_of_the_prior_is_the_correlation() {
        let axis = AxisModel::new(0.8, 2).unwrap();
        let modes = RowModes::exact(&axis, 30).unwrap();
        let scaled: Vec<StateMatrix> = modes
            .values()
            .iter()
            .map(|v| StateMatrix::identity() * *v)
            .collect();
        let band = modes.band(&scaled, 1, 3);
        for (d, lag) in band.iter().enumerate() {
            for l in 0..lag.nrows() {
                assert!((lag[(l, 0)] - axis.correlation(d as f64)).abs() < 1e-12);
            }
        }
    }
}
