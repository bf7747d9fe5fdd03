//! Partitioned solves of a band Cholesky factor with a steady interior (the row systems of the
//! quasi-optimal row filter, SPEC §2.3 generalised, once its model has settled).
//!
//! Away from the ends of a row, the factor of A = Λ + HᵀH/σ_θ² repeats with the period of
//! the state order (the model along the row is stationary there). Over that interior the
//! partitioned substitutions (`partitioned`) need no per-part coefficients or zero-input
//! responses: every part sees the same ones, kept once (a cycle of lcm(B, period) steps,
//! one response per window slot) and broadcast to all lanes, so the solve streams only x.
//! The ends (the `lead` before the parts and the `tail` after them) are substituted one
//! position at a time with the factor's own coefficients.
//!
//! The interior is made exactly periodic when the factor is made ([`snap_interior`]): the
//! rows of L within a tolerance (relative) of the row's middle in the same phase are
//! replaced by the middle's. The row filter's Λ is itself exactly periodic in its interior
//! (`ScalarRowFilter::precision` gives the interior columns the middle column's term, their
//! fits differing by rounding only), so the factor's rows converge from the ends and then
//! scatter by the factorisation's own rounding: ~1e-12 for n_y ≤ 3 (ρ = 0.9), within the
//! tolerance 1e-10, so the replaced factor solves a system within ~1e-10 of A (solutions
//! within ~3e-11, tested). For n_y = 4 the factorisation of the ill-conditioned whitened
//! systems scatters by ~2e-9 (ρ = 0.9): the tolerance is widened (1e-9, then 1e-8) only
//! where such rounding noise (flat across the interior, unlike a slow convergence from the
//! ends) leaves less than half of a long factor steady (see [`snap_interior`]). A row is
//! then replaced by one that differs from it by the same rounding noise, so the solutions
//! move no more than that rounding already moved them ((4,4) at ρ = 0.9: the distance to
//! the NumPy twin changes in its 5th digit). The (4,4) factors at ρ ≥ 0.95 keep their rows
//! and the per-part solves. Every solve of the factor (steady or not) uses the same rows.
//!
//! The wide bands (B = 11, 19) solve their steady interior by blocks (`steady_blocks`)
//! instead of by parts.

use std::ops::Range;

use super::lane_steps::{Lanes, LANES};
use super::partitioned::{decayed_len, solve_by_parts, zero_input_response, PartData};
use super::substitution::FactorCoefficients;
use crate::simd::Arith;

/// Relative distances from the middle's coefficients within which a position is steady,
/// tried smallest first (see [`snap_interior`]).
pub(crate) const STEADY_TOLERANCES: [f64; 3] = [1e-10, 1e-9, 1e-8];
/// The shortest factor whose interior may be snapped at a wider tolerance (see
/// [`snap_interior`]): on shorter ones a slow convergence from the ends looks flat.
const MIN_NOISE_ORDER: usize = 1024;
/// The longest period looked for (the state order of the row filters is at most 4).
const MAX_PERIOD: usize = 8;

/// The plan of a steady partitioned solve: LANES parts of `span` positions from x[start],
/// span a multiple of the cycle lcm(B, period), so that step j of every part has the
/// same phase.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Steady {
    pub(crate) start: usize,
    pub(crate) span: usize,
    pub(crate) forward: SteadyDirection,
    pub(crate) backward: SteadyDirection,
}

/// One substitution of a [`Steady`] solve; step j' counts in the substitution's own order
/// (backward: from the end of each part).
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct SteadyDirection {
    /// Per step of one cycle: 1/L_ii, then the B coefficients, shared by all parts.
    pub(crate) steps: Vec<f64>,
    /// Per offset t into a part and window slot q: the response at t to a unit entry in
    /// slot q of the part's starting window; cut where every response has decayed.
    pub(crate) responses: Vec<f64>,
    /// Per slot q and slot m: the response's window at the part's end.
    pub(crate) ends: Vec<f64>,
}

