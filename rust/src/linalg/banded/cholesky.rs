//! The band Cholesky factor A = L Lᵀ and its solves, planned once per factor: unrolled
//! substitutions for the fixed bandwidths, partitioned ones for long orders, steady ones
//! (shared coefficients, or blocks for the wide bands) over a periodic interior.

use super::band::{band_index, SymmetricBand};
use super::band_inverse::selected_inverse;
use super::lane_steps::{Lanes, LANES};
use super::partitioned::{part_span, LaneMajor, Strided, LANE_MAJOR_BANDS, MIN_PARTITIONED};
use super::steady_band::{snap_interior, Steady};
use super::steady_blocks::{block_size, Rhs, SteadyBlocks};
use super::substitution::{slots, substitute, substitute_plain, FactorCoefficients};
use crate::error::{FieldError, Result};
use crate::simd::{self, Arith, Kernel};

/// The bandwidths with unrolled kernels: the row filters' default bands n(max(n, 2) + 1) − 1
/// (2, 5, 11, 19 for n = 1..4) and the narrow ones of other AR orders (1, 3, 7).
const FIXED_BANDS: [usize; 7] = [1, 2, 3, 5, 7, 11, 19];

/// The smallest of [`FIXED_BANDS`] at least `b`, or `b` beyond them.
fn padded_bandwidth(b: usize) -> usize {
    FIXED_BANDS.into_iter().find(|&f| f >= b).unwrap_or(b)
}

/// Band Cholesky in place (lower band stored row by row, see [`SymmetricBand`]).
fn factor_in_place(l: &mut [f64], n: usize, b: usize) -> Result<()> {
    for i in 0..n {
        let first = i.saturating_sub(b);
        for k in first..=i {
            let mut sum = l[band_index(b, i, k)];
            let start = first.max(k.saturating_sub(b));
            // L_ip and L_kp for p = start..k: contiguous in rows i and k
            let (at_i, at_k) = (band_index(b, i, start), band_index(b, k, start));
            let len = k - start;
            for (x, y) in l[at_i..at_i + len].iter().zip(&l[at_k..at_k + len]) {
                sum -= x * y;
            }
            if k == i {
                if sum.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
                    return Err(FieldError::InvalidParameter(
                        "a filter matrix is not positive definite (ill-conditioned model)".into(),
                    ));
                }
                l[band_index(b, i, i)] = sum.sqrt();
            } else {
                l[band_index(b, i, k)] = sum / l[band_index(b, k, k)];
            }
        }
    }
    Ok(())
}

impl SymmetricBand {
    /// The entries of A⁻¹ within the band (`band_inverse`), from a plain factorisation (no
    /// solve plans: for one-off inverses).
    pub(crate) fn inverse_band(&self) -> Result<SymmetricBand> {
        let (n, b) = (self.size, self.bandwidth);
        let mut l = self.data.clone();
        factor_in_place(&mut l, n, b)?;
        Ok(SymmetricBand {
            size: n,
            bandwidth: b,
            data: selected_inverse(&l, n, b),
        })
    }

    /// The band of L before `steady_band::snap_interior`, for the tests.
    #[cfg(test)]
    pub(crate) fn cholesky_unsnapped(&self) -> Vec<f64> {
        let mut l = self.data.clone();
        factor_in_place(&mut l, self.size, self.bandwidth).unwrap();
        l
    }

