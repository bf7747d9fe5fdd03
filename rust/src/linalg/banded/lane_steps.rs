//! The steps of LANES parts of a partitioned substitution at once, one lane per part: their
//! latency chains overlap, and one step of all of them is a few vector operations.

use super::substitution::{multiply_subtract, ring_group, Window};
use crate::simd::Arith;
use std::ops::Range;

/// Parts solved at once by the partitioned solves: their latency chains overlap, and one
/// step of all of them is a few vector operations.
pub(crate) const LANES: usize = 8;
/// One value per part.
pub(crate) type Lanes = [f64; LANES];

/// The coefficients of the partitioned steps and responses: one value per lane (`[Lanes]`),
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

/// The forward steps of all parts from zero windows, reading the parts from x (at
/// x[k · span..(k + 1) · span], span = rows.len()) and writing them lane-major to rows
/// (`rows[j][k] = x[k · span + j]`); returns the windows at the parts' ends. The
/// coefficients of the t-th group of B steps start at `steps[group(t)]` (see
/// `partitioned::LaneMajorDirection::steps`).
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

/// The steps of one substitution on all parts from zero windows (`rows` lane-major, see
/// `partitioned::LaneMajor`; backward from the last row); returns the windows at the parts' ends,
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

/// B steps of the LANES parts on the B rows of `group` (in reverse when `REV`); `coef`
/// holds the steps' coefficients (see `partitioned::LaneMajorDirection::steps`).
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

/// One step of the LANES parts: `c` holds 1/L_ii and the coefficients (see
/// `partitioned::LaneMajorDirection::steps`), `window` the results before it.
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

/// The exact windows entering the parts of one substitution (by slot, then lane), `lead`
/// that of its first part, `windows` its zero-start windows at the parts' ends (see
/// [`lane_steps`]), `ends(k)` the end windows of part k's responses (see
/// `partitioned::LaneMajorDirection::ends`); and the exact window at the end of the last part.
#[inline(always)]
pub(crate) fn entering_windows<'a, A: Arith, const B: usize, const REV: bool>(
    windows: &[Lanes; B],
    ends: impl Fn(usize) -> &'a [f64],
    lead: [f64; B],
) -> ([Lanes; B], [f64; B]) {
    // each part's end is its zero-start one (its lane of `windows`) plus the response
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

/// Step j = first + r of the LANES parts on x (see [`lane_step`]); `group` holds the
/// coefficients of the B steps from `first`.
#[inline(always)]
pub(super) fn lane_step_in_place<A: Arith, const B: usize, const REV: bool>(
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
