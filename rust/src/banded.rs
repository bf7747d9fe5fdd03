//! Symmetric banded matrices and their Cholesky factors: the O(size · bandwidth) solves of
//! the quasi-optimal row filter (SPEC §2.3 generalised).

use crate::error::{FieldError, Result};
use crate::simd::{self, Arith, Kernel};
use crate::steady_band::{FactorCoefficients, Steady};
use crate::steady_blocks::{block_size, SteadyBlocks};
use std::ops::Range;

/// Runs `body` for r = 0, 1, …, B − 1 (B ≤ 11) written out, not as a loop (see
/// [`ring_group!`]).
macro_rules! unrolled {
    ($b:expr, |$r:ident| $body:block) => {
        unrolled!(@ $b, $r, $body, 0 1 2 3 4 5 6 7 8 9 10)
    };
    (@ $b:expr, $r:ident, $body:block, $($n:literal)*) => {{$(
        if $n < $b {
            let $r: usize = $n;
            $body
        }
    )*}};
}

/// One group of B steps of a substitution: `ring_group!(B, windows, |r, window| step)`
/// runs `step` for r = 0..B, each giving step r's result from the B results before it
/// (`window`, a [`Window`]); `windows` (a `&mut [T; B]`) holds the last B results, in order
/// (oldest first) before and after the group. A macro, not a function taking a closure:
/// LLVM would not inline the closure's B copies, and the ring would go through memory.
///
/// The narrow bands (B ≤ [`MAX_UNROLLED_RING`], or the limit given as a second argument:
/// [`MAX_UNROLLED_SCALAR_RING`] for single values) keep them in a ring: step r reads slot
/// (r + m) % B and overwrites slot r; written out, the slots are constants and the ring
/// stays in registers (shifting a window, or indexing it at run time, goes through
/// memory, and each step would wait on a store). The wider bands spill anyway: a loop over
/// a mirrored history (window r = history[r..r + B], no index arithmetic).
macro_rules! ring_group {
    ($b:expr, $windows:expr, |$r:ident, $window:ident| $step:block) => {
        ring_group!($b, MAX_UNROLLED_RING, $windows, |$r, $window| $step)
    };
    ($b:expr, $limit:expr, $windows:expr, |$r:ident, $window:ident| $step:block) => {{
        let windows = $windows;
        if $b <= $limit {
            unrolled!($b, |$r| {
                let y = {
                    let $window = Window::<_, $b>::Ring(windows, $r);
                    $step
                };
                windows[$r] = y;
            });
        } else {
            let mut history = [*windows; 2];
            let flat = history.as_flattened_mut();
            for $r in 0..$b {
                let y = {
                    let $window = Window::<_, $b>::Run(&flat[$r..$r + $b]);
                    $step
                };
                flat[$b + $r] = y;
            }
            *windows = history[1];
        }
    }};
}

/// A symmetric matrix with `bandwidth` sub-diagonals, lower band stored row by row:
/// entry (i, k), i - bandwidth ≤ k ≤ i, at `data[i * (bandwidth + 1) + k + bandwidth - i]`.
#[derive(Debug, Clone, PartialEq)]
pub struct SymmetricBand {
    size: usize,
    bandwidth: usize,
    data: Vec<f64>,
}

/// Where entry (i, k), i − b ≤ k ≤ i, of a lower band of bandwidth b is stored (rows of b + 1
/// entries, the diagonal last): the layout of [`SymmetricBand`] and of its Cholesky factor.
#[inline(always)]
pub(crate) fn band_index(b: usize, i: usize, k: usize) -> usize {
    i * (b + 1) + k + b - i
}

impl SymmetricBand {
    /// The zero matrix.
    pub fn zeros(size: usize, bandwidth: usize) -> Self {
        Self {
            size,
            bandwidth,
            data: vec![0.0; size * (bandwidth + 1)],
        }
    }

    /// Matrix order.
    pub fn size(&self) -> usize {
        self.size
    }

    #[inline(always)]
    fn index(&self, i: usize, k: usize) -> usize {
        band_index(self.bandwidth, i, k)
    }

    /// Adds `value` to entries (i, k) and (k, i); |i - k| must be within the band.
    pub fn add(&mut self, i: usize, k: usize, value: f64) {
        let (i, k) = if i >= k { (i, k) } else { (k, i) };
        debug_assert!(i - k <= self.bandwidth);
        let at = self.index(i, k);
        self.data[at] += value;
    }

    /// Row i of the lower band: entries (i, i − bandwidth..=i), the diagonal last (those
    /// before column 0 are padding).
    #[inline(always)]
    pub(crate) fn lower_row_mut(&mut self, i: usize) -> &mut [f64] {
        let width = self.bandwidth + 1;
        &mut self.data[i * width..(i + 1) * width]
    }

    /// Entry (i, k) of the lower band: i − bandwidth ≤ k ≤ i.
    #[inline(always)]
    pub(crate) fn lower_entry(&self, i: usize, k: usize) -> f64 {
        self.data[self.index(i, k)]
    }

    /// Bandwidth (number of sub-diagonals).
    pub fn bandwidth(&self) -> usize {
        self.bandwidth
    }

