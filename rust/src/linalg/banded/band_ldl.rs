//! LDLᵀ factors of LANES symmetric band matrices at once: the per-pixel-weighted rows of the
//! quasi-optimal row filter (SPEC §2.3 generalised, with missing pixels). Their systems
//! A_t = Λ_t + blockdiag_ℓ(Σ w h hᵀ) change with every row but not with the pixel values, so
//! LANES rows are factored side by side, one lane each: the factorisation of one matrix is a
//! chain of dependent divisions along its order, and the lanes overlap those chains (one
//! vector instruction serves all of them). Every lane runs the same scalar arithmetic, so a
//! factor does not depend on which rows share its batch.

use super::band::SymmetricBand;
use super::substitution::substitute;
use crate::error::{FieldError, Result};
use crate::simd::{self, Arith, Kernel};

/// Matrices factored side by side.
pub(crate) const LANES: usize = 8;

/// One value per lane.
pub(crate) type Lanes = [f64; LANES];

/// A_j = L_j D_j L_jᵀ, L_j unit lower banded, for the LANES lanes j, stored lane-interleaved.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct BandLdlBatch {
    size: usize,
    bandwidth: usize,
    /// [i·b + m] = L(i, i − b + m); zero outside the matrix, including `bandwidth` padding
    /// rows i ≥ size (read by the backward substitution as L(i + b − m, i)).
    lower: Vec<Lanes>,
    /// 1/D_ii.
    inverse_pivot: Vec<Lanes>,
}

impl BandLdlBatch {
    /// Room for LANES factors of order `size` and half-bandwidth `bandwidth`.
    pub fn new(size: usize, bandwidth: usize) -> Self {
        Self {
            size,
            bandwidth,
            lower: vec![[0.0; LANES]; (size + bandwidth) * bandwidth],
            inverse_pivot: vec![[0.0; LANES]; size],
        }
    }

    /// Factors A_j = bases[j] + blockdiag(blocks[·][j]) into lane j: `blocks` holds the
    /// size / order diagonal blocks of order `order`, each row-major. The bases must have
    /// this batch's order and bandwidth.
    pub fn factor(
        &mut self,
        bases: [&SymmetricBand; LANES],
        blocks: &[Lanes],
        order: usize,
    ) -> Result<()> {
        let (n, b) = (self.size, self.bandwidth);
        if order == 0
            || n % order != 0
            || blocks.len() != n * order
            || bases.iter().any(|a| a.size() != n || a.bandwidth() != b)
        {
            return Err(FieldError::Shape(format!(
                "BandLdlBatch::factor: needs bases of order {n}, bandwidth {b} and {n}·order \
                 block entries"
            )));
        }
        // the arithmetic is the plain multiply/add in either build (Rust never contracts to
        // FMA): the same bits, the lanes vectorised where AVX2 runs
        simd::dispatch(Factor {
            batch: self,
            bases: &bases,
            blocks,
            order,
        })
    }

    /// The row filters' bandwidths get their own inlined copy (unrolled inner loops).
    #[inline(always)]
    fn factor_with(
        &mut self,
        bases: &[&SymmetricBand; LANES],
        blocks: &[Lanes],
        order: usize,
    ) -> Result<()> {
        match self.bandwidth {
            1 => self.factor_fixed(bases, blocks, order, 1),
            2 => self.factor_fixed(bases, blocks, order, 2),
            3 => self.factor_fixed(bases, blocks, order, 3),
            5 => self.factor_fixed(bases, blocks, order, 5),
            7 => self.factor_fixed(bases, blocks, order, 7),
            b => self.factor_fixed(bases, blocks, order, b),
        }
    }

