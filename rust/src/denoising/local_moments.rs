//! Local mean and variance of an image over a (2r+1)² box: the locally adapted mean and
//! variance of the adaptive `denoise` (SPEC §2). Near the borders the box is cut to the
//! image (the mean of the pixels it covers). Running sums along the rows then
//! the columns: O(1) per pixel whatever r. The sums are taken about the image's mean so that
//! E[z²] − E[z]² does not cancel for images with a large offset. NaN pixels are missing: the
//! moments are those of the box's other pixels, and NaN where the box holds none.

use crate::error::{FieldError, Result};
use crate::simd::{self, Arith, Kernel};
use rayon::prelude::*;

/// Box mean and (biased) variance of each of `frames` images (row-major height × width) over
/// the window of half-width `radius`, into `mean` and `var` (NaN pixels left out; NaN where a
/// box holds no other pixel).
pub fn local_moments(
    z: &[f64],
    frames: usize,
    height: usize,
    width: usize,
    radius: usize,
    mean: &mut [f64],
    var: &mut [f64],
) -> Result<()> {
    let size = height * width;
    if z.len() != frames * size || mean.len() != z.len() || var.len() != z.len() {
        return Err(FieldError::Shape(format!(
            "local_moments: {} values for {frames}×{height}×{width}",
            z.len()
        )));
    }
    if !sum(z).is_finite() && z.iter().any(|v| v.is_infinite()) {
        return Err(FieldError::NonFinite(
            "the image holds infinite pixels".into(),
        ));
    }
    if size == 0 {
        return Ok(());
    }
    // a box reaching max(height, width) pixels out covers the frame from every pixel: a wider
    // one gives the same moments (and would size the running sums' buffers by the radius)
    let radius = radius.min(height.max(width));
    let one_frame = |((m, v), f): ((&mut [f64], &mut [f64]), &[f64])| {
        let total = sum(f);
        if total.is_nan() {
            frame_moments::<true>(f, observed_mean(f), (height, width, radius), m, v);
        } else {
            let shift = total / f.len() as f64;
            frame_moments::<false>(f, shift, (height, width, radius), m, v);
        }
    };
    if frames == 1 {
        // on this thread: no hand-over to the pool for a single frame
        one_frame(((mean, var), z));
        return Ok(());
    }
    mean.par_chunks_mut(size)
        .zip(var.par_chunks_mut(size))
        .zip(z.par_chunks(size))
        .for_each(one_frame);
    Ok(())
}

/// [`frame_moments_of`] compiled for AVX2 where the CPU has it (four columns per instruction).
fn frame_moments<const MASKED: bool>(
    z: &[f64],
    shift: f64,
    shape: (usize, usize, usize),
    mean: &mut [f64],
    var: &mut [f64],
) {
    simd::dispatch(FrameMoments::<MASKED> {
        z,
        shift,
        shape,
        mean,
        var,
    })
}

/// The arguments of [`frame_moments_of`], a [`Kernel`] of `simd::dispatch`.
struct FrameMoments<'a, const MASKED: bool> {
    z: &'a [f64],
    shift: f64,
    shape: (usize, usize, usize),
    mean: &'a mut [f64],
    var: &'a mut [f64],
}

impl<const MASKED: bool> Kernel for FrameMoments<'_, MASKED> {
    type Output = ();
    #[inline(always)]
    fn run<A: Arith>(self) {
        frame_moments_of::<MASKED>(self.z, self.shift, self.shape, self.mean, self.var)
    }
}