    /// Entry (i, k) (zero outside the band).
    pub fn get(&self, i: usize, k: usize) -> f64 {
        let (i, k) = if i >= k { (i, k) } else { (k, i) };
        if i - k > self.bandwidth {
            0.0
        } else {
            self.data[self.index(i, k)]
        }
    }

    /// self += other (same order and bandwidth).
    pub(crate) fn add_band(&mut self, other: &SymmetricBand) {
        debug_assert!(self.size == other.size && self.bandwidth == other.bandwidth);
        for (a, b) in self.data.iter_mut().zip(&other.data) {
            *a += b;
        }
    }

    /// y = A x.
    pub fn mul_vec(&self, x: &[f64], y: &mut [f64]) {
        let b = self.bandwidth;
        y.iter_mut().for_each(|v| *v = 0.0);
        for i in 0..self.size {
            let row = &self.data[i * (b + 1)..(i + 1) * (b + 1)];
            let first = i.saturating_sub(b);
            let mut acc = 0.0;
            for k in first..i {
                let a = row[k + b - i];
                acc += a * x[k];
                y[k] += a * x[i];
            }
            y[i] += acc + row[b] * x[i];
        }
    }

    /// The band's entries in the storage of bandwidth `b` ≥ its own (zeros beyond it).
    fn widened(&self, b: usize) -> Vec<f64> {
        let own = self.bandwidth;
        if b == own {
            return self.data.clone();
        }
        let mut data = vec![0.0; self.size * (b + 1)];
        for (i, row) in self.data.chunks_exact(own + 1).enumerate() {
            data[band_index(b, i, i) - own..=band_index(b, i, i)].copy_from_slice(row);
        }
        data
    }