    /// Row i of every lane: c_k = A_ik − Σ_{p<k} c_p L_kp and L_ik = c_k / D_k for
    /// k = i − b..i, then D_i = A_ii − Σ_k c_k L_ik.
    #[inline(always)]
    fn factor_fixed(
        &mut self,
        bases: &[&SymmetricBand; LANES],
        blocks: &[Lanes],
        order: usize,
        b: usize,
    ) -> Result<()> {
        let shared = bases.iter().all(|a| std::ptr::eq(*a, bases[0]));
        let mut c = vec![[0.0; LANES]; b];
        let (mut block, mut row_in_block) = (0, 0);
        for i in 0..self.size {
            let first = i.saturating_sub(b);
            let block_start = i - row_in_block;
            let block_row = (block * order + row_in_block) * order;
            let extra = |k: usize| (k >= block_start).then(|| &blocks[block_row + k - block_start]);
            for k in first..i {
                let mut s = entries(bases, shared, i, k, extra(k));
                for p in first..k {
                    let (c_p, l_kp) = (&c[p - first], &self.lower[k * b + p + b - k]);
                    for j in 0..LANES {
                        s[j] -= c_p[j] * l_kp[j];
                    }
                }
                c[k - first] = s;
                let inverse = &self.inverse_pivot[k];
                let mut l_ik = [0.0; LANES];
                for j in 0..LANES {
                    l_ik[j] = s[j] * inverse[j];
                }
                self.lower[i * b + k + b - i] = l_ik;
            }
            let mut d = entries(bases, shared, i, i, extra(i));
            for k in first..i {
                let (c_k, l_ik) = (&c[k - first], &self.lower[i * b + k + b - i]);
                for j in 0..LANES {
                    d[j] -= c_k[j] * l_ik[j];
                }
            }
            if !d.iter().fold(true, |ok, v| ok & (*v > 0.0)) {
                return Err(FieldError::InvalidParameter(
                    "a weighted row system is not positive definite (ill-conditioned model)".into(),
                ));
            }
            let inverse = &mut self.inverse_pivot[i];
            for j in 0..LANES {
                inverse[j] = 1.0 / d[j];
            }
            row_in_block += 1;
            if row_in_block == order {
                (block, row_in_block) = (block + 1, 0);
            }
        }
        Ok(())
    }

    /// Solves A_lane x = rhs in place: L y = rhs, then Lᵀ x = D⁻¹ y.
    pub fn solve_in_place(&self, lane: usize, x: &mut [f64]) {
        assert!(
            lane < LANES && x.len() == self.size,
            "BandLdlBatch::solve_in_place: lane {lane} or length {} out of range",
            x.len()
        );
        simd::dispatch(Solve {
            batch: self,
            lane,
            x,
        })
    }

    #[inline(always)]
    fn solve_with<A: Arith>(&self, lane: usize, x: &mut [f64]) {
        match self.bandwidth {
            1 => self.solve_fixed::<A, 1>(lane, x),
            2 => self.solve_fixed::<A, 2>(lane, x),
            3 => self.solve_fixed::<A, 3>(lane, x),
            5 => self.solve_fixed::<A, 5>(lane, x),
            7 => self.solve_fixed::<A, 7>(lane, x),
            11 => self.solve_fixed::<A, 11>(lane, x),
            19 => self.solve_fixed::<A, 19>(lane, x),
            _ => self.solve_dynamic::<A>(lane, x),
        }
    }

    /// The shared window substitutions of `substitution` (the newest result alone on the
    /// latency chain); the backward one reads column i of L from the rows below it.
    #[inline(always)]
    fn solve_fixed<A: Arith, const B: usize>(&self, lane: usize, x: &mut [f64]) {
        let n = self.size;
        let lower = &self.lower;
        let forward = |i: usize| std::array::from_fn(|m| lower[i * B + m][lane]);
        let backward = |i: usize| std::array::from_fn(|m| lower[(i + B - m) * B + m][lane]);
        let mut window = [0.0; B];
        substitute::<A, B, false>(x, forward, |_| 1.0, 0, n, &mut window);
        let mut window = [0.0; B];
        let inverse = |i: usize| self.inverse_pivot[i][lane];
        substitute::<A, B, true>(x, backward, inverse, 0, n, &mut window);
    }

