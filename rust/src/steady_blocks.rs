//! Block substitutions over the steady interior of a band Cholesky factor (the row systems
//! of the quasi-optimal row filter, SPEC §2.3 generalised, once its model has settled).
//!
//! Over the interior made exactly periodic by `steady_band::snap_interior`, L is block
//! Toeplitz with G × G blocks (G a multiple of the period: G = n, the state order, for the
//! n = 3, 4 filters): the diagonal block C and the sub-diagonal blocks L_k, k = 1..K,
//! K = ⌈B/G⌉, or one less when the farthest is zero (A block banded, as the row filters'
//! systems are). Each substitution is then a recursion on G-vectors:
//!
//!   forward   y_c = C⁻¹ x_c − Σ_k (C⁻¹ L_k) y_{c−k},
//!   backward  u_c = C⁻ᵀ y_c − Σ_k (C⁻ᵀ L_kᵀ) u_{c+k},
//!
//! each product a few vector multiply-adds (one AVX2 vector per block column). Unlike the
//! segmented solves of `steady_band`, nothing is corrected afterwards: those redo about B
//! multiply-adds per position to correct the start of each segment, which doubles the work
//! of the wide bands (B = 11, 19). The blocks serve the wide bands only (see
//! [`block_size`]): (2,2) in blocks of four positions ran at 93 Mpixel/s causal against 140
//! by segments (with two blocks per step too). Each step solves two blocks, the second by a
//! look-ahead from the same blocks as the first (see [`recursion`]): one block per step was
//! bound by the latency of its chain through the newest block. What else was tried, and
//! what it measured: README, "Block solves". The (4,4) factors reach their steady interior
//! only through the 1e-8 snap of `steady_band`. The positions before and after the block
//! interior are substituted one at a time with the factor's own coefficients.

use std::ops::Range;

use nalgebra::DMatrix;

use crate::banded::{band_index, Arith};
use crate::four_lanes::FourLanes;
use crate::steady_band::Snap;

/// One column of a G × G block, or one block of x (entries G.. zero).
pub(crate) type Column = [f64; 4];
/// A G × G block by columns (columns G.. zero).
type Block = [Column; 4];

/// The fewest blocks the interior must span to be solved by blocks.
const MIN_BLOCKS: usize = 16;

/// The block size of a bandwidth solved by blocks: the wide bands of the n = 3 and n = 4
/// row filters (B = 11, 19); None for the others, solved faster by segments.
pub(crate) fn block_size(b: usize) -> Option<usize> {
    match b {
        11 => Some(3),
        19 => Some(4),
        _ => None,
    }
}

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
        // the farthest block is zero when A is block banded (the row filters): left out
        if blocks.last().is_some_and(|m| m.iter().all(|&v| v == 0.0)) {
            blocks.pop();
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

    /// The length of the padded copy of x the substitutions run on: the blocks of
    /// [start − K·G, end + K·G), one vector each.
    pub(crate) fn padded_len(&self) -> usize {
        (self.end - self.start) / self.size + 2 * self.reach()
    }

    /// The positions of x held by the padded blocks `blocks` (see [`Self::padded_len`]).
    fn positions(&self, blocks: Range<usize>) -> Range<usize> {
        let first = self.start - self.reach() * self.size;
        first + blocks.start * self.size..first + blocks.end * self.size
    }

    /// The padded blocks of the interior.
    pub(crate) fn interior(&self) -> Range<usize> {
        self.reach()..self.padded_len() - self.reach()
    }

    /// The last padded blocks of the interior that hold its last b positions (the window
    /// of the one-position substitution after it).
    pub(crate) fn last(&self, b: usize) -> Range<usize> {
        let interior = self.interior();
        interior.end - b.div_ceil(self.size)..interior.end
    }

    /// The K padded blocks before the interior (the forward recursion's start).
    pub(crate) fn before(&self) -> Range<usize> {
        0..self.reach()
    }

    /// The K padded blocks after the interior (the backward recursion's start).
    pub(crate) fn after(&self) -> Range<usize> {
        self.padded_len() - self.reach()..self.padded_len()
    }

    /// Copies x into the padded blocks `blocks`.
    #[inline(always)]
    pub(crate) fn gather(&self, x: &[f64], padded: &mut [Column], blocks: Range<usize>) {
        let from = &x[self.positions(blocks.clone())];
        let to = &mut padded[blocks];
        match self.size {
            3 => gather_blocks::<3>(from, to),
            4 => gather_blocks::<4>(from, to),
            _ => unreachable!("blocks of 3 or 4"),
        }
    }

    /// Copies the padded blocks `blocks` back to x.
    #[inline(always)]
    pub(crate) fn scatter(&self, padded: &[Column], x: &mut [f64], blocks: Range<usize>) {
        let to = &mut x[self.positions(blocks.clone())];
        let from = &padded[blocks];
        match self.size {
            3 => scatter_blocks::<3>(from, to),
            4 => scatter_blocks::<4>(from, to),
            _ => unreachable!("blocks of 3 or 4"),
        }
    }

    /// One substitution over the interior of `padded` (see [`Self::padded_len`]): forward
    /// from the K blocks before it, or backward from the K blocks after it, in the vectors
    /// of `A` (AVX2 registers for `Fused`).
    #[inline(always)]
    pub(crate) fn substitute<A: Arith>(&self, padded: &mut [Column], backward: bool) {
        assert!(padded.len() == self.padded_len());
        macro_rules! run {
            ($g:literal, $k:literal) => {
                // SAFETY: `A::FourLanes` needs AVX2 and FMA only for `Fused`, which is
                // instantiated only inside `BandCholesky::solve_fused` (run on CPUs that
                // have them).
                unsafe {
                    if backward {
                        recursion::<A::FourLanes, $g, $k, true>(&self.backward, padded)
                    } else {
                        recursion::<A::FourLanes, $g, $k, false>(&self.forward, padded)
                    }
                }
            };
        }
        match (self.size, self.reach()) {
            (3, 3) => run!(3, 3),
            (3, 4) => run!(3, 4),
            (4, 4) => run!(4, 4),
            (4, 5) => run!(4, 5),
            _ => unreachable!("blocks of 3 (B = 11) or 4 (B = 19) reach ⌈B/G⌉ or one less"),
        }
    }
}