/// The box sums along the rows of the 2r + 1 rows in the window are kept in a ring; the
/// window's column sums are running sums of whole rows. Three sums per pixel: of z − shift
/// (shift: the mean of the observed pixels), of its square and, when MASKED (the frame has
/// NaN pixels), of the observed pixels; without NaN the counts are the cut box's area.
#[inline(always)]
fn frame_moments_of<const MASKED: bool>(
    z: &[f64],
    shift: f64,
    (h, w, r): (usize, usize, usize),
    mean: &mut [f64],
    var: &mut [f64],
) {
    let column_counts: Vec<f64> = (0..w)
        .map(|c| ((c + r).min(w - 1) + 1 - c.saturating_sub(r)) as f64)
        .collect();
    let span = 2 * r + 1;
    let sums = if MASKED { 3 } else { 2 };
    let mut ring: Vec<Vec<f64>> = vec![vec![0.0; span * w]; sums];
    let mut window: Vec<Vec<f64>> = vec![vec![0.0; w]; sums];
    for i in 0..(h + r) {
        if i > 2 * r && i - 2 * r - 1 < h {
            let old = (i - 2 * r - 1) % span * w..((i - 2 * r - 1) % span + 1) * w;
            for (total, row) in window.iter_mut().zip(&ring) {
                add_row(total, &row[old.clone()], -1.0);
            }
        }
        if i < h {
            let slot = i % span * w..(i % span + 1) * w;
            let [s, q, n] = ring_rows(&mut ring, slot);
            row_box_sums::<MASKED>(&z[i * w..(i + 1) * w], shift, r, [s, q, n]);
            for (total, row) in window.iter_mut().zip(&ring) {
                add_row(total, &row[i % span * w..(i % span + 1) * w], 1.0);
            }
        }
        if i >= r {
            let out = i - r;
            let rows = ((out + r).min(h - 1) + 1 - out.saturating_sub(r)) as f64;
            let at = out * w..(out + 1) * w;
            let (m, v) = (&mut mean[at.clone()], &mut var[at]);
            let (sums, squares) = (&window[0][..w], &window[1][..w]);
            let counts = if MASKED {
                &window[2][..w]
            } else {
                &column_counts[..w]
            };
            for c in 0..w {
                let count = if MASKED { counts[c] } else { rows * counts[c] };
                let inverse = 1.0 / count;
                let centred = sums[c] * inverse;
                v[c] = (squares[c] * inverse - centred * centred).max(0.0);
                m[c] = centred + shift;
                if MASKED && count == 0.0 {
                    (m[c], v[c]) = (f64::NAN, f64::NAN);
                }
            }
        }
    }
}

/// The ring's rows at `slot` of the (two or three) sums; the count's is empty when the ring
/// has no count.
fn ring_rows(ring: &mut [Vec<f64>], slot: std::ops::Range<usize>) -> [&mut [f64]; 3] {
    let mut rows = ring.iter_mut().map(|r| &mut r[slot.clone()]);
    let s = rows.next().expect("the sum's ring");
    let q = rows.next().expect("the square's ring");
    [s, q, rows.next().unwrap_or_default()]
}

fn add_row(window: &mut [f64], row: &[f64], sign: f64) {
    window.iter_mut().zip(row).for_each(|(s, v)| *s += sign * v);
}

/// sums[0][c] = Σ_{|j−c| ≤ r, 0 ≤ j < n} (x_j − shift), sums[1][c] the same of
/// (x_j − shift)² and, when MASKED, sums[2][c] the number of those x_j that are not NaN (NaN
/// adds nothing), by sliding sums (one addition per sum on the latency chain).
fn row_box_sums<const MASKED: bool>(x: &[f64], shift: f64, r: usize, sums: [&mut [f64]; 3]) {
    let n = x.len();
    // (x_j − shift, observed) with a missing x_j as (0, 0)
    let term = |j: usize| {
        let v = x[j] - shift;
        if MASKED && v.is_nan() {
            (0.0, 0.0)
        } else {
            (v, 1.0)
        }
    };
    let [sum, square, count] = sums;
    let (mut s, mut q, mut k) = (0.0, 0.0, 0.0);
    for j in 0..r.min(n) {
        let (v, o) = term(j);
        (s, q, k) = (s + v, q + v * v, k + o);
    }
    let mut emit = |c: usize, (v, o): (f64, f64), (u, p): (f64, f64)| {
        s += v - u;
        q += v * v - u * u;
        sum[c] = s;
        square[c] = q;
        if MASKED {
            k += o - p;
            count[c] = k;
        }
    };
    // columns c ≤ r gain x_{c+r}; then each gains x_{c+r} and loses x_{c−r−1}; the last r
    // only lose
    let head = (r + 1).min(n);
    let tail = (n.saturating_sub(r)).max(head);
    let none = (0.0, 0.0);
    for c in 0..head {
        emit(c, if c + r < n { term(c + r) } else { none }, none);
    }
    for c in head..tail {
        emit(c, term(c + r), term(c - r - 1));
    }
    for c in tail..n {
        emit(c, none, term(c - r - 1));
    }
}

