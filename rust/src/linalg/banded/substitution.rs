//! The window substitutions of a band factor: each step subtracts the B results before it,
//! times the step's coefficients, and waits only on the newest one (the latency chain of a
//! banded solve is its cost). Shared by the Cholesky solves, the partitioned and steady
//! solves and the LDLᵀ solves of `band_ldl`.

use super::band::band_index;
use crate::simd::Arith;

/// Runs `body` for r = 0, 1, …, B − 1 (B ≤ 11) written out, not as a loop (see
/// [`ring_group!`]).
macro_rules! unrolled {
    ($b:expr, |$r:ident| $body:block) => {
        $crate::linalg::banded::substitution::unrolled!(@ $b, $r, $body, 0 1 2 3 4 5 6 7 8 9 10)
    };
    (@ $b:expr, $r:ident, $body:block, $($n:literal)*) => {{$(
        if $n < $b {
            let $r: usize = $n;
            $body
        }
    )*}};
}
pub(crate) use unrolled;

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
        $crate::linalg::banded::substitution::ring_group!(
            $b,
            $crate::linalg::banded::substitution::MAX_UNROLLED_RING,
            $windows,
            |$r, $window| $step
        )
    };
    ($b:expr, $limit:expr, $windows:expr, |$r:ident, $window:ident| $step:block) => {{
        let windows = $windows;
        if $b <= $limit {
            $crate::linalg::banded::substitution::unrolled!($b, |$r| {
                let y = {
                    let $window =
                        $crate::linalg::banded::substitution::Window::<_, $b>::Ring(windows, $r);
                    $step
                };
                windows[$r] = y;
            });
        } else {
            let mut history = [*windows; 2];
            let flat = history.as_flattened_mut();
            for $r in 0..$b {
                let y = {
                    let $window = $crate::linalg::banded::substitution::Window::<_, $b>::Run(
                        &flat[$r..$r + $b],
                    );
                    $step
                };
                flat[$b + $r] = y;
            }
            *windows = history[1];
        }
    }};
}
pub(crate) use ring_group;

/// The widest ring of [`ring_group!`] written out (held in registers).
pub(super) const MAX_UNROLLED_RING: usize = 7;
/// The same for the one-position substitutions ([`substitute`]), whose results are single
/// values: their ring of B = 11 fits in the registers too (the (3,3) filter ran 14 % faster
/// than with it in memory).
const MAX_UNROLLED_SCALAR_RING: usize = 11;

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

/// Forward then backward substitution with the band factor `l` (1/L_ii in `inv`), no plan
/// (the bandwidths without an unrolled kernel).
pub(super) fn substitute_plain(l: &[f64], inv: &[f64], b: usize, x: &mut [f64]) {
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

/// The factor's substitution coefficients (see `BandCholesky`): 1/L_ii and, per position,
/// the B pre-scaled coefficients of each direction.
pub(crate) struct FactorCoefficients<'a> {
    pub(crate) bandwidth: usize,
    pub(crate) inverse_diagonal: &'a [f64],
    pub(crate) forward: &'a [f64],
    pub(crate) backward: &'a [f64],
}

impl FactorCoefficients<'_> {
    pub(super) fn size(&self) -> usize {
        self.inverse_diagonal.len()
    }

    /// Whether positions i and r have the same coefficients in both directions.
    pub(super) fn same(&self, i: usize, r: usize) -> bool {
        let b = self.bandwidth;
        let (fi, fr) = (
            &self.forward[i * b..(i + 1) * b],
            &self.forward[r * b..(r + 1) * b],
        );
        let (bi, br) = (
            &self.backward[i * b..(i + 1) * b],
            &self.backward[r * b..(r + 1) * b],
        );
        self.inverse_diagonal[i] == self.inverse_diagonal[r] && fi == fr && bi == br
    }
}