/// x (whole blocks of G) into padded blocks, the lanes from G on zero.
#[inline(always)]
fn gather_blocks<const G: usize>(x: &[f64], padded: &mut [Column]) {
    for (block, v) in padded.iter_mut().zip(x.chunks_exact(G)) {
        *block = std::array::from_fn(|p| if p < G { v[p] } else { 0.0 });
    }
}

/// Padded blocks back to x (whole blocks of G).
#[inline(always)]
fn scatter_blocks<const G: usize>(padded: &[Column], x: &mut [f64]) {
    for (block, v) in padded.iter().zip(x.chunks_exact_mut(G)) {
        v.copy_from_slice(&block[..G]);
    }
}

/// The matrices of a [`BlockSteps`] as vectors, one per column.
struct Loaded<V, const K: usize> {
    scale: [V; 4],
    terms: [[V; 4]; K],
    ahead: [V; 4],
    paired: [[V; 4]; K],
}

/// The recursion of one substitution over the padded blocks K.. len − K, backward when
/// `REV`, two blocks per step: block j from the K blocks before it, and block j ± 1 from
/// the same blocks (the look-ahead of [`BlockSteps`]), so that the two multiply-add chains
/// of a step are independent and each waits on the previous step only through its last
/// few products. One block at a time, the chain through the newest block made every step
/// wait ~17 cycles (Zen 4) for 12 multiply-adds (B = 11). The last K blocks are carried in
/// registers, their lanes broadcast by shuffles: broadcasting the older ones from the
/// stored blocks instead ran ~40 % slower (B = 11).
///
/// # Safety
/// The CPU has the instructions of `V` (see [`FourLanes`]).
#[inline(always)]
unsafe fn recursion<V: FourLanes, const G: usize, const K: usize, const REV: bool>(
    steps: &BlockSteps,
    padded: &mut [Column],
) {
    let len = padded.len();
    assert!(len >= 2 * K && K >= 2 && steps.terms.len() == K);
    let m = Loaded::<V, K> {
        scale: load_block(&steps.scale),
        terms: std::array::from_fn(|k| load_block(&steps.terms[k])),
        ahead: load_block(&steps.ahead),
        paired: std::array::from_fn(|k| load_block(&steps.paired[k])),
    };
    // padded block of the recursion's i-th block
    let at = |i: usize| if REV { len - 1 - i } else { i };
    // the last K blocks, newest first
    let mut recent: [V; K] = std::array::from_fn(|k| V::load(&padded[at(K - 1 - k)]));
    let mut i = K;
    while i + 1 < len - K {
        let (first, second) = pair::<V, G, K>(&m, [&padded[at(i)], &padded[at(i + 1)]], &recent);
        first.store(&mut padded[at(i)]);
        second.store(&mut padded[at(i + 1)]);
        let mut next = [second; K];
        next[1] = first;
        next[2..].copy_from_slice(&recent[..K - 2]);
        recent = next;
        i += 2;
    }
    if i < len - K {
        single::<V, G, K>(&m, &padded[at(i)], &recent).store(&mut padded[at(i)]);
    }
}