/// Makes the interior of the band factor `l` (rows of b + 1 entries, see `SymmetricBand`)
/// exactly periodic: the rows within a tolerance of the middle row of the same phase
/// become copies of it, over the longest such range around the middle among the periods
/// 1..=8 (a period that does not fit leaves only a short range, and nothing is replaced
/// outside it); returns the tolerance, period and range (see [`Snap`]).
///
/// The tolerance is the smallest of [`STEADY_TOLERANCES`]; a wider one only where the
/// smallest leaves less than half the factor steady because of rounding noise, not of a
/// slow convergence from the ends: a factor of at least [`MIN_NOISE_ORDER`] rows whose
/// wider range covers half of it, and whose rows scatter about as much near the middle
/// (the central quarter) as over the central half (a converging factor's deviations decay
/// towards the middle).
pub(crate) fn snap_interior(l: &mut [f64], n: usize, b: usize) -> Option<Snap> {
    if n < 2 * MAX_PERIOD {
        return None;
    }
    let row = |i: usize| i * (b + 1)..(i + 1) * (b + 1);
    // per period: the largest entry of the middle rows, the scale of the tolerances
    let scales: Vec<f64> = (1..=MAX_PERIOD)
        .map(|period| {
            let middle = n / 2 / period * period;
            l[row(middle).start..row(middle + period - 1).end]
                .iter()
                .fold(f64::MIN_POSITIVE, |a, v| a.max(v.abs()))
        })
        .collect();
    // the largest deviation from the middle rows over `positions`, relative to the scale
    let deviation = |period: usize, positions: Range<usize>| {
        let (l, scale) = (&*l, scales[period - 1]);
        positions.fold(0.0f64, |d, i| {
            let (li, lr) = (&l[row(i)], &l[row(reference(n, i, period))]);
            li.iter()
                .zip(lr)
                .fold(d, |d, (p, q)| d.max((p - q).abs() / scale))
        })
    };
    let steady = |tolerance: f64| {
        longest(|period| periodic_range(n, period, |i, _| deviation(period, i..i + 1) <= tolerance))
    };
    let covers_half = |(lo, hi): (usize, usize)| 2 * (hi - lo) >= n;
    let noise_limited = |period: usize| {
        let half = deviation(period, n / 4..3 * n / 4);
        n >= MIN_NOISE_ORDER && deviation(period, 3 * n / 8..5 * n / 8) >= half / 4.0
    };
    let smallest = (STEADY_TOLERANCES[0], steady(STEADY_TOLERANCES[0]));
    let (tolerance, (period, (lo, hi))) = if covers_half(smallest.1 .1) {
        smallest
    } else {
        STEADY_TOLERANCES[1..]
            .iter()
            .map(|&tolerance| (tolerance, steady(tolerance)))
            .find(|&(_, (period, range))| covers_half(range) && noise_limited(period))
            .unwrap_or(smallest)
    };
    for i in lo..hi {
        let r = reference(n, i, period);
        if r != i {
            l.copy_within(row(r), row(i).start);
        }
    }
    Some(Snap {
        tolerance,
        period,
        rows: lo..hi,
    })
}

/// What [`snap_interior`] made exactly periodic.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Snap {
    /// The tolerance it took (one of [`STEADY_TOLERANCES`]).
    pub(crate) tolerance: f64,
    pub(crate) period: usize,
    /// The rows that repeat with that period, bit for bit.
    pub(crate) rows: Range<usize>,
}

/// The middle position of an order-n factor with the phase of position i.
fn reference(n: usize, i: usize, period: usize) -> usize {
    n / 2 / period * period + i % period
}

/// The positions [lo, hi) around the middle for which `same(i, reference)` holds.
fn periodic_range(n: usize, period: usize, same: impl Fn(usize, usize) -> bool) -> (usize, usize) {
    let middle = n / 2 / period * period;
    let steady = |i: &usize| same(*i, reference(n, *i, period));
    let lo = (0..middle).rev().find(|i| !steady(i)).map_or(0, |i| i + 1);
    let hi = (middle..n).find(|i| !steady(i)).unwrap_or(n);
    (lo, hi)
}

