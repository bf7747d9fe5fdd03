//! Partitioned solves of a band Cholesky factor: the order split into LANES parts whose
//! substitutions run at once, each started from a zero window, then corrected with the
//! zero-input responses to the exact window left by the part before it (the substitutions
//! are linear recursions).

use super::lane_steps::{
    add_responses, entering_windows, forward_steps, lane_step_in_place, lane_steps,
    LaneCoefficients, Lanes, LANES,
};
use super::substitution::{ring_group, slots, substitute, FactorCoefficients};
use crate::simd::Arith;

/// Smallest order solved by parts.
pub(super) const MIN_PARTITIONED: usize = 16 * LANES;
/// Zero-input responses are cut once the recursion's state has decayed below this fraction
/// of its peak: what is dropped lies far below the rounding of the corrections.
const NEGLIGIBLE: f64 = 1e-20;
/// The smallest bandwidth whose partitioned solves run on a lane-major copy of x
/// ([`LaneMajor`]); the narrower bands, with fewer operations per step, are faster solved
/// on x itself ([`Strided`]).
pub(super) const LANE_MAJOR_BANDS: usize = 5;

/// The substitutions of a partitioned solve: run on LANES parts at once, each started from
/// a zero window, then corrected with the zero-input responses to the exact window left by
/// the previous part (the substitutions are linear recursions).
///
/// Both substitutions share one partition of x: its first LANES · span entries, part
/// k at x[k · span..(k + 1) · span], held lane-major (`rows[j][k] = x[k · span + j]`, see
/// [`forward_steps`]) while the parts are solved, so that a step loads and stores one
/// vector. The remainder of the order (x[LANES · span..], < LANES · B entries) follows the
/// last part in the forward substitution and leads the backward one.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct LaneMajor {
    /// Part length.
    pub(super) span: usize,
    forward: LaneMajorDirection,
    backward: LaneMajorDirection,
}

/// One substitution of a [`LaneMajor`] solve, in its own order of positions (position p is
/// x[p], or x[n − 1 − p] backward). Lane l of its vectors belongs to the part stored at
/// x[l · span..(l + 1) · span]: its part l forward, its part LANES − 1 − l backward.
#[derive(Debug, Clone, PartialEq)]
struct LaneMajorDirection {
    /// Positions before the parts (solved exactly from a zero window): 0 forward, the
    /// remainder backward.
    lead: usize,
    /// Per step j (the j-th position of every part): 1/L_ii, then the B coefficients,
    /// each for the LANES parts, so that a step reads contiguous vectors.
    steps: Vec<Lanes>,
    /// Per offset t into the parts and window slot q: each part's response at t to a
    /// unit entry in slot q of its starting window; cut where every response has decayed.
    responses: Vec<Lanes>,
    /// Per part k (in the direction's order), slot q and slot m: the response's window
    /// at the part's end.
    ends: Vec<f64>,
}

impl LaneMajorDirection {
    /// This substitution for [`solve_by_parts`] (bandwidth b).
    fn data(&self, b: usize) -> PartData<'_, [Lanes]> {
        PartData {
            steps: &self.steps,
            responses: &self.responses,
            ends: &self.ends,
            ends_stride: b * b,
        }
    }

    fn new(f: &FactorCoefficients, coef: &[f64], reverse: bool) -> LaneMajorDirection {
        let (n, b) = (f.size(), f.bandwidth);
        let span = part_span(n, b);
        let lead = if reverse { n - LANES * span } else { 0 };
        let at = |p: usize| if reverse { n - 1 - p } else { p };
        // the part (in this direction's order) of lane l
        let part = |l: usize| if reverse { LANES - 1 - l } else { l };
        let position = |l: usize, j: usize| at(lead + part(l) * span + j);
        let mut steps = Vec::with_capacity(span * (b + 1));
        for j in 0..span {
            steps.push(std::array::from_fn(|l| f.inverse_diagonal[position(l, j)]));
            for m in 0..b {
                steps.push(std::array::from_fn(|l| coef[position(l, j) * b + m]));
            }
        }
        // part 0 starts from the exact window when nothing leads it: no response
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
            .map(|i| std::array::from_fn(|l| h[part(l)][i % b][i / b]))
            .collect();
        LaneMajorDirection {
            lead,
            steps,
            responses,
            ends,
        }
    }
}

