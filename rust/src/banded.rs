//! Symmetric banded matrices and their Cholesky factors: the O(size · bandwidth) solves of
//! the quasi-optimal row filter (SPEC §2.3 generalised).

use crate::error::{FieldError, Result};

/// A symmetric matrix with `bandwidth` sub-diagonals, lower band stored row by row:
/// entry (i, k), i - bandwidth ≤ k ≤ i, at `data[i * (bandwidth + 1) + k + bandwidth - i]`.
#[derive(Debug, Clone, PartialEq)]
pub struct SymmetricBand {
    size: usize,
    bandwidth: usize,
    data: Vec<f64>,
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
        i * (self.bandwidth + 1) + k + self.bandwidth - i
    }

    /// Adds `value` to entries (i, k) and (k, i); |i - k| must be within the band.
    pub fn add(&mut self, i: usize, k: usize, value: f64) {
        let (i, k) = if i >= k { (i, k) } else { (k, i) };
        debug_assert!(i - k <= self.bandwidth);
        let at = self.index(i, k);
        self.data[at] += value;
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

    /// The Cholesky factor L (A = L Lᵀ), same band storage.
    pub fn cholesky(&self) -> Result<BandCholesky> {
        let (n, b) = (self.size, self.bandwidth);
        let mut l = self.data.clone();
        for i in 0..n {
            let first = i.saturating_sub(b);
            for k in first..=i {
                let mut sum = l[i * (b + 1) + k + b - i];
                let start = first.max(k.saturating_sub(b));
                for p in start..k {
                    sum -= l[i * (b + 1) + p + b - i] * l[k * (b + 1) + p + b - k];
                }
                if k == i {
                    if sum.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
                        return Err(FieldError::InvalidParameter(
                            "a filter matrix is not positive definite (ill-conditioned model)"
                                .into(),
                        ));
                    }
                    l[i * (b + 1) + b] = sum.sqrt();
                } else {
                    l[i * (b + 1) + k + b - i] = sum / l[k * (b + 1) + b];
                }
            }
        }
        let inverse_diagonal: Vec<f64> = (0..n).map(|i| 1.0 / l[i * (b + 1) + b]).collect();
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
            responses: None,
        };
        if b <= 3 && n >= MIN_SEGMENTED {
            factor.responses = Some(Responses::new(&factor));
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
    responses: Option<Responses>,
}

/// Segments run interleaved by the segmented solves (their chains overlap in the pipeline).
const SEGMENTS: usize = 4;
/// Smallest order solved by segments.
const MIN_SEGMENTED: usize = 64;

/// Zero-input responses of the two substitutions on segments 1.. to a unit entry of their
/// starting window: the corrections that turn a segment started from zeros into the exact
/// solution (the substitutions are linear recursions).
#[derive(Debug, Clone, PartialEq)]
struct Responses {
    /// Length of segments 0..SEGMENTS − 1 (the last one takes the rest).
    span: usize,
    /// Per direction, per segment k ≥ 1, per window slot m: the response over the segment.
    forward: Vec<Vec<f64>>,
    backward: Vec<Vec<f64>>,
}

impl Responses {
    fn new(f: &BandCholesky) -> Responses {
        let (n, b) = (f.size, f.bandwidth);
        let span = n / SEGMENTS;
        let run = |coef: &[f64], reverse: bool| {
            let mut out = Vec::new();
            for k in 1..SEGMENTS {
                let (start, end) = (k * span, if k + 1 == SEGMENTS { n } else { (k + 1) * span });
                for m in 0..b {
                    let mut window = vec![0.0; b];
                    window[m] = 1.0;
                    let mut h = Vec::with_capacity(end - start);
                    for p in start..end {
                        let i = if reverse { n - 1 - p } else { p };
                        let acc = -(0..b).fold(0.0, |acc, q| acc + coef[i * b + q] * window[q]);
                        h.push(acc);
                        window.rotate_left(1);
                        window[b - 1] = acc;
                    }
                    out.push(h);
                }
            }
            out
        };
        Responses {
            span,
            forward: run(&f.forward, false),
            backward: run(&f.backward, true),
        }
    }
}

impl BandCholesky {
    /// Solves A x = rhs in place (forward then backward substitution).
    pub fn solve_in_place(&self, x: &mut [f64]) {
        // fixed bandwidths unroll the inner products (the bandwidths of the row filters)
        match self.bandwidth {
            1 => self.solve_in_registers::<1>(x),
            2 => self.solve_in_registers::<2>(x),
            3 => self.solve_in_registers::<3>(x),
            5 => self.solve_in_memory::<5>(x),
            7 => self.solve_in_memory::<7>(x),
            _ => self.solve_dynamic(x),
        }
    }

    /// Substitutions with the last B results kept in registers and the pre-scaled
    /// coefficients, so that each step waits only on one multiply and one subtract (the
    /// latency chain of a banded solve is its cost). For small B.
    fn solve_in_registers<const B: usize>(&self, x: &mut [f64]) {
        if let Some(r) = &self.responses {
            self.substitute_segmented::<B, false>(x, &self.forward, &r.forward, r.span);
            self.substitute_segmented::<B, true>(x, &self.backward, &r.backward, r.span);
            return;
        }
        let n = self.size;
        let mut window = [0.0; B];
        self.substitute::<B, false>(x, &self.forward, 0, n, &mut window);
        let mut window = [0.0; B];
        self.substitute::<B, true>(x, &self.backward, 0, n, &mut window);
    }