    /// The entries of A⁻¹ within the band (`band_inverse`), from a plain factorisation (no
    /// solve plans: for one-off inverses).
    pub(crate) fn inverse_band(&self) -> Result<SymmetricBand> {
        let (n, b) = (self.size, self.bandwidth);
        let mut l = self.data.clone();
        factor_in_place(&mut l, n, b)?;
        Ok(SymmetricBand {
            size: n,
            bandwidth: b,
            data: crate::band_inverse::selected_inverse(&l, n, b),
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
    /// 19 gets the unrolled kernels; for the orders solved by segments, its interior rows
    /// are made exactly periodic (`steady_band`).
    pub fn cholesky(&self) -> Result<BandCholesky> {
        let (n, b) = (self.size, padded_bandwidth(self.bandwidth));
        let mut l = self.widened(b);
        factor_in_place(&mut l, n, b)?;
        let steady = FIXED_BANDS.contains(&b) && n >= MIN_SEGMENTED && segment_span(n, b) >= 2 * b;
        let snap = if steady {
            crate::steady_band::snap_interior(&mut l, n, b)
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
            segmented: None,
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
                factor.segment(b >= LANE_MAJOR_BANDS);
            }
        }
        Ok(factor)
    }
}

/// The smallest of [`FIXED_BANDS`] at least `b`, or `b` beyond them.
fn padded_bandwidth(b: usize) -> usize {
    FIXED_BANDS.into_iter().find(|&f| f >= b).unwrap_or(b)
}

/// Forward then backward substitution with the band factor `l` (1/L_ii in `inv`), no plan
/// (the bandwidths without an unrolled kernel).
fn substitute_plain(l: &[f64], inv: &[f64], b: usize, x: &mut [f64]) {
    let n = inv.len();
    for i in 0..n {
        let first = i.saturating_sub(b);
        let row = &l[band_index(b, i, first)..band_index(b, i, i)];
        let sum: f64 = row.iter().zip(&x[first..i]).map(|(a, v)| a * v).sum();
        x[i] = (x[i] - sum) * inv[i];
    }
    for i in (0..n).rev() {
        let mut acc = x[i];
        for j in (1..=b.min(n - 1 - i)).rev() {
            acc -= l[band_index(b, i + j, i)] * x[i + j];
        }
        x[i] = acc * inv[i];
    }
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

/// Lower Cholesky factor of a [`SymmetricBand`].
#[derive(Debug, Clone, PartialEq)]
pub struct BandCholesky {
    size: usize,
    bandwidth: usize,
    data: Vec<f64>,
    inverse_diagonal: Vec<f64>,
    forward: Vec<f64>,
    backward: Vec<f64>,
    segmented: Option<Segmented>,
    strided: Option<Strided>,
    steady: Option<Steady>,
    blocks: Option<SteadyBlocks>,
}

/// Segments solved at once by the segmented solves: their latency chains overlap, and one
/// step of all of them is a few vector operations.
pub(crate) const LANES: usize = 8;
/// One value per segment.
pub(crate) type Lanes = [f64; LANES];

/// The coefficients of the segmented steps and responses: one value per lane (`[Lanes]`),
/// or one value shared by every lane (`[f64]`: the steady interior of a factor, see
/// `steady_band`).
pub(crate) trait LaneCoefficients: std::ops::Index<Range<usize>, Output = Self> {
    /// Entry i for every lane.
    fn lanes(&self, i: usize) -> Lanes;
    /// Number of entries.
    fn count(&self) -> usize;
}

impl LaneCoefficients for [Lanes] {
    #[inline(always)]
    fn lanes(&self, i: usize) -> Lanes {
        self[i]
    }
    fn count(&self) -> usize {
        self.len()
    }
}

impl LaneCoefficients for [f64] {
    #[inline(always)]
    fn lanes(&self, i: usize) -> Lanes {
        [self[i]; LANES]
    }
    fn count(&self) -> usize {
        self.len()
    }
}

/// Smallest order solved by segments.
const MIN_SEGMENTED: usize = 16 * LANES;
/// The bandwidths with unrolled kernels: the row filters' default bands n(max(n, 2) + 1) − 1
/// (2, 5, 11, 19 for n = 1..4) and the narrow ones of other AR orders (1, 3, 7).
const FIXED_BANDS: [usize; 7] = [1, 2, 3, 5, 7, 11, 19];
/// The widest ring of [`ring_group!`] written out (held in registers).
const MAX_UNROLLED_RING: usize = 7;
/// The same for the one-position substitutions ([`substitute`]), whose results are single
/// values: their ring of B = 11 fits in the registers too. Through memory, each position's
/// 11 window loads besides the 11 coefficients' made the ends of the (3,3) rows ~1/3 of
/// its solves (~10.6 cycles per position); written out, the (3,3) filter ran 14 % faster.
const MAX_UNROLLED_SCALAR_RING: usize = 11;
/// Zero-input responses are cut once the recursion's state has decayed below this fraction
/// of its peak: what is dropped lies far below the rounding of the corrections.
const NEGLIGIBLE: f64 = 1e-20;
/// The smallest bandwidth whose segmented solves run on a lane-major copy of x
/// ([`Segmented`]); the narrower bands, with fewer operations per step, are faster solved
/// on x itself ([`Strided`]).
const LANE_MAJOR_BANDS: usize = 5;

/// The substitutions of a segmented solve: run on LANES segments at once, each started from
/// a zero window, then corrected with the zero-input responses to the exact window left by
/// the previous segment (the substitutions are linear recursions).
///
/// Both substitutions share one segmentation of x: its first LANES · span entries, segment
/// k at x[k · span..(k + 1) · span], held lane-major (`rows[j][k] = x[k · span + j]`, see
/// [`forward_steps`]) while the segments are solved, so that a step loads and stores one
/// vector. The remainder of the order (x[LANES · span..], < LANES · B entries) follows the
/// last segment in the forward substitution and leads the backward one.
#[derive(Debug, Clone, PartialEq)]
struct Segmented {
    /// Segment length.
    span: usize,
    forward: Direction,
    backward: Direction,
}

/// One substitution of a [`Segmented`] solve, in its own order of positions (position p is
/// x[p], or x[n − 1 − p] backward). Lane l of its vectors belongs to the segment stored at
/// x[l · span..(l + 1) · span]: its segment l forward, its segment LANES − 1 − l backward.
#[derive(Debug, Clone, PartialEq)]
struct Direction {
    /// Positions before the segments (solved exactly from a zero window): 0 forward, the
    /// remainder backward.
    lead: usize,
    /// Per step j (the j-th position of every segment): 1/L_ii, then the B coefficients,
    /// each for the LANES segments, so that a step reads contiguous vectors.
    steps: Vec<Lanes>,
    /// Per offset t into the segments and window slot q: each segment's response at t to a
    /// unit entry in slot q of its starting window; cut where every response has decayed.
    responses: Vec<Lanes>,
    /// Per segment k (in the direction's order), slot q and slot m: the response's window
    /// at the segment's end.
    ends: Vec<f64>,
}

impl Direction {
    /// This substitution for [`solve_by_segments`] (bandwidth b).
    fn data(&self, b: usize) -> SegmentData<'_, [Lanes]> {
        SegmentData {
            steps: &self.steps,
            responses: &self.responses,
            ends: &self.ends,
            ends_stride: b * b,
        }
    }

    fn new(f: &BandCholesky, coef: &[f64], reverse: bool) -> Direction {
        let (n, b) = (f.size, f.bandwidth);
        let span = segment_span(n, b);
        let lead = if reverse { n - LANES * span } else { 0 };
        let at = |p: usize| if reverse { n - 1 - p } else { p };
        // the segment (in this direction's order) of lane l
        let segment = |l: usize| if reverse { LANES - 1 - l } else { l };
        let position = |l: usize, j: usize| at(lead + segment(l) * span + j);
        let mut steps = Vec::with_capacity(span * (b + 1));
        for j in 0..span {
            steps.push(std::array::from_fn(|l| f.inverse_diagonal[position(l, j)]));
            for m in 0..b {
                steps.push(std::array::from_fn(|l| coef[position(l, j) * b + m]));
            }
        }
        // segment 0 starts from the exact window when nothing leads it: no response
        let mut h = vec![vec![vec![0.0; span]; b]; LANES];
        let mut ends = vec![0.0; LANES * b * b];
        let mut len = 0;
        for k in usize::from(lead == 0)..LANES {
            for q in 0..b {
                let positions = (lead + k * span..lead + (k + 1) * span).map(at);
                h[k][q] = zero_input_response(coef, b, q, positions);
                let end = &h[k][q][span - b..];
                ends[(k * b + q) * b..(k * b + q + 1) * b].copy_from_slice(end);
                len = len.max(decayed_len(&h[k][q], b));
            }
        }
        let responses = (0..len * b)
            .map(|i| std::array::from_fn(|l| h[segment(l)][i % b][i / b]))
            .collect();
        Direction {
            lead,
            steps,
            responses,
            ends,
        }
    }
}

/// The segmented solves of the narrower bands (below [`LANE_MAJOR_BANDS`]), directly on
/// x: LANES segments of span positions in each substitution's own order (forward x[k ·
/// span..], backward from x[n − 1 − k · span] down), the remainder after the last segment.
#[derive(Debug, Clone, PartialEq)]
struct Strided {
    /// Segment length.
    span: usize,
    forward: StridedDirection,
    backward: StridedDirection,
}

/// One substitution of a [`Strided`] solve, in its own order of positions.
#[derive(Debug, Clone, PartialEq)]
struct StridedDirection {
    /// Per step j: 1/L_ii, then the B coefficients, each for the LANES segments (position
    /// k · span + j for segment k), so that a step reads contiguous vectors.
    steps: Vec<Lanes>,
    /// Per segment k ≥ 1 and window slot q: the response over the segment to a unit entry
    /// in slot q of its starting window, cut where it has decayed.
    responses: Vec<Vec<f64>>,
    /// Per segment k ≥ 1, slot q and slot m: the response's window at the segment's end.
    ends: Vec<f64>,
}

impl StridedDirection {
    fn new(f: &BandCholesky, coef: &[f64], reverse: bool) -> StridedDirection {
        let (n, b) = (f.size, f.bandwidth);
        let span = segment_span(n, b);
        let at = |p: usize| if reverse { n - 1 - p } else { p };
        let mut steps = Vec::with_capacity(span * (b + 1));
        for j in 0..span {
            steps.push(std::array::from_fn(
                |k| f.inverse_diagonal[at(k * span + j)],
            ));
            for m in 0..b {
                steps.push(std::array::from_fn(|k| coef[at(k * span + j) * b + m]));
            }
        }
        let (mut responses, mut ends) = (Vec::new(), Vec::new());
        for k in 1..LANES {
            for q in 0..b {
                let positions = (k * span..(k + 1) * span).map(at);
                let h = zero_input_response(coef, b, q, positions);
                ends.extend_from_slice(&h[span - b..]);
                responses.push(decayed(h, b));
            }
        }
        StridedDirection {
            steps,
            responses,
            ends,
        }
    }
}

/// Segment length: a multiple of b (the main loop takes b steps at a time, see
/// [`lane_group`]).
fn segment_span(n: usize, b: usize) -> usize {
    n / LANES / b * b
}

/// The substitution's output at `positions` for a zero right-hand side, started from a
/// window with a unit entry in slot q.
pub(crate) fn zero_input_response(
    coef: &[f64],
    b: usize,
    q: usize,
    positions: impl Iterator<Item = usize>,
) -> Vec<f64> {
    let mut window = vec![0.0; b];
    window[q] = 1.0;
    positions
        .map(|i| {
            let y = -(0..b).fold(0.0, |acc, m| acc + coef[i * b + m] * window[m]);
            window.rotate_left(1);
            window[b - 1] = y;
            y
        })
        .collect()
}

/// The length of `h` up to where the recursion's state (its last b values) has become
/// negligible: the rest is a response to that state, as negligible (the factor is well
/// conditioned).
pub(crate) fn decayed_len(h: &[f64], b: usize) -> usize {
    let peak = h.iter().fold(1.0f64, |p, v| p.max(v.abs()));
    let small = |e: &usize| h[e - b..*e].iter().all(|v| v.abs() < NEGLIGIBLE * peak);
    (b..=h.len()).find(small).unwrap_or(h.len())
}

/// `h` cut at [`decayed_len`].
fn decayed(mut h: Vec<f64>, b: usize) -> Vec<f64> {
    h.truncate(decayed_len(&h, b));
    h
}

/// What a solve knows of its right-hand side (see
/// [`BandCholesky::solve_observed_in_place`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Rhs {
    /// Any entries.
    Dense,
    /// Zero outside the first position of every block of the block plan.
    FirstOfBlock,
}

thread_local! {
    /// The lane-major copy of x of the segmented solves, kept between calls.
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
            data: crate::band_inverse::selected_inverse(&self.data, self.size, self.bandwidth),
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

    /// Whether the solves use the steady interior (by segments or by blocks).
    #[cfg(test)]
    pub(crate) fn is_steady(&self) -> bool {
        self.steady.is_some() || self.blocks.is_some()
    }

    /// The solve without a plan (one substitution at a time), for the tests.
    #[cfg(test)]
    pub(crate) fn solve_unplanned(&self, x: &mut [f64]) {
        self.solve_dynamic(x)
    }

    /// Plans the segmented solves, on a lane-major copy of x or on x itself.
    fn segment(&mut self, lane_major: bool) {
        let span = segment_span(self.size, self.bandwidth);
        (self.segmented, self.strided) = if lane_major {
            let s = Segmented {
                span,
                forward: Direction::new(self, &self.forward, false),
                backward: Direction::new(self, &self.backward, true),
            };
            (Some(s), None)
        } else {
            let s = Strided {
                span,
                forward: StridedDirection::new(self, &self.forward, false),
                backward: StridedDirection::new(self, &self.backward, true),
            };
            (None, Some(s))
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
    /// chain of a banded solve is its cost); segmented for long orders.
    #[inline(always)]
    fn solve_fixed<A: Arith, const B: usize>(&self, x: &mut [f64], rhs: Rhs) {
        if let Some(blocks) = &self.blocks {
            return self.solve_blocks::<A, B>(x, blocks, rhs);
        }
        if let Some(s) = &self.strided {
            self.substitute_segmented::<A, B, false>(x, &self.forward, &s.forward, s.span);
            self.substitute_segmented::<A, B, true>(x, &self.backward, &s.backward, s.span);
            return;
        }
        let span = match (&self.segmented, &self.steady) {
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
            match (&self.segmented, &self.steady) {
                (Some(s), _) => self.solve_segmented::<A, B>(x, rows, s),
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

    /// The substitution on the LANES segments at once from zero windows, then the
    /// corrections, then the remainder from the exact window of the last segment.
    #[inline(always)]
    fn substitute_segmented<A: Arith, const B: usize, const REV: bool>(
        &self,
        x: &mut [f64],
        coef: &[f64],
        direction: &StridedDirection,
        span: usize,
    ) {
        let n = self.size;
        let at = |p: usize| if REV { n - 1 - p } else { p };
        assert!(LANES * span <= n && n == x.len() && direction.steps.len() == span * (B + 1));
        let mut windows = [[0.0; LANES]; B];
        for (t, group) in direction.steps.chunks_exact(B * (B + 1)).enumerate() {
            ring_group!(B, &mut windows, |r, window| {
                lane_step_in_place::<A, B, REV>(x, span, t * B, r, group, window)
            });
        }
        // span is a multiple of B: the ring is back in order, oldest first
        // segment 0 started from the exact (zero) window
        let mut entering = [0.0; B];
        for k in 1..LANES {
            entering = segment_end::<A, B>(&windows, direction, k - 1, &entering);
            for (q, h) in direction.responses[(k - 1) * B..k * B].iter().enumerate() {
                let start = at(k * span);
                if REV {
                    let seg = x[start + 1 - h.len()..=start].iter_mut().rev();
                    add_scaled::<A>(seg, h, entering[q]);
                } else {
                    add_scaled::<A>(x[start..start + h.len()].iter_mut(), h, entering[q]);
                }
            }
        }
        let mut last = segment_end::<A, B>(&windows, direction, LANES - 1, &entering);
        let inv = |i: usize| self.inverse_diagonal[i];
        substitute::<A, B, REV>(x, slots(coef), inv, LANES * span, n, &mut last);
    }

    /// Both substitutions by segments (see [`Segmented`]) on the lane-major copy `rows` of
    /// the segmented part of x (the first LANES · span entries: no lead).
    #[inline(always)]
    fn solve_segmented<A: Arith, const B: usize>(
        &self,
        x: &mut [f64],
        rows: &mut [Lanes],
        s: &Segmented,
    ) {
        let whole = LANES * s.span;
        assert!(s.forward.steps.len() == s.span * (B + 1) && s.forward.lead == 0);
        assert!(s.backward.steps.len() == s.span * (B + 1) && s.backward.lead == x.len() - whole);
        let (forward, backward) = (s.forward.data(B), s.backward.data(B));
        let per_lane = |t: usize| t * B * (B + 1);
        solve_by_segments::<A, B, [Lanes]>(
            &self.coefficients(),
            x,
            rows,
            0,
            forward,
            backward,
            per_lane,
        );
    }
}

/// One substitution of [`solve_by_segments`]: `steps` its coefficients (group t of B steps
/// from `steps[group(t)]`, 1/L_ii then the B coefficients per step), `responses` B per
/// offset into a segment, `ends` the B · B end windows of segment k's responses (in the
/// substitution's order) at `k · ends_stride` (0: one set shared by all segments).
pub(crate) struct SegmentData<'a, C: ?Sized> {
    pub(crate) steps: &'a C,
    pub(crate) responses: &'a C,
    pub(crate) ends: &'a [f64],
    pub(crate) ends_stride: usize,
}

/// Solves L Lᵀ x = rhs in place with the factor `f`: LANES segments of span = rows.len()
/// positions from x[start] solved at once on the lane-major `rows`, started from zero
/// windows and corrected with the responses; the positions before them (the lead) and
/// after them (the tail) one at a time, with the factor's own coefficients.
#[inline(always)]
pub(crate) fn solve_by_segments<A: Arith, const B: usize, C: LaneCoefficients + ?Sized>(
    f: &FactorCoefficients,
    x: &mut [f64],
    rows: &mut [Lanes],
    start: usize,
    forward: SegmentData<C>,
    backward: SegmentData<C>,
    group: impl Fn(usize) -> usize + Copy,
) {
    let (n, span) = (x.len(), rows.len());
    let end = start + LANES * span;
    assert!(end <= n && n == f.inverse_diagonal.len() && f.bandwidth == B);
    let inv = |i: usize| f.inverse_diagonal[i];
    // the B responses of each offset into a segment
    let offsets = |responses: &C| (0..responses.count() / B).map(|t| t * B..(t + 1) * B);
    // forward: the lead, the segments from zero windows, their corrections, the tail
    let mut window = [0.0; B];
    substitute::<A, B, false>(x, slots(f.forward), inv, 0, start, &mut window);
    let windows = forward_steps::<A, B, C>(&x[start..end], rows, forward.steps, group);
    let ends = |k: usize| &forward.ends[k * forward.ends_stride..][..B * B];
    let (entering, mut last) = entering_windows::<A, B, false>(&windows, ends, window);
    for (row, at) in rows.iter_mut().zip(offsets(forward.responses)) {
        add_responses::<A, B, C>(row, &forward.responses[at], &entering);
    }
    substitute::<A, B, false>(x, slots(f.forward), inv, end, n, &mut last);
    // backward: the tail, the segments and their corrections (written to x), the lead
    let mut window = [0.0; B];
    substitute::<A, B, true>(x, slots(f.backward), inv, 0, n - end, &mut window);
    let windows = lane_steps::<A, B, true, C>(rows, backward.steps, group);
    let ends = |k: usize| &backward.ends[k * backward.ends_stride..][..B * B];
    let (entering, mut last) = entering_windows::<A, B, true>(&windows, ends, window);
    // corrected in place first: fused with the scatter below, LLVM makes it scalar
    for (row, at) in rows.iter_mut().rev().zip(offsets(backward.responses)) {
        add_responses::<A, B, C>(row, &backward.responses[at], &entering);
    }
    let mut segments = x[start..end].chunks_exact_mut(span);
    let mut segments: [&mut [f64]; LANES] = std::array::from_fn(|_| segments.next().unwrap());
    for (j, row) in rows.iter().enumerate() {
        for (segment, &vk) in segments.iter_mut().zip(row) {
            segment[j] = vk;
        }
    }
    substitute::<A, B, true>(x, slots(f.backward), inv, n - start, n, &mut last);
}

/// One substitution over the positions [start, end) of its order (position p is x[p], or
/// x[n − 1 − p] when `REV`): y_p = x_p · scale(p's index) − Σ_m coef_p[m] y_{p−B+m},
/// `window` holding y_{p−B..p} (oldest first), `coef(i)` the B coefficients of x[i].
/// Shared by the Cholesky solves (scale 1/L_ii, pre-scaled coefficients) and the LDLᵀ
/// solves of `band_ldl` (scale 1, then 1/D_ii).
#[inline(always)]
pub(crate) fn substitute<A: Arith, const B: usize, const REV: bool>(
    x: &mut [f64],
    coef: impl Fn(usize) -> [f64; B],
    scale: impl Fn(usize) -> f64,
    start: usize,
    end: usize,
    window: &mut [f64; B],
) {
    let n = x.len();
    let index = |p: usize| if REV { n - 1 - p } else { p };
    // (a function, not a closure: LLVM would not inline a closure called from B + 2 places)
    #[inline(always)]
    fn step<A: Arith, const B: usize>(
        x: &mut f64,
        c: [f64; B],
        scale: f64,
        w: Window<f64, B>,
    ) -> f64 {
        let [y] = multiply_subtract::<A, B, 1>([*x * scale], |m| [c[m]], |m| [w.get(m)]);
        *x = y;
        y
    }
    let whole = start + (end - start) / B * B;
    let mut ring = *window;
    for group in (start..whole).step_by(B) {
        ring_group!(B, MAX_UNROLLED_SCALAR_RING, &mut ring, |r, window| {
            let i = index(group + r);
            step::<A, B>(&mut x[i], coef(i), scale(i), window)
        });
    }
    // back in order after whole groups; the rest one step at a time
    for p in whole..end {
        let i = index(p);
        let y = step::<A, B>(&mut x[i], coef(i), scale(i), Window::Ring(&ring, 0));
        ring.rotate_left(1);
        ring[B - 1] = y;
    }
    *window = ring;
}

/// The coefficients of x[i] in a substitution whose B per position are stored contiguously.
#[inline(always)]
pub(crate) fn slots<const B: usize>(coef: &[f64]) -> impl Fn(usize) -> [f64; B] + '_ {
    move |i| coef[i * B..(i + 1) * B].try_into().unwrap()
}

/// The forward steps of all segments from zero windows, reading the segments from x (at
/// x[k · span..(k + 1) · span], span = rows.len()) and writing them lane-major to rows
/// (`rows[j][k] = x[k · span + j]`); returns the windows at the segments' ends. The
/// coefficients of the t-th group of B steps start at `steps[group(t)]` (see
/// [`Direction::steps`]).
#[inline(always)]
pub(crate) fn forward_steps<A: Arith, const B: usize, C: LaneCoefficients + ?Sized>(
    x: &[f64],
    rows: &mut [Lanes],
    steps: &C,
    group: impl Fn(usize) -> usize,
) -> [Lanes; B] {
    let span = rows.len();
    assert!(x.len() == LANES * span && span % B == 0);
    let mut windows = [[0.0; LANES]; B];
    for (t, group_rows) in rows.chunks_exact_mut(B).enumerate() {
        let at = group(t);
        let c = &steps[at..at + B * (B + 1)];
        let group: &mut [Lanes; B] = group_rows.try_into().unwrap();
        ring_group!(B, &mut windows, |r, window| {
            let j = t * B + r;
            // SAFETY: k < LANES and j < span (the group is within rows), so
            // k · span + j < LANES · span = x.len() (asserted above); unchecked
            // because the LANES bounds checks per step cost more than the arithmetic.
            let v: Lanes = std::array::from_fn(|k| unsafe { *x.get_unchecked(k * span + j) });
            let y = lane_step::<A, B, C>(v, &c[r * (B + 1)..(r + 1) * (B + 1)], window);
            group[r] = y;
            y
        });
    }
    windows
}

/// The steps of one substitution on all segments from zero windows (`rows` lane-major, see
/// [`Segmented`]; backward from the last row); returns the windows at the segments' ends,
/// oldest first.
#[inline(always)]
pub(crate) fn lane_steps<
    A: Arith,
    const B: usize,
    const REV: bool,
    C: LaneCoefficients + ?Sized,
>(
    rows: &mut [Lanes],
    steps: &C,
    group: impl Fn(usize) -> usize,
) -> [Lanes; B] {
    // a ring of windows, B steps per group: slot (r + m) % B holds the result m − B steps
    // back at step r, constant indices once unrolled, so the windows stay in registers
    // (shifting them, or indexing them at run time, goes through memory)
    let mut windows = [[0.0; LANES]; B];
    let coefs = |t: usize| &steps[group(t)..group(t) + B * (B + 1)];
    if REV {
        for (t, rows) in rows.chunks_exact_mut(B).rev().enumerate() {
            lane_group::<A, B, REV, C>(rows, coefs(t), &mut windows);
        }
    } else {
        for (t, rows) in rows.chunks_exact_mut(B).enumerate() {
            lane_group::<A, B, REV, C>(rows, coefs(t), &mut windows);
        }
    }
    // span is a multiple of B: the ring is back in order, oldest first
    windows
}

/// B steps of the LANES segments on the B rows of `group` (in reverse when `REV`); `coef`
/// holds the steps' coefficients (see [`Direction::steps`]).
#[inline(always)]
fn lane_group<A: Arith, const B: usize, const REV: bool, C: LaneCoefficients + ?Sized>(
    group: &mut [Lanes],
    coef: &C,
    windows: &mut [Lanes; B],
) {
    let group: &mut [Lanes; B] = group.try_into().unwrap();
    ring_group!(B, windows, |r, window| {
        let row = if REV { B - 1 - r } else { r };
        let c = &coef[r * (B + 1)..(r + 1) * (B + 1)];
        let y = lane_step::<A, B, C>(group[row], c, window);
        group[row] = y;
        y
    });
}

/// One step of the LANES segments: `c` holds 1/L_ii and the coefficients (see
/// [`Direction::steps`]), `window` the results before it.
#[inline(always)]
fn lane_step<A: Arith, const B: usize, C: LaneCoefficients + ?Sized>(
    v: Lanes,
    c: &C,
    window: Window<Lanes, B>,
) -> Lanes {
    let scale = c.lanes(0);
    let start = std::array::from_fn(|k| v[k] * scale[k]);
    multiply_subtract::<A, B, LANES>(start, |m| c.lanes(1 + m), |m| window.get(m))
}

/// start − Σ_m c(m) w(m) over m = 0..B, lane by lane, the newest window entry (m = B − 1)
/// last: it alone is on the latency chain from the previous step. Beyond
/// [`MAX_UNROLLED_RING`], the older terms go to four partial sums, so that the chain
/// within a step stays shorter than the step's multiply-adds take to issue.
#[inline(always)]
pub(crate) fn multiply_subtract<A: Arith, const B: usize, const L: usize>(
    start: [f64; L],
    c: impl Fn(usize) -> [f64; L],
    w: impl Fn(usize) -> [f64; L],
) -> [f64; L] {
    let mut acc = start;
    if B <= MAX_UNROLLED_RING {
        for m in 0..B - 1 {
            sub_term::<A, L>(&mut acc, c(m), w(m));
        }
    } else {
        let mut parts = [acc, [0.0; L], [0.0; L], [0.0; L]];
        let older = B - 1;
        for q in 0..older / 4 {
            for (j, part) in parts.iter_mut().enumerate() {
                sub_term::<A, L>(part, c(4 * q + j), w(4 * q + j));
            }
        }
        for m in older / 4 * 4..older {
            sub_term::<A, L>(&mut parts[m % 4], c(m), w(m));
        }
        acc = std::array::from_fn(|k| (parts[0][k] + parts[1][k]) + (parts[2][k] + parts[3][k]));
    }
    sub_term::<A, L>(&mut acc, c(B - 1), w(B - 1));
    acc
}

/// acc −= c w, lane by lane.
#[inline(always)]
fn sub_term<A: Arith, const L: usize>(acc: &mut [f64; L], c: [f64; L], w: [f64; L]) {
    for k in 0..L {
        acc[k] = A::sub_product(acc[k], c[k], w[k]);
    }
}

/// The B results before a step of a substitution, oldest first (see [`ring_group!`]): a
/// ring and the slot of the oldest, or a run of a history.
#[derive(Clone, Copy)]
pub(crate) enum Window<'a, T, const B: usize> {
    Ring(&'a [T; B], usize),
    Run(&'a [T]),
}

impl<T: Copy, const B: usize> Window<'_, T, B> {
    /// The result B − m steps back.
    #[inline(always)]
    pub(crate) fn get(&self, m: usize) -> T {
        match self {
            Window::Ring(slots, first) => slots[(first + m) % B],
            Window::Run(run) => run[m],
        }
    }
}

/// The exact windows entering the segments of one substitution (by slot, then lane), `lead`
/// that of its first segment, `windows` its zero-start windows at the segments' ends (see
/// [`lane_steps`]), `ends(k)` the end windows of segment k's responses (see
/// [`Direction::ends`]); and the exact window at the end of the last segment.
#[inline(always)]
pub(crate) fn entering_windows<'a, A: Arith, const B: usize, const REV: bool>(
    windows: &[Lanes; B],
    ends: impl Fn(usize) -> &'a [f64],
    lead: [f64; B],
) -> ([Lanes; B], [f64; B]) {
    // each segment's end is its zero-start one (its lane of `windows`) plus the response
    // to the window entering it
    let mut entering = [[0.0; LANES]; B];
    let mut window = lead;
    for k in 0..LANES {
        let lane = if REV { LANES - 1 - k } else { k };
        for q in 0..B {
            entering[q][lane] = window[q];
        }
        let ends = ends(k);
        window = std::array::from_fn(|m| {
            let mut y = windows[m][lane];
            for (q, &w) in window.iter().enumerate() {
                y = A::add_product(y, w, ends[q * B + m]);
            }
            y
        });
    }
    (entering, window)
}

/// row += Σ_q entering[q] h[q], lane by lane.
#[inline(always)]
pub(crate) fn add_responses<A: Arith, const B: usize, C: LaneCoefficients + ?Sized>(
    row: &mut Lanes,
    h: &C,
    entering: &[Lanes; B],
) {
    // a local accumulator: updating `row` in place, LLVM makes the loop scalar
    let mut acc = *row;
    for (q, eq) in entering.iter().enumerate() {
        let hq = h.lanes(q);
        for k in 0..LANES {
            acc[k] = A::add_product(acc[k], eq[k], hq[k]);
        }
    }
    *row = acc;
}

/// Step j = first + r of the LANES segments on x (see [`lane_step`]); `group` holds the
/// coefficients of the B steps from `first`.
#[inline(always)]
fn lane_step_in_place<A: Arith, const B: usize, const REV: bool>(
    x: &mut [f64],
    span: usize,
    first: usize,
    r: usize,
    group: &[Lanes],
    window: Window<Lanes, B>,
) -> Lanes {
    let (n, j) = (x.len(), first + r);
    let at = |p: usize| if REV { n - 1 - p } else { p };
    // SAFETY (both blocks): k < LANES and j < span, so k · span + j < LANES · span ≤ n
    // (asserted by the caller) and at() maps [0, n) onto itself; unchecked because the
    // 2 · LANES bounds checks per step cost more than the arithmetic.
    let v: Lanes = std::array::from_fn(|k| unsafe { *x.get_unchecked(at(k * span + j)) });
    let y = lane_step::<A, B, [Lanes]>(v, &group[r * (B + 1)..(r + 1) * (B + 1)], window);
    for (k, &yk) in y.iter().enumerate() {
        unsafe { *x.get_unchecked_mut(at(k * span + j)) = yk };
    }
    y
}

/// The exact window at the end of segment k: its zero-start one (`windows`, lane k) plus
/// the response to the exact window `entering` it.
#[inline(always)]
fn segment_end<A: Arith, const B: usize>(
    windows: &[Lanes; B],
    direction: &StridedDirection,
    k: usize,
    entering: &[f64; B],
) -> [f64; B] {
    std::array::from_fn(|m| {
        let mut y = windows[m][k];
        if k > 0 {
            for (q, &w) in entering.iter().enumerate() {
                y = A::add_product(y, w, direction.ends[((k - 1) * B + q) * B + m]);
            }
        }
        y
    })
}

/// x += w h, term by term.
#[inline(always)]
fn add_scaled<'a, A: Arith>(x: impl Iterator<Item = &'a mut f64>, h: &[f64], w: f64) {
    for (v, &hp) in x.zip(h) {
        *v = A::add_product(*v, w, hp);
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
    /// factors of the segmented orders have their interior snapped (see `steady_band`).
    fn snapped_tolerance(n: usize) -> f64 {
        if n >= MIN_SEGMENTED {
            10.0 * crate::steady_band::STEADY_TOLERANCES[0]
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

    /// (bandwidth, order) pairs: n = 40: one pass; n ≥ 128: the segmented solves, with and
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

    /// A nearly singular matrix: slowly decaying responses, not cut within a segment.
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
            let zero = vec![[0.0; crate::band_ldl::LANES]; n];
            let mut ldl = crate::band_ldl::BandLdlBatch::new(n, b);
            ldl.factor([&a; crate::band_ldl::LANES], &zero, 1).unwrap();
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
        // orders: just above MIN_SEGMENTED, not multiples of LANES or of b, long
        for b in FIXED_BANDS {
            for n in [MIN_SEGMENTED, MIN_SEGMENTED + 1, 131, 259, 1000, 1003, 4096] {
                if segment_span(n, b) < 2 * b {
                    continue; // too short for segments (see `SymmetricBand::cholesky`)
                }
                for a in [test_matrix(n, b), slow_matrix(n, b)] {
                    let mut lane_major = a.cholesky().unwrap();
                    let mut strided = lane_major.clone();
                    lane_major.segment(true);
                    strided.segment(false);
                    assert!(lane_major.segmented.is_some() && strided.strided.is_some());
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