    /// The Cholesky factor L (A = L Lᵀ), in the band storage of the smallest of
    /// [`FIXED_BANDS`] that holds the band (zeros beyond it: a band factor has no fill
    /// outside the band; wider bands are kept as they are), so that every bandwidth up to
    /// 19 gets the unrolled kernels; for the orders solved by parts, its interior rows
    /// are made exactly periodic (`steady_band`).
    pub fn cholesky(&self) -> Result<BandCholesky> {
        let (n, b) = (self.size, padded_bandwidth(self.bandwidth));
        let mut l = self.widened(b);
        factor_in_place(&mut l, n, b)?;
        let steady = FIXED_BANDS.contains(&b) && n >= MIN_PARTITIONED && part_span(n, b) >= 2 * b;
        let snap = if steady {
            snap_interior(&mut l, n, b)
        } else {
            None
        };
        let inverse_diagonal: Vec<f64> = (0..n).map(|i| 1.0 / l[band_index(b, i, i)]).collect();
        // Pre-scaled coefficients of the substitutions, zero outside the matrix: row i of L
        // (columns i − b..i) and column i below the pivot (rows i + 1..i + b), times 1/L_ii.
        let mut forward = vec![0.0; n * b];
        let mut backward = vec![0.0; n * b];
        for i in 0..n {
            for m in 0..b {
                if i + m >= b {
                    forward[i * b + m] = l[i * (b + 1) + m] * inverse_diagonal[i];
                }
                // slot m pairs with x[i + b − m] (the oldest first, in backward order)
                let r = i + b - m;
                if r < n {
                    backward[i * b + m] = l[r * (b + 1) + m] * inverse_diagonal[i];
                }
            }
        }
        let mut factor = BandCholesky {
            size: n,
            bandwidth: b,
            data: l,
            inverse_diagonal,
            forward,
            backward,
            lane_major: None,
            strided: None,
            steady: None,
            blocks: None,
        };
        let block = snap
            .as_ref()
            .and_then(|s| block_size(s.period, b).map(|g| (s, g)));
        if let Some((snap, g)) = block {
            factor.blocks = SteadyBlocks::new(&factor.data, n, b, g, snap);
        }
        if steady && factor.blocks.is_none() {
            factor.steady = Steady::new(&factor.coefficients());
            if factor.steady.is_none() {
                factor.partition(b >= LANE_MAJOR_BANDS);
            }
        }
        Ok(factor)
    }
}

/// Lower Cholesky factor of a [`SymmetricBand`].
#[derive(Debug, Clone, PartialEq)]
pub struct BandCholesky {
    size: usize,
    bandwidth: usize,
    data: Vec<f64>,
    inverse_diagonal: Vec<f64>,
    forward: Vec<f64>,
    backward: Vec<f64>,
    lane_major: Option<LaneMajor>,
    strided: Option<Strided>,
    steady: Option<Steady>,
    blocks: Option<SteadyBlocks>,
}

thread_local! {
    /// The lane-major copy of x of the partitioned solves, kept between calls.
    static SCRATCH: std::cell::Cell<Vec<Lanes>> = const { std::cell::Cell::new(Vec::new()) };
}

/// `$solve` with `$b` bound to the factor's bandwidth as a constant, for the bandwidths
/// with a fixed kernel (unrolled inner products); `$dynamic` for the others.
macro_rules! by_bandwidth {
    ($factor:expr, |$b:ident| $solve:expr, $dynamic:expr) => {
        match $factor.bandwidth {
            1 => {
                const $b: usize = 1;
                $solve
            }
            2 => {
                const $b: usize = 2;
                $solve
            }
            3 => {
                const $b: usize = 3;
                $solve
            }
            5 => {
                const $b: usize = 5;
                $solve
            }
            7 => {
                const $b: usize = 7;
                $solve
            }
            11 => {
                const $b: usize = 11;
                $solve
            }
            19 => {
                const $b: usize = 19;
                $solve
            }
            _ => $dynamic,
        }
    };
}

/// One solve of a factor with a fixed bandwidth B, a [`Kernel`] of `simd::dispatch`: the
/// fused build runs one rounding and one latency per step instead of two.
struct FixedSolve<'a, const B: usize> {
    factor: &'a BandCholesky,
    x: &'a mut [f64],
    rhs: Rhs,
}

impl<const B: usize> Kernel for FixedSolve<'_, B> {
    type Output = ();
    #[inline(always)]
    fn run<A: Arith>(self) {
        self.factor.solve_fixed::<A, B>(self.x, self.rhs)
    }
}