    /// One substitution over the positions [start, end) of its order (position p is x[p],
    /// or x[n − 1 − p] when `REV`): y_p = x_p / L_pp − Σ_m coef_p[m] y_{p−B+m}, `window`
    /// holding y_{p−B..p} (oldest first).
    #[inline(always)]
    fn substitute<const B: usize, const REV: bool>(
        &self,
        x: &mut [f64],
        coef: &[f64],
        start: usize,
        end: usize,
        window: &mut [f64; B],
    ) {
        let n = self.size;
        for p in start..end {
            self.step(x, coef, if REV { n - 1 - p } else { p }, window);
        }
    }

    /// x_i ← x_i / L_ii − Σ_m coef_i[m] window[m], then pushed into `window`.
    #[inline(always)]
    fn step<const B: usize>(&self, x: &mut [f64], coef: &[f64], i: usize, window: &mut [f64; B]) {
        let c: &[f64; B] = coef[i * B..(i + 1) * B].try_into().unwrap();
        let mut acc = x[i] * self.inverse_diagonal[i];
        for m in 0..B {
            acc -= c[m] * window[m];
        }
        x[i] = acc;
        window.rotate_left(1);
        window[B - 1] = acc;
    }

    /// The substitution on SEGMENTS segments at once, each started from a zero window (their
    /// latency chains overlap), then corrected segment by segment with the zero-input
    /// responses to the exact window left by the previous one.
    fn substitute_segmented<const B: usize, const REV: bool>(
        &self,
        x: &mut [f64],
        coef: &[f64],
        responses: &[Vec<f64>],
        span: usize,
    ) {
        let n = self.size;
        let mut windows = [[0.0; B]; SEGMENTS];
        for j in 0..span {
            for (k, window) in windows.iter_mut().enumerate() {
                let p = k * span + j;
                self.step(x, coef, if REV { n - 1 - p } else { p }, window);
            }
        }
        let last = &mut windows[SEGMENTS - 1];
        self.substitute::<B, REV>(x, coef, SEGMENTS * span, n, last);
        for k in 1..SEGMENTS {
            let start = k * span;
            let end = if k + 1 == SEGMENTS { n } else { start + span };
            let at = |p: usize| if REV { n - 1 - p } else { p };
            let exact: [f64; B] = std::array::from_fn(|m| x[at(start - B + m)]);
            for (m, &w) in exact.iter().enumerate() {
                let h = &responses[(k - 1) * B + m];
                for (p, hp) in (start..end).zip(h) {
                    x[at(p)] += w * hp;
                }
            }
        }
    }

    /// The same substitutions reading the last B results back from `x` (scalar stores and
    /// loads, forwarded): for wider bands, whose windows do not fit in registers.
    fn solve_in_memory<const B: usize>(&self, x: &mut [f64]) {
        let (n, inv) = (self.size, &self.inverse_diagonal);
        let (forward, backward) = (&self.forward, &self.backward);
        for i in 0..n {
            let coef: &[f64; B] = forward[i * B..(i + 1) * B].try_into().unwrap();
            let mut acc = x[i] * inv[i];
            for m in (B - i.min(B))..B {
                acc -= coef[m] * x[i + m - B];
            }
            x[i] = acc;
        }
        for i in (0..n).rev() {
            let coef: &[f64; B] = backward[i * B..(i + 1) * B].try_into().unwrap();
            let mut acc = x[i] * inv[i];
            for m in (i + B).saturating_sub(n - 1)..B {
                acc -= coef[m] * x[i + B - m];
            }
            x[i] = acc;
        }
    }

    fn solve_dynamic(&self, x: &mut [f64]) {
        let (n, b) = (self.size, self.bandwidth);
        let (l, inv) = (&self.data, &self.inverse_diagonal);
        for i in 0..n {
            let first = i.saturating_sub(b);
            let row = &l[i * (b + 1) + first + b - i..i * (b + 1) + b];
            let sum: f64 = row.iter().zip(&x[first..i]).map(|(a, v)| a * v).sum();
            x[i] = (x[i] - sum) * inv[i];
        }
        for i in (0..n).rev() {
            let mut acc = x[i];
            for j in (1..=b.min(n - 1 - i)).rev() {
                acc -= l[(i + j) * (b + 1) + b - j] * x[i + j];
            }
            x[i] = acc * inv[i];
        }
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

    #[test]
    fn fixed_and_dynamic_solves_agree() {
        // n = 40: one pass; n ≥ 64 (b ≤ 3): the segmented solves, uneven last segment
        for (b, n) in [1usize, 2, 3, 5, 7, 9]
            .into_iter()
            .flat_map(|b| [(b, 40usize), (b, 259), (b, 1000)])
        {
            let mut a = SymmetricBand::zeros(n, b);
            for i in 0..n {
                a.add(i, i, 10.0);
                for k in i.saturating_sub(b)..i {
                    a.add(i, k, ((i * 7 + k) % 5) as f64 * 0.2 - 0.4);
                }
            }
            let ch = a.cholesky().unwrap();
            let rhs: Vec<f64> = (0..n).map(|i| (i as f64).cos()).collect();
            let (mut x, mut y) = (rhs.clone(), rhs.clone());
            ch.solve_in_place(&mut x);
            ch.solve_dynamic(&mut y);
            let mut back = vec![0.0; n];
            a.mul_vec(&x, &mut back);
            assert!(x.iter().zip(&y).all(|(p, q)| (p - q).abs() < 1e-13));
            assert!(back.iter().zip(&rhs).all(|(p, q)| (p - q).abs() < 1e-12));
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