/// The period in 1..=MAX_PERIOD with the longest range (the shortest among equals).
fn longest(range: impl Fn(usize) -> (usize, usize)) -> (usize, (usize, usize)) {
    (1..=MAX_PERIOD)
        .map(|p| (p, range(p)))
        .max_by_key(|&(p, (lo, hi))| (hi - lo, usize::MAX - p))
        .expect("MAX_PERIOD > 0")
}

fn lcm(a: usize, b: usize) -> usize {
    let gcd = |mut a: usize, mut b: usize| {
        while b != 0 {
            (a, b) = (b, a % b);
        }
        a
    };
    a / gcd(a, b) * b
}

impl Steady {
    /// The steady plan of a factor (see [`snap_interior`]), if its exactly periodic interior
    /// holds LANES parts of at least two cycles each.
    pub(crate) fn new(f: &FactorCoefficients) -> Option<Steady> {
        let (n, b) = (f.size(), f.bandwidth);
        if n < 2 * MAX_PERIOD {
            return None;
        }
        let (period, (lo, hi)) = longest(|p| periodic_range(n, p, |i, r| f.same(i, r)));
        let cycle = lcm(b, period);
        let span = (hi - lo) / LANES / cycle * cycle;
        if span < 2 * cycle {
            return None;
        }
        let phase = |p: usize| reference(n, p, period);
        let forward_position = |j: usize| phase(lo + j);
        // backward step j' is the position span − 1 − j' of a part
        let backward_position = |j: usize| phase(lo + span - 1 - j);
        Some(Steady {
            start: lo,
            span,
            forward: SteadyDirection::new(f, f.forward, cycle, span, forward_position),
            backward: SteadyDirection::new(f, f.backward, cycle, span, backward_position),
        })
    }

    /// Groups of B steps in one cycle.
    fn groups(&self, b: usize) -> usize {
        self.forward.steps.len() / (b * (b + 1))
    }

    /// Solves A x = rhs in place with the factor `f`; `rows`: span lanes of scratch.
    #[inline(always)]
    pub(crate) fn solve<A: Arith, const B: usize>(
        &self,
        f: &FactorCoefficients,
        x: &mut [f64],
        rows: &mut [Lanes],
    ) {
        assert!(rows.len() == self.span);
        let groups = self.groups(B);
        let (forward, backward) = (self.forward.data(), self.backward.data());
        let shared = move |t: usize| t % groups * B * (B + 1);
        solve_by_parts::<A, B, [f64]>(f, x, rows, self.start, forward, backward, shared);
    }
}

