//! Block substitutions over the steady interior of a band Cholesky factor (the row systems
//! of the quasi-optimal row filter, SPEC §2.3 generalised, once its model has settled).
//!
//! Over the interior made exactly periodic by `steady_band::snap_interior`, L is block
//! Toeplitz with G × G blocks (G a multiple of the period: G = n, the state order, for the
//! n = 3, 4 filters, G = 4 for n = 2): the diagonal block C and the sub-diagonal blocks
//! L_k, k = 1..K, K = ⌈B/G⌉, or fewer when the farthest are zero (A block banded, as the
//! row filters' systems are, and the more so when the band is stored padded; K = m for
//! G = n). Each substitution is then a recursion on G-vectors:
//!
//!   forward   y_c = C⁻¹ x_c − Σ_k (C⁻¹ L_k) y_{c−k},
//!   backward  u_c = C⁻ᵀ y_c − Σ_k (C⁻ᵀ L_kᵀ) u_{c+k},
//!
//! each product a few vector multiply-adds (one AVX2 vector per block column). Unlike the
//! partitioned solves of `steady_band`, nothing is corrected afterwards: those redo about B
//! multiply-adds per position to correct the start of each part, which doubles the work
//! of the wide bands (B = 11, 19). The blocks serve the n_y = 3, 4 filters (every n_x,
//! K = m = 2…4) and the n_y = 2 ones with m ≥ 4 (see [`block_size`]; (2,2) is faster by
//! parts). Each step solves two blocks, the second by a look-ahead from the same blocks as
//! the first (see [`recursion`]): one block per step was bound by the latency of its chain
//! through the newest block. What else was tried: the design notes, "Block solves". The
//! (4,4) factors reach their steady
//! interior only through the 1e-8 snap of `steady_band`. The positions before and after
//! the block interior are substituted one at a time with the factor's own coefficients.

use std::ops::Range;

use nalgebra::DMatrix;

use super::band::band_index;
use super::steady_band::Snap;
use crate::simd::{block, block_mut, Arith, F64x4};

/// What a solve knows of its right-hand side (see
/// [`BandCholesky::solve_observed_in_place`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Rhs {
    /// Any entries.
    Dense,
    /// Zero outside the first position of every block of the block plan.
    FirstOfBlock,
}

/// One column of a G × G block, or one block of x (entries G.. zero).
pub(crate) type Column = [f64; 4];
/// A G × G block by columns (columns G.. zero).
type Block = [Column; 4];

/// The fewest blocks the interior must span to be solved by blocks.
const MIN_BLOCKS: usize = 16;

/// The block size G of a factor of bandwidth b whose interior repeats with `period`, if it
/// is solved by blocks: G = the period when it is 3 or 4 (the n = 3, 4 row filters, every
/// AR order m ≥ 2 along the row: B = n(m + 1) − 1, stored padded to a fixed bandwidth, see
/// `cholesky`), G = 4 for period 2 beyond B = 7 (the n = 2 filters with m ≥ 4: (2,4) ran
/// 1.55× faster than by parts; with m = 3, B = 7, no faster), or the old rule for the
/// wide fixed bands (B = 11 in blocks of 3, B = 19 in blocks of 4) when the period divides
/// it. The narrower bands are solved faster by parts.
pub(crate) fn block_size(period: usize, b: usize) -> Option<usize> {
    if period == 3 || period == 4 {
        return Some(period);
    }
    if period == 2 && b > 7 {
        return Some(4);
    }
    [(11, 3), (19, 4)]
        .into_iter()
        .find(|&(band, g)| band == b && g % period == 0)
        .map(|(_, g)| g)
}

/// The (G, K) the recursions are compiled for: blocks of 3 and 4, K = 2…4 blocks per
/// step (m = K for the block-banded row systems), and (4, 5) for a full band B = 19.
const COMPILED: [(usize, usize); 7] = [(3, 2), (3, 3), (3, 4), (4, 2), (4, 3), (4, 4), (4, 5)];

/// The plan of a block solve over the positions [start, end) (whole blocks).
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct SteadyBlocks {
    /// G.
    size: usize,
    pub(crate) start: usize,
    pub(crate) end: usize,
    forward: BlockSteps,
    backward: BlockSteps,
}