    /// The same substitutions for any bandwidth, in the same order of operations.
    #[inline(always)]
    fn solve_dynamic<A: Arith>(&self, lane: usize, x: &mut [f64]) {
        let (n, b) = (self.size, self.bandwidth);
        for i in 0..n {
            let first = i.saturating_sub(b);
            let mut acc = x[i];
            for (p, v) in x[first..i].iter().enumerate() {
                acc = A::sub_product(acc, self.lower[i * b + first + p + b - i][lane], *v);
            }
            x[i] = acc;
        }
        for i in (0..n).rev() {
            let mut acc = x[i] * self.inverse_pivot[i][lane];
            for j in (1..=b.min(n - 1 - i)).rev() {
                acc = A::sub_product(acc, self.lower[(i + j) * b + b - j][lane], x[i + j]);
            }
            x[i] = acc;
        }
    }
}

/// The factorisation of a batch, a [`Kernel`] of `simd::dispatch`.
struct Factor<'a> {
    batch: &'a mut BandLdlBatch,
    bases: &'a [&'a SymmetricBand; LANES],
    blocks: &'a [Lanes],
    order: usize,
}

impl Kernel for Factor<'_> {
    type Output = Result<()>;
    #[inline(always)]
    fn run<A: Arith>(self) -> Result<()> {
        self.batch.factor_with(self.bases, self.blocks, self.order)
    }
}

/// The solve of one lane, a [`Kernel`] of `simd::dispatch` (with FMA where the CPU has it).
struct Solve<'a> {
    batch: &'a BandLdlBatch,
    lane: usize,
    x: &'a mut [f64],
}

impl Kernel for Solve<'_> {
    type Output = ();
    #[inline(always)]
    fn run<A: Arith>(self) {
        self.batch.solve_with::<A>(self.lane, self.x)
    }
}

