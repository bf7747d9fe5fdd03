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
    if z.iter().any(|v| !v.is_finite()) {
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
    let shift = z.iter().sum::<f64>() / z.len() as f64;
    // box sums along the rows, of z − shift (into mean) and its square (into var)
    for (row, (m, v)) in z
        .chunks_exact(w)
        .zip(mean.chunks_exact_mut(w).zip(var.chunks_exact_mut(w)))
    {
        box_sums(row.iter().map(|x| x - shift), r, m);
        box_sums(row.iter().map(|x| (x - shift) * (x - shift)), r, v);
    }
    // then along the columns: a running sum of whole rows (contiguous, vectorised)
    for out in [&mut *mean, &mut *var] {
        let rows = out.to_vec();
        let mut window = vec![0.0; w];
        for i in 0..(h + r) {
            if i < h {
                add_row(&mut window, &rows[i * w..(i + 1) * w], 1.0);
            }
            if i > 2 * r && i - 2 * r - 1 < h {
                add_row(
                    &mut window,
                    &rows[(i - 2 * r - 1) * w..(i - 2 * r) * w],
                    -1.0,
                );
            }
            if i >= r {
                out[(i - r) * w..(i - r + 1) * w].copy_from_slice(&window);
            }
        }
    }
    for i in 0..h {
        let rows = (i + r).min(h - 1) + 1 - i.saturating_sub(r);
        for c in 0..w {
            let cols = (c + r).min(w - 1) + 1 - c.saturating_sub(r);
            let count = (rows * cols) as f64;
            let k = i * w + c;
            let m = mean[k] / count;
            var[k] = (var[k] / count - m * m).max(0.0);
            mean[k] = m + shift;
        }
    }
}

fn add_row(window: &mut [f64], row: &[f64], sign: f64) {
    window.iter_mut().zip(row).for_each(|(s, v)| *s += sign * v);
}

/// out[i] = Σ_{|j−i| ≤ r, 0 ≤ j < n} x[j] by a running sum.
fn box_sums(x: impl Iterator<Item = f64>, r: usize, out: &mut [f64]) {
    let n = out.len();
    let mut prefix = Vec::with_capacity(n + 1);
    prefix.push(0.0);
    let mut acc = 0.0;
    for v in x {
        acc += v;
        prefix.push(acc);
    }
    for (i, o) in out.iter_mut().enumerate() {
        *o = prefix[(i + r + 1).min(n)] - prefix[i.saturating_sub(r)];
    }
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