/// One substitution of a [`SteadyBlocks`] solve: block j = S x_j − Σ_k T_k (block j ∓ k),
/// and for the look-ahead (see [`recursion`]) the blocks of block j ± 1 from the blocks
/// before block j: block j ± 1 = S x_{j±1} − (T_1 S) x_j − Σ_k U_k (block j ∓ k),
/// U_k = T_{k+1} − T_1 T_k (T_{K+1} = 0).
#[derive(Debug, Clone, PartialEq)]
struct BlockSteps {
    /// S: C⁻¹ (forward) or C⁻ᵀ (backward).
    scale: Block,
    /// Per k = 1..=K, T_k: C⁻¹ L_k (forward) or C⁻ᵀ L_kᵀ (backward).
    terms: Vec<Block>,
    /// T_1 S.
    ahead: Block,
    /// Per k = 1..=K: U_k.
    paired: Vec<Block>,
}

impl BlockSteps {
    /// The steps of scale S and terms T_k (k = 1..=K).
    fn new(scale: DMatrix<f64>, terms: Vec<DMatrix<f64>>) -> BlockSteps {
        let first = &terms[0];
        let paired = (0..terms.len())
            .map(|k| {
                let product = first * &terms[k];
                columns(&match terms.get(k + 1) {
                    Some(next) => next - product,
                    None => -product,
                })
            })
            .collect();
        BlockSteps {
            ahead: columns(&(first * &scale)),
            scale: columns(&scale),
            terms: terms.iter().map(columns).collect(),
            paired,
        }
    }
}

impl SteadyBlocks {
    /// The block plan of the factor `l` (order n, bandwidth b, rows of b + 1 entries, see
    /// `SymmetricBand`) in blocks of g positions, if the rows `snap` made exactly periodic
    /// have a period dividing g and span at least [`MIN_BLOCKS`] blocks clear of the ends.
    pub(crate) fn new(
        l: &[f64],
        n: usize,
        b: usize,
        g: usize,
        snap: &Snap,
    ) -> Option<SteadyBlocks> {
        if g % snap.period != 0 {
            return None;
        }
        let reach = b.div_ceil(g);
        let start = snap.rows.start.div_ceil(g).max(reach) * g;
        let end = (snap.rows.end / g).min((n / g).saturating_sub(reach)) * g;
        if end < start + MIN_BLOCKS * g {
            return None;
        }
        // block k of the interior's block row: L[start + p, start + q − k·g], p, q < g
        let block = |k: usize| {
            DMatrix::from_fn(g, g, |p, q| {
                // (start ≥ K·g: no column before the first)
                let (i, j) = (start + p, start + q - k * g);
                if j <= i && i - j <= b {
                    l[band_index(b, i, j)]
                } else {
                    0.0
                }
            })
        };
        let inverse = block(0).solve_lower_triangular(&DMatrix::identity(g, g))?;
        let mut blocks: Vec<DMatrix<f64>> = (1..=reach).map(block).collect();
        // the farthest blocks are zero when A is block banded (the row filters; more than
        // one when the band is stored padded): left out
        while blocks.last().is_some_and(|m| m.iter().all(|&v| v == 0.0)) {
            blocks.pop();
        }
        if !COMPILED.contains(&(g, blocks.len())) {
            return None;
        }
        let forward = BlockSteps::new(
            inverse.clone(),
            blocks.iter().map(|m| &inverse * m).collect(),
        );
        // C⁻ᵀ L_kᵀ = (L_k C⁻¹)ᵀ
        let backward = BlockSteps::new(
            inverse.transpose(),
            blocks.iter().map(|m| (m * &inverse).transpose()).collect(),
        );
        Some(SteadyBlocks {
            size: g,
            start,
            end,
            forward,
            backward,
        })
    }

    /// Blocks per step of the recursions (K).
    pub(crate) fn reach(&self) -> usize {
        self.forward.terms.len()
    }

    /// The positions the recursions read and write: the interior [start, end) and the K
    /// blocks on either side of it, from which the forward and backward recursions start.
    pub(crate) fn span(&self) -> Range<usize> {
        let reach = self.reach() * self.size;
        self.start - reach..self.end + reach
    }

    /// G, the block size.
    pub(crate) fn size(&self) -> usize {
        self.size
    }

