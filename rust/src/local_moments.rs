//! Local mean and variance of an image over a (2r+1)² box: the locally adapted mean and
//! variance of the adaptive `denoise` (SPEC §2, README "denoise"). Near the borders the box
//! is cut to the image (the mean of the pixels it covers). Running sums along the rows then
//! the columns: O(1) per pixel whatever r. The sums are taken about the image's mean so that
//! E[z²] − E[z]² does not cancel for images with a large offset.

use crate::error::{FieldError, Result};
use rayon::prelude::*;

/// Box mean and (biased) variance of each of `frames` images (row-major height × width) over
/// the window of half-width `radius`, into `mean` and `var`.
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
    if !crate::vector_row_filter::all_finite(z) {
        return Err(FieldError::NonFinite(
            "the image holds NaN or infinite pixels".into(),
        ));
    }
    if size == 0 {
        return Ok(());
    }
    mean.par_chunks_mut(size)
        .zip(var.par_chunks_mut(size))
        .zip(z.par_chunks(size))
        .for_each(|((m, v), f)| frame_moments(f, height, width, radius, m, v));
    Ok(())
}

fn frame_moments(z: &[f64], h: usize, w: usize, r: usize, mean: &mut [f64], var: &mut [f64]) {
    let shift = sum(z) / z.len() as f64;
    let column_counts: Vec<f64> = (0..w)
        .map(|c| ((c + r).min(w - 1) + 1 - c.saturating_sub(r)) as f64)
        .collect();
    // the box sums along the rows (of z − shift and its square) of the 2r + 1 rows in the
    // window, in a ring; the window's column sums are running sums of whole rows
    let span = 2 * r + 1;
    let (mut ring_sum, mut ring_square) = (vec![0.0; span * w], vec![0.0; span * w]);
    let (mut window_sum, mut window_square) = (vec![0.0; w], vec![0.0; w]);
    for i in 0..(h + r) {
        if i > 2 * r && i - 2 * r - 1 < h {
            let old = (i - 2 * r - 1) % span * w..((i - 2 * r - 1) % span + 1) * w;
            add_row(&mut window_sum, &ring_sum[old.clone()], -1.0);
            add_row(&mut window_square, &ring_square[old], -1.0);
        }
        if i < h {
            let slot = i % span * w..(i % span + 1) * w;
            let (s, q) = (&mut ring_sum[slot.clone()], &mut ring_square[slot]);
            row_box_sums(&z[i * w..(i + 1) * w], shift, r, s, q);
            add_row(&mut window_sum, s, 1.0);
            add_row(&mut window_square, q, 1.0);
        }
        if i >= r {
            let out = i - r;
            let rows = ((out + r).min(h - 1) + 1 - out.saturating_sub(r)) as f64;
            let at = out * w..(out + 1) * w;
            for ((((m, v), s), q), cols) in mean[at.clone()]
                .iter_mut()
                .zip(&mut var[at])
                .zip(&window_sum)
                .zip(&window_square)
                .zip(&column_counts)
            {
                let inverse = 1.0 / (rows * cols);
                let centred = s * inverse;
                *v = (q * inverse - centred * centred).max(0.0);
                *m = centred + shift;
            }
        }
    }
}

fn add_row(window: &mut [f64], row: &[f64], sign: f64) {
    window.iter_mut().zip(row).for_each(|(s, v)| *s += sign * v);
}

/// sum[c] = Σ_{|j−c| ≤ r, 0 ≤ j < n} (x_j − shift) and square[c] the same of (x_j − shift)²,
/// by sliding sums (one addition per sum on the latency chain).
fn row_box_sums(x: &[f64], shift: f64, r: usize, sum: &mut [f64], square: &mut [f64]) {
    let n = x.len();
    let centred = |j: usize| x[j] - shift;
    let (mut s, mut q) = (0.0, 0.0);
    for j in 0..r.min(n) {
        s += centred(j);
        q += centred(j) * centred(j);
    }
    let mut emit = |c: usize, ds: f64, dq: f64| {
        s += ds;
        q += dq;
        sum[c] = s;
        square[c] = q;
    };
    // columns c ≤ r gain x_{c+r}; then each gains x_{c+r} and loses x_{c−r−1}; the last r
    // only lose
    let head = (r + 1).min(n);
    let tail = (n.saturating_sub(r)).max(head);
    for c in 0..head {
        let v = if c + r < n { centred(c + r) } else { 0.0 };
        emit(c, v, v * v);
    }
    for c in head..tail {
        let (v, u) = (centred(c + r), centred(c - r - 1));
        emit(c, v - u, v * v - u * u);
    }
    for c in tail..n {
        let u = centred(c - r - 1);
        emit(c, -u, -(u * u));
    }
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

    #[test]
    fn matches_a_brute_force_box() {
        let (h, w, r) = (7usize, 9usize, 2usize);
        let z: Vec<f64> = (0..h * w)
            .map(|k| ((k * 37 % 11) as f64).sin() + 100.0)
            .collect();
        let (mut m, mut v) = (vec![0.0; h * w], vec![0.0; h * w]);
        local_moments(&z, 1, h, w, r, &mut m, &mut v).unwrap();
        for i in 0..h {
            for c in 0..w {
                let mut vals = Vec::new();
                for a in i.saturating_sub(r)..=(i + r).min(h - 1) {
                    for b in c.saturating_sub(r)..=(c + r).min(w - 1) {
                        vals.push(z[a * w + b]);
                    }
                }
                let mu = vals.iter().sum::<f64>() / vals.len() as f64;
                let var = vals.iter().map(|x| (x - mu) * (x - mu)).sum::<f64>() / vals.len() as f64;
                assert!((m[i * w + c] - mu).abs() < 1e-12);
                assert!((v[i * w + c] - var).abs() < 1e-10);
            }
        }
    }

    #[test]
    fn refuses_bad_input() {
        let mut out = vec![0.0; 4];
        let mut var = vec![0.0; 4];
        assert!(local_moments(&[0.0; 3], 1, 2, 2, 1, &mut out, &mut var).is_err());
        assert!(local_moments(&[f64::NAN; 4], 1, 2, 2, 1, &mut out, &mut var).is_err());
    }
}