impl BandCholesky {
    /// The entries of A⁻¹ within the band (`band_inverse`), as a symmetric band.
    pub(crate) fn inverse_band(&self) -> SymmetricBand {
        SymmetricBand {
            size: self.size,
            bandwidth: self.bandwidth,
            data: selected_inverse(&self.data, self.size, self.bandwidth),
        }
    }

    /// The substitution coefficients, for the steady solves.
    fn coefficients(&self) -> FactorCoefficients<'_> {
        FactorCoefficients {
            bandwidth: self.bandwidth,
            inverse_diagonal: &self.inverse_diagonal,
            forward: &self.forward,
            backward: &self.backward,
        }
    }

    /// The steady plan, if the solves use one.
    #[cfg(test)]
    pub(crate) fn steady_plan(&self) -> Option<&Steady> {
        self.steady.as_ref()
    }

    /// The block plan, if the solves use one.
    #[cfg(test)]
    pub(crate) fn block_plan(&self) -> Option<&SteadyBlocks> {
        self.blocks.as_ref()
    }

    /// Whether the solves use the steady interior (by parts or by blocks).
    #[cfg(test)]
    pub(crate) fn is_steady(&self) -> bool {
        self.steady.is_some() || self.blocks.is_some()
    }

    /// The solve without a plan (one substitution at a time), for the tests.
    #[cfg(test)]
    pub(crate) fn solve_unplanned(&self, x: &mut [f64]) {
        self.solve_dynamic(x)
    }

    /// Plans the partitioned solves, on a lane-major copy of x or on x itself.
    fn partition(&mut self, lane_major: bool) {
        let f = self.coefficients();
        (self.lane_major, self.strided) = if lane_major {
            (Some(LaneMajor::new(&f)), None)
        } else {
            (None, Some(Strided::new(&f)))
        };
    }

    /// Solves A x = rhs in place (forward then backward substitution).
    pub fn solve_in_place(&self, x: &mut [f64]) {
        self.solve_rhs(x, Rhs::Dense)
    }

    /// [`Self::solve_in_place`] for a right-hand side that is zero outside the positions
    /// 0, stride, 2·stride, … (the row filters' innovations: one observed component in
    /// each column of `stride` states), with the same result (up to the sign of zeros):
    /// the block solves of a plan with blocks of `stride` skip the products by the zeros
    /// (~1/5 of the forward recursion's multiply-adds for blocks of 3).
    pub(crate) fn solve_observed_in_place(&self, x: &mut [f64], stride: usize) {
        debug_assert!(x
            .iter()
            .enumerate()
            .all(|(i, v)| i % stride == 0 || *v == 0.0));
        let rhs = match &self.blocks {
            Some(blocks) if blocks.size() == stride => Rhs::FirstOfBlock,
            _ => Rhs::Dense,
        };
        self.solve_rhs(x, rhs)
    }

    /// The solve, on the CPU's best kernels. One function per bandwidth and build (see
    /// `simd::dispatch`): with the kernels of every bandwidth inlined into one function,
    /// the release test binary took 43 minutes to build instead of 4.5 (same bits, same
    /// speed).
    fn solve_rhs(&self, x: &mut [f64], rhs: Rhs) {
        by_bandwidth!(
            self,
            |B| simd::dispatch(FixedSolve::<B> {
                factor: self,
                x,
                rhs
            }),
            self.solve_dynamic(x)
        )
    }

    /// The solve with separate multiplies and adds (the portable kernels), for the tests.
    #[cfg(test)]
    fn solve_plain(&self, x: &mut [f64], rhs: Rhs) {
        by_bandwidth!(
            self,
            |B| simd::run_plain(FixedSolve::<B> {
                factor: self,
                x,
                rhs
            }),
            self.solve_dynamic(x)
        )
    }

    /// Substitutions with the last B results kept in registers and the pre-scaled
    /// coefficients, so that each step waits only on one multiply-subtract (the latency
    /// chain of a banded solve is its cost); partitioned for long orders.
    #[inline(always)]
    fn solve_fixed<A: Arith, const B: usize>(&self, x: &mut [f64], rhs: Rhs) {
        if let Some(blocks) = &self.blocks {
            return self.solve_blocks::<A, B>(x, blocks, rhs);
        }
        if let Some(s) = &self.strided {
            s.solve::<A, B>(&self.coefficients(), x);
            return;
        }
        let span = match (&self.lane_major, &self.steady) {
            (Some(s), _) => s.span,
            (_, Some(s)) => s.span,
            _ => 0,
        };
        if span > 0 {
            // taken out of the thread-local (not used in a closure): the kernels must stay
            // inlined into the caller's target features
            let mut scratch = SCRATCH.take();
            if scratch.len() < span {
                scratch.resize(span, [0.0; LANES]);
            }
            let rows = &mut scratch[..span];
            match (&self.lane_major, &self.steady) {
                (Some(s), _) => s.solve::<A, B>(&self.coefficients(), x, rows),
                (_, Some(s)) => s.solve::<A, B>(&self.coefficients(), x, rows),
                _ => unreachable!(),
            }
            SCRATCH.set(scratch);
            return;
        }
        let n = self.size;
        let inv = |i: usize| self.inverse_diagonal[i];
        let mut window = [0.0; B];
        substitute::<A, B, false>(x, slots(&self.forward), inv, 0, n, &mut window);
        let mut window = [0.0; B];
        substitute::<A, B, true>(x, slots(&self.backward), inv, 0, n, &mut window);
    }

    /// Both substitutions by blocks over the steady interior (see [`SteadyBlocks`]), in
    /// place, and one position at a time before and after it.
    #[inline(always)]
    fn solve_blocks<A: Arith, const B: usize>(
        &self,
        x: &mut [f64],
        blocks: &SteadyBlocks,
        rhs: Rhs,
    ) {
        let (n, start, end) = (self.size, blocks.start, blocks.end);
        let inv = |i: usize| self.inverse_diagonal[i];
        let (forward, backward) = (slots(&self.forward), slots(&self.backward));
        let mut window = [0.0; B];
        substitute::<A, B, false>(x, &forward, inv, 0, start, &mut window);
        blocks.substitute::<A>(x, false, rhs);
        let mut window: [f64; B] = std::array::from_fn(|j| x[end - B + j]);
        substitute::<A, B, false>(x, &forward, inv, end, n, &mut window);
        let mut window = [0.0; B];
        substitute::<A, B, true>(x, &backward, inv, 0, n - end, &mut window);
        blocks.substitute::<A>(x, true, Rhs::Dense);
        let mut window: [f64; B] = std::array::from_fn(|j| x[start + B - 1 - j]);
        substitute::<A, B, true>(x, &backward, inv, n - start, n, &mut window);
    }
}