    /// One substitution of x over the interior, in place: forward from the K blocks before
    /// it, or backward from the K blocks after it (x holds them solved), in the vectors of
    /// `A` (AVX2 registers for `Fused`). `rhs`: what x holds over the interior (the
    /// backward substitution's is the forward one's dense result).
    #[inline(always)]
    pub(crate) fn substitute<A: Arith>(&self, x: &mut [f64], backward: bool, rhs: Rhs) {
        let x = &mut x[self.span()];
        macro_rules! run {
            ($g:literal, $k:literal) => {
                // SAFETY: `A::Vector` needs AVX2 and FMA only for `Fused`, which is
                // instantiated only inside `simd::dispatch`'s FMA build (run on CPUs that
                // have them).
                unsafe {
                    match (backward, rhs) {
                        (true, _) => recursion::<A::Vector, $g, $k, $g, true>(&self.backward, x),
                        (false, Rhs::Dense) => {
                            recursion::<A::Vector, $g, $k, $g, false>(&self.forward, x)
                        }
                        (false, Rhs::FirstOfBlock) => {
                            recursion::<A::Vector, $g, $k, 1, false>(&self.forward, x)
                        }
                    }
                }
            };
        }
        match (self.size, self.reach()) {
            (3, 2) => run!(3, 2),
            (3, 3) => run!(3, 3),
            (3, 4) => run!(3, 4),
            (4, 2) => run!(4, 2),
            (4, 3) => run!(4, 3),
            (4, 4) => run!(4, 4),
            (4, 5) => run!(4, 5),
            _ => unreachable!("`new` plans only the COMPILED (G, K)"),
        }
    }
}

/// The matrices of a [`BlockSteps`] as vectors, one per column.
struct Loaded<V, const K: usize> {
    scale: [V; 4],
    terms: [[V; 4]; K],
    ahead: [V; 4],
    paired: [[V; 4]; K],
}

/// The recursion of one substitution over x (whole blocks of G positions, the interior
/// and the K blocks on either side of it), in place: the blocks K.. len − K, backward when
/// `REV`, two per step: block j from the K blocks before it, and block j ± 1 from the
/// same blocks (the look-ahead of [`BlockSteps`]), so that the two multiply-add chains of
/// a step are independent and each waits on the previous step only through its last few
/// products. The last K blocks are carried in registers, their lanes broadcast by shuffles
/// (broadcast from the stored blocks: ~40 % slower at B = 11), and the blocks are read and
/// written in x itself, not copied to a padded vector.
///
/// # Safety
/// The CPU has the instructions of `V` (see [`F64x4`]).
#[inline(always)]
unsafe fn recursion<V: F64x4, const G: usize, const K: usize, const IN: usize, const REV: bool>(
    steps: &BlockSteps,
    x: &mut [f64],
) {
    let len = x.len() / G;
    assert!(x.len() == len * G && len >= 2 * K && K >= 2 && steps.terms.len() == K);
    let m = Loaded::<V, K> {
        scale: load_block(&steps.scale),
        terms: std::array::from_fn(|k| load_block(&steps.terms[k])),
        ahead: load_block(&steps.ahead),
        paired: std::array::from_fn(|k| load_block(&steps.paired[k])),
    };
    // first position of the recursion's i-th block
    let at = |i: usize| G * if REV { len - 1 - i } else { i };
    // the last K blocks, newest first
    let mut recent: [V; K] = std::array::from_fn(|k| {
        let block = block::<G>(x, at(K - 1 - k));
        V::load(&std::array::from_fn(|p| if p < G { block[p] } else { 0.0 }))
    });
    let mut i = K;
    while i + 1 < len - K {
        let (first, second) =
            pair::<V, G, K, IN>(&m, [block(x, at(i)), block(x, at(i + 1))], &recent);
        first.store_lanes::<G>(block_mut(x, at(i)));
        second.store_lanes::<G>(block_mut(x, at(i + 1)));
        let mut next = [second; K];
        next[1] = first;
        next[2..].copy_from_slice(&recent[..K - 2]);
        recent = next;
        i += 2;
    }
    if i < len - K {
        single::<V, G, K, IN>(&m, block(x, at(i)), &recent).store_lanes::<G>(block_mut(x, at(i)));
    }
}