/// The partitioned solves of the narrower bands (below [`LANE_MAJOR_BANDS`]), directly on
/// x: LANES parts of span positions in each substitution's own order (forward x[k ·
/// span..], backward from x[n − 1 − k · span] down), the remainder after the last part.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Strided {
    /// Part length.
    span: usize,
    forward: StridedDirection,
    backward: StridedDirection,
}

/// One substitution of a [`Strided`] solve, in its own order of positions.
#[derive(Debug, Clone, PartialEq)]
struct StridedDirection {
    /// Per step j: 1/L_ii, then the B coefficients, each for the LANES parts (position
    /// k · span + j for part k), so that a step reads contiguous vectors.
    steps: Vec<Lanes>,
    /// Per part k ≥ 1 and window slot q: the response over the part to a unit entry
    /// in slot q of its starting window, cut where it has decayed.
    responses: Vec<Vec<f64>>,
    /// Per part k ≥ 1, slot q and slot m: the response's window at the part's end.
    ends: Vec<f64>,
}

impl StridedDirection {
    fn new(f: &FactorCoefficients, coef: &[f64], reverse: bool) -> StridedDirection {
        let (n, b) = (f.size(), f.bandwidth);
        let span = part_span(n, b);
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

/// Part length: a multiple of b (the main loop takes b steps at a time, see
/// [`lane_group`]).
pub(super) fn part_span(n: usize, b: usize) -> usize {
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

impl Strided {
    /// The plan of the factor `f`.
    pub(super) fn new(f: &FactorCoefficients) -> Strided {
        Strided {
            span: part_span(f.size(), f.bandwidth),
            forward: StridedDirection::new(f, f.forward, false),
            backward: StridedDirection::new(f, f.backward, true),
        }
    }

    /// Solves A x = rhs in place with the factor `f` (bandwidth B).
    #[inline(always)]
    pub(super) fn solve<A: Arith, const B: usize>(&self, f: &FactorCoefficients, x: &mut [f64]) {
        Self::substitute::<A, B, false>(f, x, f.forward, &self.forward, self.span);
        Self::substitute::<A, B, true>(f, x, f.backward, &self.backward, self.span);
    }

    /// The substitution on the LANES parts at once from zero windows, then the
    /// corrections, then the remainder from the exact window of the last part.
    #[inline(always)]
    fn substitute<A: Arith, const B: usize, const REV: bool>(
        f: &FactorCoefficients,
        x: &mut [f64],
        coef: &[f64],
        direction: &StridedDirection,
        span: usize,
    ) {
        let n = f.size();
        let at = |p: usize| if REV { n - 1 - p } else { p };
        assert!(LANES * span <= n && n == x.len() && direction.steps.len() == span * (B + 1));
        let mut windows = [[0.0; LANES]; B];
        for (t, group) in direction.steps.chunks_exact(B * (B + 1)).enumerate() {
            ring_group!(B, &mut windows, |r, window| {
                lane_step_in_place::<A, B, REV>(x, span, t * B, r, group, window)
            });
        }
        // span is a multiple of B: the ring is back in order, oldest first
        // part 0 started from the exact (zero) window
        let mut entering = [0.0; B];
        for k in 1..LANES {
            entering = part_end::<A, B>(&windows, direction, k - 1, &entering);
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
        let mut last = part_end::<A, B>(&windows, direction, LANES - 1, &entering);
        let inv = |i: usize| f.inverse_diagonal[i];
        substitute::<A, B, REV>(x, slots(coef), inv, LANES * span, n, &mut last);
    }
}

impl LaneMajor {
    /// The plan of the factor `f`.
    pub(super) fn new(f: &FactorCoefficients) -> LaneMajor {
        LaneMajor {
            span: part_span(f.size(), f.bandwidth),
            forward: LaneMajorDirection::new(f, f.forward, false),
            backward: LaneMajorDirection::new(f, f.backward, true),
        }
    }

    /// Both substitutions by parts with the factor `f` (bandwidth B) on the lane-major
    /// copy `rows` of the first LANES · span entries of x (no lead).
    #[inline(always)]
    pub(super) fn solve<A: Arith, const B: usize>(
        &self,
        f: &FactorCoefficients,
        x: &mut [f64],
        rows: &mut [Lanes],
    ) {
        let s = self;
        let whole = LANES * s.span;
        assert!(s.forward.steps.len() == s.span * (B + 1) && s.forward.lead == 0);
        assert!(s.backward.steps.len() == s.span * (B + 1) && s.backward.lead == x.len() - whole);
        let (forward, backward) = (s.forward.data(B), s.backward.data(B));
        let per_lane = |t: usize| t * B * (B + 1);
        solve_by_parts::<A, B, [Lanes]>(f, x, rows, 0, forward, backward, per_lane);
    }
}

/// One substitution of [`solve_by_parts`]: `steps` its coefficients (group t of B steps
/// from `steps[group(t)]`, 1/L_ii then the B coefficients per step), `responses` B per
/// offset into a part, `ends` the B · B end windows of part k's responses (in the
/// substitution's order) at `k · ends_stride` (0: one set shared by all parts).
pub(crate) struct PartData<'a, C: ?Sized> {
    pub(crate) steps: &'a C,
    pub(crate) responses: &'a C,
    pub(crate) ends: &'a [f64],
    pub(crate) ends_stride: usize,
}

/// Solves L Lᵀ x = rhs in place with the factor `f`: LANES parts of span = rows.len()
/// positions from x[start] solved at once on the lane-major `rows`, started from zero
/// windows and corrected with the responses; the positions before them (the lead) and
/// after them (the tail) one at a time, with the factor's own coefficients.
#[inline(always)]
pub(crate) fn solve_by_parts<A: Arith, const B: usize, C: LaneCoefficients + ?Sized>(
    f: &FactorCoefficients,
    x: &mut [f64],
    rows: &mut [Lanes],
    start: usize,
    forward: PartData<C>,
    backward: PartData<C>,
    group: impl Fn(usize) -> usize + Copy,
) {
    let (n, span) = (x.len(), rows.len());
    let end = start + LANES * span;
    assert!(end <= n && n == f.inverse_diagonal.len() && f.bandwidth == B);
    let inv = |i: usize| f.inverse_diagonal[i];
    // the B responses of each offset into a part
    let offsets = |responses: &C| (0..responses.count() / B).map(|t| t * B..(t + 1) * B);
    // forward: the lead, the parts from zero windows, their corrections, the tail
    let mut window = [0.0; B];
    substitute::<A, B, false>(x, slots(f.forward), inv, 0, start, &mut window);
    let windows = forward_steps::<A, B, C>(&x[start..end], rows, forward.steps, group);
    let ends = |k: usize| &forward.ends[k * forward.ends_stride..][..B * B];
    let (entering, mut last) = entering_windows::<A, B, false>(&windows, ends, window);
    for (row, at) in rows.iter_mut().zip(offsets(forward.responses)) {
        add_responses::<A, B, C>(row, &forward.responses[at], &entering);
    }
    substitute::<A, B, false>(x, slots(f.forward), inv, end, n, &mut last);
    // backward: the tail, the parts and their corrections (written to x), the lead
    let mut window = [0.0; B];
    substitute::<A, B, true>(x, slots(f.backward), inv, 0, n - end, &mut window);
    let windows = lane_steps::<A, B, true, C>(rows, backward.steps, group);
    let ends = |k: usize| &backward.ends[k * backward.ends_stride..][..B * B];
    let (entering, mut last) = entering_windows::<A, B, true>(&windows, ends, window);
    // corrected in place first: fused with the scatter below, LLVM makes it scalar
    for (row, at) in rows.iter_mut().rev().zip(offsets(backward.responses)) {
        add_responses::<A, B, C>(row, &backward.responses[at], &entering);
    }
    let mut parts = x[start..end].chunks_exact_mut(span);
    let mut parts: [&mut [f64]; LANES] = std::array::from_fn(|_| parts.next().unwrap());
    for (j, row) in rows.iter().enumerate() {
        for (part, &vk) in parts.iter_mut().zip(row) {
            part[j] = vk;
        }
    }
    substitute::<A, B, true>(x, slots(f.backward), inv, n - start, n, &mut last);
}

/// The exact window at the end of part k: its zero-start one (`windows`, lane k) plus
/// the response to the exact window `entering` it.
#[inline(always)]
fn part_end<A: Arith, const B: usize>(
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