/// The mean of the pixels that are not NaN (0 if none).
fn observed_mean(x: &[f64]) -> f64 {
    let (total, count) = x
        .iter()
        .filter(|v| !v.is_nan())
        .fold((0.0, 0usize), |(t, n), v| (t + v, n + 1));
    if count == 0 {
        return 0.0;
    }
    total / count as f64
}

/// Σ x with LANES independent accumulators (a single one is a chain of additions).
fn sum(x: &[f64]) -> f64 {
    const LANES: usize = 8;
    let mut acc = [0.0; LANES];
    let mut blocks = x.chunks_exact(LANES);
    for block in &mut blocks {
        for (a, v) in acc.iter_mut().zip(block) {
            *a += v;
        }
    }
    acc.iter().sum::<f64>() + blocks.remainder().iter().sum::<f64>()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Box mean and variance of the non-NaN pixels by brute force (None: no such pixel).
    fn brute_force(
        z: &[f64],
        (h, w, r): (usize, usize, usize),
        i: usize,
        c: usize,
    ) -> Option<(f64, f64)> {
        let mut vals = Vec::new();
        for a in i.saturating_sub(r)..=(i + r).min(h - 1) {
            for b in c.saturating_sub(r)..=(c + r).min(w - 1) {
                if !z[a * w + b].is_nan() {
                    vals.push(z[a * w + b]);
                }
            }
        }
        let n = vals.len() as f64;
        let mu = vals.iter().sum::<f64>() / n;
        let var = vals.iter().map(|x| (x - mu) * (x - mu)).sum::<f64>() / n;
        (!vals.is_empty()).then_some((mu, var))
    }

    fn assert_brute_force(z: &[f64], (h, w, r): (usize, usize, usize)) {
        let (mut m, mut v) = (vec![0.0; h * w], vec![0.0; h * w]);
        local_moments(z, 1, h, w, r, &mut m, &mut v).unwrap();
        for i in 0..h {
            for c in 0..w {
                let (got_m, got_v) = (m[i * w + c], v[i * w + c]);
                match brute_force(z, (h, w, r), i, c) {
                    Some((mu, var)) => {
                        assert!((got_m - mu).abs() < 1e-12, "mean at {i},{c}");
                        assert!((got_v - var).abs() < 1e-10, "variance at {i},{c}");
                    }
                    None => assert!(got_m.is_nan() && got_v.is_nan(), "empty box at {i},{c}"),
                }
            }
        }
    }

    fn test_image(h: usize, w: usize) -> Vec<f64> {
        (0..h * w)
            .map(|k| ((k * 37 % 11) as f64).sin() + 100.0)
            .collect()
    }

    #[test]
    fn matches_a_brute_force_box() {
        assert_brute_force(&test_image(7, 9), (7, 9, 2));
    }

    #[test]
    fn missing_pixels_are_left_out_and_an_empty_box_is_nan() {
        let (h, w, r) = (9usize, 11usize, 1usize);
        let mut z = test_image(h, w);
        for k in (0..h * w).filter(|k| k % 7 == 3) {
            z[k] = f64::NAN;
        }
        // a 4 × 4 hole: the boxes of its inner 2 × 2 pixels hold no observed pixel
        for i in 2..6 {
            z[i * w + 4..i * w + 8].fill(f64::NAN);
        }
        assert_brute_force(&z, (h, w, r));
        let (mut m, mut v) = (vec![0.0; h * w], vec![0.0; h * w]);
        local_moments(&z, 1, h, w, r, &mut m, &mut v).unwrap();
        assert!(m[3 * w + 5].is_nan() && m[2 * w + 5].is_finite());
    }

    #[test]
    fn refuses_bad_input() {
        let mut out = vec![0.0; 4];
        let mut var = vec![0.0; 4];
        assert!(local_moments(&[0.0; 3], 1, 2, 2, 1, &mut out, &mut var).is_err());
        assert!(local_moments(&[f64::INFINITY; 4], 1, 2, 2, 1, &mut out, &mut var).is_err());
        // all missing: no error, every moment NaN
        local_moments(&[f64::NAN; 4], 1, 2, 2, 1, &mut out, &mut var).unwrap();
        assert!(out.iter().chain(&var).all(|v| v.is_nan()));
    }
}