/// Blocks i and i + 1 of a [`recursion`] (in its order) from x_i, x_{i+1} and the K blocks
/// before block i (newest first). The older blocks' products are accumulated first; each
/// block's product by the newest block is a chain of its own, subtracted last.
#[inline(always)]
#[allow(clippy::needless_range_loop)] // as `product_of_splats`
unsafe fn pair<V: F64x4, const G: usize, const K: usize, const IN: usize>(
    m: &Loaded<V, K>,
    [x, x_next]: [&[f64; G]; 2],
    recent: &[V; K],
) -> (V, V) {
    let mut first = product_of_splats::<V, IN>(&m.scale, x);
    let mut second = product_of_splats::<V, IN>(&m.scale, x_next);
    for q in 0..IN {
        second = V::sub_product(second, m.ahead[q], V::splat(&x[q]));
    }
    for k in (1..K).rev() {
        if G == 4 {
            // each product its own short chain: shared by both chains, the 16 broadcasts
            // of a step spilled (B = 19 ran 1.3x slower)
            first = V::sub(first, product::<V, G>(&m.terms[k], recent[k]));
            second = V::sub(second, product::<V, G>(&m.paired[k], recent[k]));
            continue;
        }
        for q in 0..G {
            let w = recent[k].lane(q);
            first = V::sub_product(first, m.terms[k][q], w);
            second = V::sub_product(second, m.paired[k][q], w);
        }
    }
    (
        V::sub(first, product::<V, G>(&m.terms[0], recent[0])),
        V::sub(second, product::<V, G>(&m.paired[0], recent[0])),
    )
}

/// Block i of a [`recursion`] alone (the last of an odd count), newest block last.
#[inline(always)]
unsafe fn single<V: F64x4, const G: usize, const K: usize, const IN: usize>(
    m: &Loaded<V, K>,
    x: &[f64; G],
    recent: &[V; K],
) -> V {
    let mut acc = product_of_splats::<V, IN>(&m.scale, x);
    for k in (0..K).rev() {
        for q in 0..G {
            acc = V::sub_product(acc, m.terms[k][q], recent[k].lane(q));
        }
    }
    acc
}

/// The columns of a block as vectors.
///
/// # Safety
/// As [`F64x4::load`].
#[inline(always)]
unsafe fn load_block<V: F64x4>(m: &Block) -> [V; 4] {
    [
        V::load(&m[0]),
        V::load(&m[1]),
        V::load(&m[2]),
        V::load(&m[3]),
    ]
}

/// m x, x from memory (its lanes broadcast by loads), x zero from lane IN on.
#[inline(always)]
#[allow(clippy::needless_range_loop)] // iterator adapters (`skip`) were not unrolled: 3.7x slower
unsafe fn product_of_splats<V: F64x4, const IN: usize>(m: &[V; 4], x: &[f64]) -> V {
    let mut acc = V::mul(m[0], V::splat(&x[0]));
    for q in 1..IN {
        acc = V::add_product(acc, m[q], V::splat(&x[q]));
    }
    acc
}

/// m v, v in a register (its lanes broadcast by shuffles).
#[inline(always)]
#[allow(clippy::needless_range_loop)] // as `product_of_splats`
fn product<V: F64x4, const G: usize>(m: &[V; 4], v: V) -> V {
    let mut acc = V::mul(m[0], v.lane(0));
    for q in 1..G {
        acc = V::add_product(acc, m[q], v.lane(q));
    }
    acc
}