impl BandCholesky {
    fn solve_dynamic(&self, x: &mut [f64]) {
        substitute_plain(&self.data, &self.inverse_diagonal, self.bandwidth, x);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::linalg::banded::band_ldl::{BandLdlBatch, LANES as LDL_LANES};
    use crate::linalg::banded::steady_band::STEADY_TOLERANCES;

    #[test]
    fn solves_a_banded_system() {
        let (n, b) = (9usize, 2usize);
        let mut a = SymmetricBand::zeros(n, b);
        for i in 0..n {
            a.add(i, i, 4.0 + i as f64 * 0.1);
            if i >= 1 {
                a.add(i, i - 1, -1.0);
            }
            if i >= 2 {
                a.add(i, i - 2, 0.3);
            }
        }
        let x: Vec<f64> = (0..n).map(|i| (i as f64).sin()).collect();
        let mut rhs = vec![0.0; n];
        a.mul_vec(&x, &mut rhs);
        // dense check of mul_vec
        for (i, got) in rhs.iter().enumerate() {
            let want: f64 = (0..n).map(|k| a.get(i, k) * x[k]).sum();
            assert!((got - want).abs() < 1e-12);
        }
        a.cholesky().unwrap().solve_in_place(&mut rhs);
        assert!(rhs.iter().zip(&x).all(|(p, q)| (p - q).abs() < 1e-12));
    }

    /// The agreement expected with A itself (residuals, unsnapped factors): the planned
    /// factors of the partitioned orders have their interior snapped (see `steady_band`).
    fn snapped_tolerance(n: usize) -> f64 {
        if n >= MIN_PARTITIONED {
            10.0 * STEADY_TOLERANCES[0]
        } else {
            1e-12
        }
    }

    /// A diagonally dominant test matrix with irregular off-diagonal entries.
    fn test_matrix(n: usize, b: usize) -> SymmetricBand {
        let mut a = SymmetricBand::zeros(n, b);
        for i in 0..n {
            // diagonally dominant for every b
            a.add(i, i, 10.0 + b as f64);
            for k in i.saturating_sub(b)..i {
                a.add(i, k, ((i * 7 + k) % 5) as f64 * 0.2 - 0.4);
            }
        }
        a
    }

    /// (bandwidth, order) pairs: n = 40: one pass; n ≥ 128: the partitioned solves, with and
    /// without a remainder; the bandwidths between the fixed ones are stored padded.
    fn test_cases() -> impl Iterator<Item = (usize, usize)> {
        [1usize, 2, 3, 4, 5, 7, 8, 9, 11, 14, 15, 19, 23]
            .into_iter()
            .flat_map(|b| [(b, 40usize), (b, 128), (b, 259), (b, 1000)])
    }

    #[test]
    fn fixed_and_dynamic_solves_agree() {
        for (b, n) in test_cases() {
            let a = test_matrix(n, b);
            let ch = a.cholesky().unwrap();
            let rhs: Vec<f64> = (0..n).map(|i| (i as f64).cos()).collect();
            let (mut x, mut y) = (rhs.clone(), rhs.clone());
            ch.solve_in_place(&mut x);
            ch.solve_dynamic(&mut y);
            let mut back = vec![0.0; n];
            a.mul_vec(&x, &mut back);
            assert!(x.iter().zip(&y).all(|(p, q)| (p - q).abs() < 1e-13));
            let residual = back
                .iter()
                .zip(&rhs)
                .fold(0.0f64, |m, (p, q)| m.max((p - q).abs()));
            assert!(
                residual < snapped_tolerance(n),
                "b {b} n {n}: residual {residual:e}"
            );
        }
    }

    /// A nearly singular matrix: slowly decaying responses, not cut within a part.
    fn slow_matrix(n: usize, b: usize) -> SymmetricBand {
        let mut a = SymmetricBand::zeros(n, b);
        for i in 0..n {
            // 2.5 > 1.6 Σ_{d ≤ 7} 1/d²; the wider bands need a little more
            a.add(i, i, if b <= 7 { 2.5 } else { 2.65 });
            for k in i.saturating_sub(b)..i {
                a.add(i, k, -0.8 / ((i - k) * (i - k)) as f64);
            }
        }
        a
    }

    #[test]
    fn slowly_decaying_solves_agree() {
        for (b, n) in test_cases() {
            let a = slow_matrix(n, b);
            let ch = a.cholesky().unwrap();
            let rhs: Vec<f64> = (0..n).map(|i| (i as f64).cos()).collect();
            let (mut x, mut y, mut z) = (rhs.clone(), rhs.clone(), rhs.clone());
            ch.solve_in_place(&mut x);
            ch.solve_dynamic(&mut y);
            ch.solve_plain(&mut z, Rhs::Dense);
            let scale = y.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            assert!(x.iter().zip(&y).all(|(p, q)| (p - q).abs() < 1e-12 * scale));
            assert!(z.iter().zip(&y).all(|(p, q)| (p - q).abs() < 1e-12 * scale));
        }
    }

    #[test]
    fn fused_and_plain_solves_agree() {
        // solve_in_place takes the fused kernels when the CPU has FMA
        println!("fused kernels: {}", simd::fused_available());
        for (b, n) in test_cases() {
            let ch = test_matrix(n, b).cholesky().unwrap();
            let rhs: Vec<f64> = (0..n).map(|i| (i as f64 * 0.3).sin()).collect();
            let (mut x, mut y) = (rhs.clone(), rhs);
            ch.solve_in_place(&mut x);
            ch.solve_plain(&mut y, Rhs::Dense);
            assert!(x.iter().zip(&y).all(|(p, q)| (p - q).abs() < 1e-12));
        }
    }

    #[test]
    fn ldl_and_planned_solves_agree() {
        for (n, b) in [(9usize, 2usize), (300, 2), (300, 7)] {
            let a = test_matrix(n, b);
            let rhs: Vec<f64> = (0..n).map(|i| (i as f64).sin()).collect();
            let (mut x, mut y) = (rhs.clone(), rhs);
            a.cholesky().unwrap().solve_in_place(&mut x);
            let zero = vec![[0.0; LDL_LANES]; n];
            let mut ldl = BandLdlBatch::new(n, b);
            ldl.factor([&a; LDL_LANES], &zero, 1).unwrap();
            ldl.solve_in_place(5, &mut y);
            let most = x
                .iter()
                .zip(&y)
                .fold(0.0f64, |m, (p, q)| m.max((p - q).abs()));
            assert!(most < snapped_tolerance(n), "b {b} n {n}: {most:e}");
        }
    }

    #[test]
    fn lane_major_and_strided_solves_agree() {
        // orders: just above MIN_PARTITIONED, not multiples of LANES or of b, long
        for b in FIXED_BANDS {
            for n in [
                MIN_PARTITIONED,
                MIN_PARTITIONED + 1,
                131,
                259,
                1000,
                1003,
                4096,
            ] {
                if part_span(n, b) < 2 * b {
                    continue; // too short for parts (see `SymmetricBand::cholesky`)
                }
                for a in [test_matrix(n, b), slow_matrix(n, b)] {
                    let mut lane_major = a.cholesky().unwrap();
                    let mut strided = lane_major.clone();
                    lane_major.partition(true);
                    strided.partition(false);
                    assert!(lane_major.lane_major.is_some() && strided.strided.is_some());
                    let rhs: Vec<f64> = (0..n).map(|i| (i as f64 * 0.7).sin()).collect();
                    let (mut x, mut y, mut z) = (rhs.clone(), rhs.clone(), rhs.clone());
                    lane_major.solve_in_place(&mut x);
                    strided.solve_in_place(&mut y);
                    lane_major.solve_dynamic(&mut z);
                    let scale = z.iter().fold(0.0f64, |m, v| m.max(v.abs()));
                    assert!(x.iter().zip(&y).all(|(p, q)| (p - q).abs() < 1e-12 * scale));
                    assert!(x.iter().zip(&z).all(|(p, q)| (p - q).abs() < 1e-12 * scale));
                    // the plain build of the lane-major path too
                    let mut w = rhs;
                    lane_major.solve_plain(&mut w, Rhs::Dense);
                    assert!(w.iter().zip(&z).all(|(p, q)| (p - q).abs() < 1e-12 * scale));
                }
            }
        }
    }

    #[test]
    fn a_padded_factor_is_the_factor_of_its_band() {
        for b in [4usize, 8, 9, 14, 15] {
            let n = 40;
            let a = test_matrix(n, b);
            let own = a.cholesky_unsnapped();
            let padded = a.cholesky().unwrap();
            let wide = padded.bandwidth;
            assert!(FIXED_BANDS.contains(&wide) && wide > b, "b {b}: {wide}");
            for i in 0..n {
                for k in i.saturating_sub(wide)..=i {
                    let expected = if i - k <= b {
                        own[band_index(b, i, k)]
                    } else {
                        0.0
                    };
                    assert_eq!(padded.data[band_index(wide, i, k)], expected, "b {b}");
                }
            }
        }
    }

    #[test]
    fn indefinite_is_an_error() {
        let mut a = SymmetricBand::zeros(2, 1);
        a.add(0, 0, 1.0);
        a.add(1, 1, 1.0);
        a.add(1, 0, 2.0);
        assert!(a.cholesky().is_err());
    }
}