/// Blocks i and i + 1 of a [`recursion`] (in its order) from x_i, x_{i+1} and the K blocks
/// before block i (newest first). The older blocks' products are accumulated first; each
/// block's product by the newest block is a chain of its own, subtracted last.
#[inline(always)]
#[allow(clippy::needless_range_loop)] // as `product_of_splats`
unsafe fn pair<V: FourLanes, const G: usize, const K: usize>(
    m: &Loaded<V, K>,
    [x, x_next]: [&Column; 2],
    recent: &[V; K],
) -> (V, V) {
    let mut first = product_of_splats::<V, G>(&m.scale, x);
    let mut second = product_of_splats::<V, G>(&m.scale, x_next);
    for q in 0..G {
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
unsafe fn single<V: FourLanes, const G: usize, const K: usize>(
    m: &Loaded<V, K>,
    x: &Column,
    recent: &[V; K],
) -> V {
    let mut acc = product_of_splats::<V, G>(&m.scale, x);
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
/// As [`FourLanes::load`].
#[inline(always)]
unsafe fn load_block<V: FourLanes>(m: &Block) -> [V; 4] {
    [
        V::load(&m[0]),
        V::load(&m[1]),
        V::load(&m[2]),
        V::load(&m[3]),
    ]
}

/// m x, x from memory (its lanes broadcast by loads).
#[inline(always)]
#[allow(clippy::needless_range_loop)] // iterator adapters (`skip`) were not unrolled: 3.7x slower
unsafe fn product_of_splats<V: FourLanes, const G: usize>(m: &[V; 4], x: &Column) -> V {
    let mut acc = V::mul(m[0], V::splat(&x[0]));
    for q in 1..G {
        acc = V::add_product(acc, m[q], V::splat(&x[q]));
    }
    acc
}

/// m v, v in a register (its lanes broadcast by shuffles).
#[inline(always)]
#[allow(clippy::needless_range_loop)] // as `product_of_splats`
fn product<V: FourLanes, const G: usize>(m: &[V; 4], v: V) -> V {
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
    use crate::banded::{fused_available, Fused, Plain};
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

    /// Block j = S x_j − Σ_k T_k (block j ∓ k), one block at a time.
    fn one_at_a_time(steps: &BlockSteps, g: usize, padded: &mut [Column], backward: bool) {
        let (len, reach) = (padded.len(), steps.terms.len());
        let at = |i: usize| if backward { len - 1 - i } else { i };
        let times = |m: &Block, v: &Column| -> Column {
            std::array::from_fn(|p| (0..g).map(|q| m[q][p] * v[q]).sum())
        };
        for i in reach..len - reach {
            let mut block = times(&steps.scale, &padded[at(i)]);
            for (k, term) in steps.terms.iter().enumerate() {
                let product = times(term, &padded[at(i - 1 - k)]);
                block = std::array::from_fn(|p| block[p] - product[p]);
            }
            padded[at(i)] = block;
        }
    }

    #[target_feature(enable = "fma,avx2")]
    unsafe fn substitute_fused(plan: &SteadyBlocks, padded: &mut [Column], backward: bool) {
        plan.substitute::<Fused>(padded, backward)
    }

    #[test]
    fn the_look_ahead_recursion_matches_one_block_at_a_time() {
        // even and odd interior counts (the last block of an odd count is solved alone),
        // both directions, plain and fused arithmetic
        for (g, reach) in [(3usize, 3usize), (3, 4), (4, 4), (4, 5)] {
            for count in [20usize, 21] {
                let plan = random_plan(g, reach, count, (g * 10 + reach + count) as u64);
                assert_eq!(plan.padded_len(), count + 2 * reach);
                let x: Vec<Column> = (0..plan.padded_len())
                    .map(|i| {
                        std::array::from_fn(|p| {
                            if p < g {
                                (i as f64 + p as f64).sin()
                            } else {
                                0.0
                            }
                        })
                    })
                    .collect();
                for backward in [false, true] {
                    let steps = if backward {
                        &plan.backward
                    } else {
                        &plan.forward
                    };
                    let mut expected = x.clone();
                    one_at_a_time(steps, g, &mut expected, backward);
                    let scale = expected
                        .iter()
                        .flatten()
                        .fold(0.0f64, |m, v| m.max(v.abs()));
                    let mut plain = x.clone();
                    plan.substitute::<Plain>(&mut plain, backward);
                    let mut results = vec![plain];
                    if fused_available() {
                        let mut fused = x.clone();
                        // SAFETY: the CPU has FMA and AVX2.
                        unsafe { substitute_fused(&plan, &mut fused, backward) };
                        results.push(fused);
                    }
                    for result in results {
                        let most = result
                            .iter()
                            .flatten()
                            .zip(expected.iter().flatten())
                            .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
                        assert!(most < 1e-13 * scale, "g {g} K {reach} n {count}: {most:e}");
                        // the lanes from G on stay zero
                        assert!(result.iter().all(|c| c[g..].iter().all(|&v| v == 0.0)));
                    }
                }
            }
        }
    }
}