/// The columns of the g × g matrix m, each padded to four lanes (as are the columns from g
/// on).
fn columns(m: &DMatrix<f64>) -> Block {
    std::array::from_fn(|q| {
        std::array::from_fn(|p| {
            if p < m.nrows() && q < m.ncols() {
                m[(p, q)]
            } else {
                0.0
            }
        })
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::simd::{self, Kernel};
    use rand::{Rng, SeedableRng};
    use rand_xoshiro::Xoshiro256PlusPlus;

    /// A plan over `count` interior blocks with random steps of small norm.
    fn random_plan(g: usize, reach: usize, count: usize, seed: u64) -> SteadyBlocks {
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
        let mut steps = || {
            let mut random =
                |scale: f64| DMatrix::from_fn(g, g, |_, _| scale * (rng.random::<f64>() - 0.5));
            let scale = random(1.0);
            let terms = (0..reach).map(|_| random(0.5 / reach as f64)).collect();
            BlockSteps::new(scale, terms)
        };
        let (forward, backward) = (steps(), steps());
        let start = reach * g;
        SteadyBlocks {
            size: g,
            start,
            end: start + count * g,
            forward,
            backward,
        }
    }

    /// Block j = S x_j − Σ_k T_k (block j ∓ k), one block at a time (x whole blocks of g).
    fn one_at_a_time(steps: &BlockSteps, g: usize, x: &mut [f64], backward: bool) {
        let (len, reach) = (x.len() / g, steps.terms.len());
        let at = |i: usize| g * if backward { len - 1 - i } else { i };
        let times = |m: &Block, v: &[f64]| -> Vec<f64> {
            (0..g)
                .map(|p| (0..g).map(|q| m[q][p] * v[q]).sum())
                .collect()
        };
        for i in reach..len - reach {
            let mut block = times(&steps.scale, &x[at(i)..]);
            for (k, term) in steps.terms.iter().enumerate() {
                let product = times(term, &x[at(i - 1 - k)..]);
                block.iter_mut().zip(product).for_each(|(b, p)| *b -= p);
            }
            x[at(i)..at(i) + g].copy_from_slice(&block);
        }
    }

    /// One substitution of a plan, for `simd::dispatch`.
    struct Substitute<'a> {
        plan: &'a SteadyBlocks,
        x: &'a mut [f64],
        backward: bool,
        rhs: Rhs,
    }

    impl Kernel for Substitute<'_> {
        type Output = ();
        #[inline(always)]
        fn run<A: Arith>(self) {
            self.plan.substitute::<A>(self.x, self.backward, self.rhs)
        }
    }

    #[test]
    fn the_look_ahead_recursion_matches_one_block_at_a_time() {
        // even and odd interior counts (the last block of an odd count is solved alone),
        // both directions, plain and fused arithmetic, and forward with x zero outside the
        // first position of every block (`Rhs::FirstOfBlock`); the positions outside the
        // span (one after it) are left alone
        let cases = [
            (false, Rhs::Dense),
            (true, Rhs::Dense),
            (false, Rhs::FirstOfBlock),
        ];
        for (g, reach) in COMPILED {
            for count in [20usize, 21] {
                let plan = random_plan(g, reach, count, (g * 10 + reach + count) as u64);
                assert_eq!(plan.span(), 0..(count + 2 * reach) * g);
                let len = plan.span().end + 1;
                for (backward, rhs) in cases {
                    // (the blocks before the interior, the forward start, stay dense)
                    let sparse = |i: usize| rhs == Rhs::FirstOfBlock && i >= plan.start;
                    let x: Vec<f64> = (0..len)
                        .map(|i| {
                            if sparse(i) && i % g > 0 {
                                0.0
                            } else {
                                (i as f64).sin()
                            }
                        })
                        .collect();
                    let steps = if backward {
                        &plan.backward
                    } else {
                        &plan.forward
                    };
                    let mut expected = x.clone();
                    one_at_a_time(steps, g, &mut expected[plan.span()], backward);
                    let scale = expected.iter().fold(0.0f64, |m, v| m.max(v.abs()));
                    let substitute = |x: &mut [f64], fused: bool| {
                        let kernel = Substitute {
                            plan: &plan,
                            x,
                            backward,
                            rhs,
                        };
                        if fused {
                            simd::dispatch(kernel)
                        } else {
                            simd::run_plain(kernel)
                        }
                    };
                    let mut plain = x.clone();
                    substitute(&mut plain, false);
                    let mut results = vec![plain];
                    if simd::fused_available() {
                        let mut fused = x.clone();
                        substitute(&mut fused, true);
                        results.push(fused);
                    }
                    for result in results {
                        let most = result
                            .iter()
                            .zip(&expected)
                            .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
                        let case = format!("g {g} K {reach} n {count} {backward} {rhs:?}");
                        assert!(most < 1e-13 * scale, "{case}: {most:e}");
                        assert_eq!(result[len - 1], x[len - 1]);
                    }
                }
            }
        }
    }
}
