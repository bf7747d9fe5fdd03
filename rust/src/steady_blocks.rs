//! Block substitutions over the steady interior of a band Cholesky factor (the row systems
//! of the quasi-optimal row filter, SPEC §2.3 generalised, once its model has settled).
//!
//! Over the interior made exactly periodic by `steady_band::snap_interior`, L is block
//! Toeplitz with G × G blocks (G a multiple of the period: G = n, the state order, for the
//! n = 3, 4 filters): the diagonal block C and the sub-diagonal blocks L_k, k = 1..K,
//! K = ⌈B/G⌉, or one less when the farthest is zero (A block banded, as the row filters'
//! systems are). Each substitution is then a recursion on G-vectors, one block per step:
//!
//!   forward   y_c = C⁻¹ x_c − Σ_k (C⁻¹ L_k) y_{c−k},
//!   backward  u_c = C⁻ᵀ y_c − Σ_k (C⁻ᵀ L_kᵀ) u_{c+k},
//!
//! each product a few vector multiply-adds (one AVX2 vector per block column). Unlike the
//! segmented solves of `steady_band`, nothing is corrected afterwards: those redo about B
//! multiply-adds per position to correct the start of each segment, which doubles the work
//! of the wide bands (B = 11, 19). The blocks serve the wide bands only (see
//! [`block_size`]): (2,2) in blocks of four positions ran at 93 Mpixel/s causal against 140
//! by segments. What bounds the recursion is not settled (README, "Block solves"): each
//! step accumulates its products in one serial chain, newest block last; a build meant to
//! have no chain (the block K back instead of the newest) ran as fast, but it kept a chain
//! of K·G + G multiply-adds through block j − K, about the same latency per step. Two
//! chains side by side (the second half from zeros, corrected by the response to the first
//! half's end) ran slower; carrying the last K blocks in registers (no reload of a block
//! stored a few steps before) gained ~10 % for (3,3). Solving two blocks per step from the
//! blocks before them (one more block product per pair) did not pay: no faster for (3,3),
//! ~10 % for (4,4), within the noise of this machine. Nor did broadcasting each new block's
//! components once and carrying the broadcasts (G shuffles per step instead of K·G;
//! bit-identical results): (3,3) unchanged, (4,4) ~10 % slower (its 16 broadcast vectors
//! spill). The (4,4) factors reach their steady interior only through the 1e-8 snap of
//! `steady_band`. The positions before and after the block interior are substituted one at
//! a time with the factor's own coefficients.

use std::ops::Range;

use nalgebra::DMatrix;

use crate::banded::{band_index, Arith};
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

/// One substitution of a [`SteadyBlocks`] solve.
#[derive(Debug, Clone, PartialEq)]
struct BlockSteps {
    /// C⁻¹ (forward) or C⁻ᵀ (backward).
    scale: Block,
    /// Per k = 1..=K: C⁻¹ L_k (forward) or C⁻ᵀ L_kᵀ (backward).
    terms: Vec<Block>,
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
        // backward: C⁻ᵀ L_kᵀ = (L_k C⁻¹)ᵀ
        let forward = BlockSteps {
            terms: blocks.iter().map(|m| columns(&(&inverse * m))).collect(),
            scale: columns(&inverse),
        };
        let backward = BlockSteps {
            terms: blocks
                .iter()
                .map(|m| columns(&(m * &inverse).transpose()))
                .collect(),
            scale: columns(&inverse.transpose()),
        };
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
    /// from the K blocks before it, or backward from the K blocks after it.
    #[inline(always)]
    pub(crate) fn substitute<A: Arith>(&self, padded: &mut [Column], backward: bool) {
        assert!(padded.len() == self.padded_len());
        macro_rules! run {
            ($g:literal, $k:literal) => {
                if backward {
                    recursion::<A, $g, $k, true>(&self.backward, padded)
                } else {
                    recursion::<A, $g, $k, false>(&self.forward, padded)
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

/// The recursion of one substitution over the padded blocks K.. len − K: block j becomes
/// scale · block j − Σ_k terms_k · block (j ∓ k), backward when `REV`.
#[inline(always)]
fn recursion<A: Arith, const G: usize, const K: usize, const REV: bool>(
    steps: &BlockSteps,
    padded: &mut [Column],
) {
    let terms: &[Block; K] = steps.terms[..].try_into().unwrap();
    let len = padded.len();
    assert!(len >= 2 * K);
    // the last K blocks are carried in registers (newest first): no step reloads a block
    // it has just stored
    if REV {
        let mut recent: [Column; K] = std::array::from_fn(|k| padded[len - K + k]);
        for j in (K..len - K).rev() {
            recent = step::<A, G, K>(steps, terms, padded, j, &recent);
        }
    } else {
        let mut recent: [Column; K] = std::array::from_fn(|k| padded[K - 1 - k]);
        for j in K..len - K {
            recent = step::<A, G, K>(steps, terms, padded, j, &recent);
        }
    }
}

/// Block j of a [`recursion`] from the K blocks before it in the recursion's order (newest
/// first); returns them with block j in front (a function, not a closure: LLVM would not
/// inline a closure into the caller's target features).
#[inline(always)]
fn step<A: Arith, const G: usize, const K: usize>(
    steps: &BlockSteps,
    terms: &[Block; K],
    padded: &mut [Column],
    j: usize,
    recent: &[Column; K],
) -> [Column; K] {
    let mut acc = scaled::<A, G>(&steps.scale, &padded[j]);
    for k in (0..K).rev() {
        subtract::<A, G>(&mut acc, &terms[k], &recent[k]);
    }
    padded[j] = acc;
    let mut next = [acc; K];
    next[1..].copy_from_slice(&recent[..K - 1]);
    next
}

/// m v (m by columns), lane by lane.
#[inline(always)]
fn scaled<A: Arith, const G: usize>(m: &Block, v: &Column) -> Column {
    let mut acc = [0.0; 4];
    for (q, &vq) in v.iter().enumerate().take(G) {
        for (a, &c) in acc.iter_mut().zip(&m[q]) {
            *a = A::add_product(*a, c, vq);
        }
    }
    acc
}

/// acc −= m w (m by columns), lane by lane.
#[inline(always)]
fn subtract<A: Arith, const G: usize>(acc: &mut Column, m: &Block, w: &Column) {
    for (q, &wq) in w.iter().enumerate().take(G) {
        for (a, &c) in acc.iter_mut().zip(&m[q]) {
            *a = A::sub_product(*a, c, wq);
        }
    }
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