impl SteadyDirection {
    /// This substitution for [`solve_by_parts`]: one set of end windows for all parts.
    fn data(&self) -> PartData<'_, [f64]> {
        PartData {
            steps: &self.steps,
            responses: &self.responses,
            ends: &self.ends,
            ends_stride: 0,
        }
    }

    /// `coef`: the direction's coefficients; `position(j')`: the middle position whose
    /// coefficients serve step j'.
    fn new(
        f: &FactorCoefficients,
        coef: &[f64],
        cycle: usize,
        span: usize,
        position: impl Fn(usize) -> usize,
    ) -> SteadyDirection {
        let b = f.bandwidth;
        let mut steps = Vec::with_capacity(cycle * (b + 1));
        for j in 0..cycle {
            let i = position(j);
            steps.push(f.inverse_diagonal[i]);
            steps.extend_from_slice(&coef[i * b..(i + 1) * b]);
        }
        let h: Vec<Vec<f64>> = (0..b)
            .map(|q| zero_input_response(coef, b, q, (0..span).map(&position)))
            .collect();
        let ends = (0..b * b).map(|i| h[i / b][span - b + i % b]).collect();
        let len = h.iter().map(|hq| decayed_len(hq, b)).max().unwrap_or(0);
        let responses = (0..len * b).map(|i| h[i % b][i / b]).collect();
        SteadyDirection {
            steps,
            responses,
            ends,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::linalg::banded::band::SymmetricBand;

    /// A band matrix whose diagonals repeat with `period` (edges included: the factor still
    /// converges from both ends), optionally perturbed by a relative `noise` per entry.
    fn periodic(n: usize, b: usize, period: usize, noise: f64) -> SymmetricBand {
        periodic_within(n, b, b, period, noise)
    }

    /// [`periodic`] with entries only within `reach` ≤ b of the diagonal.
    fn periodic_within(
        n: usize,
        b: usize,
        reach: usize,
        period: usize,
        noise: f64,
    ) -> SymmetricBand {
        let mut a = SymmetricBand::zeros(n, b);
        for i in 0..n {
            let jitter = noise * ((i * 7919) % 97) as f64 / 97.0;
            // (the wider bands' longer off-diagonal sums need a larger diagonal)
            let diagonal = if b <= 7 { 2.5 } else { 3.5 };
            a.add(i, i, diagonal + 0.3 * (i % period) as f64 + jitter);
            for k in i.saturating_sub(reach)..i {
                a.add(
                    i,
                    k,
                    -0.8 / ((i - k) * (i - k)) as f64 * (1.0 + 0.1 * (k % period) as f64),
                );
            }
        }
        a
    }

    fn solves(a: &SymmetricBand) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
        let n = a.size();
        let rhs: Vec<f64> = (0..n).map(|i| (i as f64 * 0.7).cos()).collect();
        let factor = a.cholesky().unwrap();
        let (mut x, mut y) = (rhs.clone(), rhs.clone());
        factor.solve_in_place(&mut x);
        factor.solve_unplanned(&mut y);
        (rhs, x, y)
    }

    fn max_difference(u: &[f64], v: &[f64]) -> f64 {
        u.iter()
            .zip(v)
            .fold(0.0f64, |m, (p, q)| m.max((p - q).abs()))
    }

    #[test]
    fn steady_solves_match_the_unplanned_solve() {
        for b in [1usize, 2, 3, 5, 7, 11, 19] {
            for period in [1usize, 2, 3, 4] {
                for n in [400usize, 1000, 2051, 5000] {
                    let a = periodic(n, b, period, 0.0);
                    let factor = a.cholesky().unwrap();
                    // (short orders may hold too few cycles for a plan)
                    let long = n >= 5 * LANES * lcm(b, period);
                    assert!(factor.is_steady() || !long, "b {b} p {period} n {n}");
                    if let Some(plan) = factor.steady_plan() {
                        assert_eq!(plan.span % lcm(b, period), 0);
                        assert!(plan.start + LANES * plan.span <= n);
                    }
                    let (rhs, x, y) = solves(&a);
                    let scale = y.iter().fold(0.0f64, |m, v| m.max(v.abs()));
                    assert!(
                        max_difference(&x, &y) < 1e-13 * scale,
                        "b {b} p {period} n {n}"
                    );
                    // the snapped factor still solves A itself
                    let mut back = vec![0.0; n];
                    a.mul_vec(&x, &mut back);
                    assert!(max_difference(&back, &rhs) < 10.0 * STEADY_TOLERANCES[0]);
                }
            }
        }
    }

    #[test]
    fn block_solves_match_the_unplanned_solve() {
        // the wide bands with a period dividing their block size are solved by blocks,
        // reaching ⌈B/G⌉ blocks back, one less when A is block banded (the row filters)
        for (b, g) in [(11usize, 3usize), (19, 4)] {
            for period in (1..=g).filter(|p| g % p == 0) {
                for (reach, blocks) in [(b, b.div_ceil(g)), (b + 1 - g, b.div_ceil(g) - 1)] {
                    let n = 600 * g;
                    let a = periodic_within(n, b, reach, period, 0.0);
                    let factor = a.cholesky().unwrap();
                    let plan = factor.block_plan().expect("a block plan");
                    assert_eq!(plan.reach(), blocks, "b {b} p {period} reach {reach}");
                    assert!(plan.start % g == 0 && plan.end - plan.start > n / 2);
                    let (rhs, x, y) = solves(&a);
                    let scale = y.iter().fold(0.0f64, |m, v| m.max(v.abs()));
                    assert!(max_difference(&x, &y) < 1e-13 * scale, "b {b} p {period}");
                    let mut back = vec![0.0; n];
                    a.mul_vec(&x, &mut back);
                    assert!(max_difference(&back, &rhs) < 10.0 * STEADY_TOLERANCES[0]);
                    // a right-hand side observed at the first position of every block (the
                    // row filters' innovations; blocks of g: the forward recursion skips
                    // the zeros): the same solution
                    assert_eq!(plan.size(), g);
                    let observed: Vec<f64> = (0..n)
                        .map(|i| if i % g == 0 { rhs[i] } else { 0.0 })
                        .collect();
                    let (mut dense, mut sparse) = (observed.clone(), observed);
                    factor.solve_in_place(&mut dense);
                    factor.solve_observed_in_place(&mut sparse, g);
                    assert_eq!(dense, sparse, "b {b} p {period}");
                }
            }
        }
    }

    #[test]
    fn snapping_moves_the_factor_within_the_tolerance_only() {
        let (n, b) = (1000usize, 5usize);
        let a = periodic(n, b, 2, 0.0);
        let exact = a.cholesky_unsnapped();
        let mut snapped = exact.clone();
        // an exactly periodic matrix: its factor settles to rounding, the smallest tolerance
        let snap = snap_interior(&mut snapped, n, b).unwrap();
        assert_eq!((snap.tolerance, snap.period), (STEADY_TOLERANCES[0], 2));
        // (the rows snapped repeat bit for bit: the range the block plans are built on)
        let row = |i: usize| &snapped[i * (b + 1)..(i + 1) * (b + 1)];
        assert!(snap.rows.len() >= n / 2);
        assert!(snap.rows.clone().all(|i| row(i) == row(n / 2 + i % 2)));
        let scale = exact.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let moved = max_difference(&exact, &snapped);
        assert!(
            moved > 0.0 && moved <= STEADY_TOLERANCES[0] * scale,
            "{moved:e}"
        );
    }

    #[test]
    fn an_interior_scattered_by_rounding_noise_is_snapped_at_its_level() {
        // diagonal (~3.5) scattered by up to 2e-9 (as an ill-conditioned fit leaves it): the
        // smallest tolerance finds short ranges only, the next one the whole interior
        let (n, b) = (2000usize, 11usize);
        let a = periodic(n, b, 3, 2e-9);
        let exact = a.cholesky_unsnapped();
        let mut snapped = exact.clone();
        let tolerance = snap_interior(&mut snapped, n, b).unwrap().tolerance;
        assert_eq!(tolerance, STEADY_TOLERANCES[1]);
        let scale = exact.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        assert!(max_difference(&exact, &snapped) <= tolerance * scale);
        let factor = a.cholesky().unwrap();
        assert!(factor.is_steady());
        let (rhs, x, y) = solves(&a);
        let solution = y.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        assert!(max_difference(&x, &y) < 1e-13 * solution);
        let mut back = vec![0.0; n];
        a.mul_vec(&x, &mut back);
        assert!(max_difference(&back, &rhs) < 10.0 * tolerance);
    }

    #[test]
    fn an_irregular_interior_gets_no_steady_plan() {
        // entries scattered by 1e-4, beyond every tolerance: nothing is snapped, the
        // partitioned solve takes over
        let a = periodic(1000, 5, 1, 1e-4);
        assert!(!a.cholesky().unwrap().is_steady());
        let (_, x, y) = solves(&a);
        assert!(max_difference(&x, &y) < 1e-12);
    }
}