/// Entry (i, k), k ≤ i, of every lane's base (one load when they share it) plus `extra`.
#[inline(always)]
fn entries(
    bases: &[&SymmetricBand; LANES],
    shared: bool,
    i: usize,
    k: usize,
    extra: Option<&Lanes>,
) -> Lanes {
    let mut a = [bases[0].lower_entry(i, k); LANES];
    if !shared {
        for (a, base) in a.iter_mut().zip(bases) {
            *a = base.lower_entry(i, k);
        }
    }
    if let Some(extra) = extra {
        for j in 0..LANES {
            a[j] += extra[j];
        }
    }
    a
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An SPD band matrix (diagonally dominant) with a seed-dependent pattern.
    fn band(n: usize, b: usize, seed: usize) -> SymmetricBand {
        let mut a = SymmetricBand::zeros(n, b);
        for i in 0..n {
            a.add(
                i,
                i,
                2.0 * b as f64 + 1.0 + ((i * 7 + seed) % 5) as f64 * 0.1,
            );
            for k in i.saturating_sub(b)..i {
                a.add(i, k, (((i * 13 + k * 3 + seed) % 11) as f64 - 5.0) / 6.0);
            }
        }
        a
    }

    /// Lane j's diagonal blocks w h hᵀ (w ≥ 0 varying with the block and the lane).
    fn blocks(n: usize, order: usize) -> Vec<Lanes> {
        let h: Vec<f64> = (0..order).map(|r| 1.0 + 0.3 * r as f64).collect();
        (0..n * order)
            .map(|at| {
                let (ell, r, c) = (at / (order * order), at / order % order, at % order);
                std::array::from_fn(|j| ((ell * 5 + j) % 4) as f64 * 0.5 * h[r] * h[c])
            })
            .collect()
    }

    fn dense_solve(
        a: &SymmetricBand,
        blocks: &[Lanes],
        j: usize,
        order: usize,
        rhs: &[f64],
    ) -> Vec<f64> {
        let n = a.size();
        let dense = nalgebra::DMatrix::from_fn(n, n, |r, c| {
            let extra = if r / order == c / order {
                blocks[(r / order) * order * order + (r % order) * order + c % order][j]
            } else {
                0.0
            };
            a.get(r, c) + extra
        });
        let rhs = nalgebra::DVector::from_column_slice(rhs);
        dense.lu().solve(&rhs).unwrap().iter().copied().collect()
    }

    #[test]
    fn solves_match_a_dense_solve() {
        for (n, b, order) in [
            (10, 1, 1),
            (12, 2, 1),
            (9, 3, 1),
            (20, 5, 2),
            (24, 7, 2),
            (24, 4, 2),
        ] {
            let own: Vec<SymmetricBand> = (0..LANES).map(|s| band(n, b, s % 3)).collect();
            let blocks = blocks(n, order);
            for shared in [false, true] {
                let bases = std::array::from_fn(|j| &own[if shared { 0 } else { j }]);
                let mut batch = BandLdlBatch::new(n, b);
                batch.factor(bases, &blocks, order).unwrap();
                for (j, base) in bases.iter().enumerate() {
                    let rhs: Vec<f64> = (0..n).map(|i| ((i * 3 + j) % 7) as f64 - 3.0).collect();
                    let expected = dense_solve(base, &blocks, j, order, &rhs);
                    let mut x = rhs.clone();
                    batch.solve_in_place(j, &mut x);
                    for (u, v) in x.iter().zip(&expected) {
                        assert!((u - v).abs() < 1e-12, "n {n} b {b}: {u} vs {v}");
                    }
                }
            }
        }
    }

    #[test]
    fn a_lane_does_not_depend_on_the_others() {
        let own: Vec<SymmetricBand> = (0..LANES).map(|s| band(16, 2, s)).collect();
        let blocks = blocks(16, 1);
        let mut batch = BandLdlBatch::new(16, 2);
        batch
            .factor(std::array::from_fn(|j| &own[j]), &blocks, 1)
            .unwrap();
        for j in 0..LANES {
            let alone: Vec<Lanes> = blocks.iter().map(|e| [e[j]; LANES]).collect();
            let mut single = BandLdlBatch::new(16, 2);
            single.factor([&own[j]; LANES], &alone, 1).unwrap();
            let (mut x, mut y) = (vec![1.0; 16], vec![1.0; 16]);
            batch.solve_in_place(j, &mut x);
            single.solve_in_place(0, &mut y);
            assert_eq!(x, y);
        }
    }

    use crate::simd::Plain;

    #[test]
    fn fused_plain_and_dynamic_solves_agree() {
        let base = band(40, 2, 1);
        let blocks = blocks(40, 1);
        let mut batch = BandLdlBatch::new(40, 2);
        batch.factor([&base; LANES], &blocks, 1).unwrap();
        let rhs: Vec<f64> = (0..40).map(|i| (i as f64).sin()).collect();
        let mut plain = rhs.clone();
        batch.solve_with::<Plain>(3, &mut plain);
        let mut dynamic = rhs.clone();
        batch.solve_dynamic::<Plain>(3, &mut dynamic);
        assert_eq!(plain, dynamic);
        let mut x = rhs;
        batch.solve_in_place(3, &mut x);
        for (u, v) in x.iter().zip(&plain) {
            assert!((u - v).abs() < 1e-13);
        }
    }

    #[test]
    fn indefinite_and_misshapen_are_errors() {
        let mut a = SymmetricBand::zeros(4, 1);
        for i in 0..4 {
            a.add(i, i, 1.0);
        }
        a.add(2, 1, 3.0);
        let zero = vec![[0.0; LANES]; 4];
        let mut batch = BandLdlBatch::new(4, 1);
        assert!(batch.factor([&a; LANES], &zero, 1).is_err());
        assert!(batch.factor([&a; LANES], &zero[..3], 1).is_err());
        assert!(batch.factor([&a; LANES], &zero, 0).is_err());
    }
}
