//! The noise level of an image (the observation noise θ of `denoise`): Donoho's robust estimate of the variance
//! σ_θ² of white noise from the finest diagonal Haar details. The detail
//! d = (z₀₀ − z₀₁ − z₁₀ + z₁₁)/2 of a 2×2 block is ~0 on a smooth image and N(0, σ_θ²) on
//! white noise, so σ̂_θ = median|d| / Φ⁻¹(3/4) (the normal's quartile) ignores the few blocks
//! on edges and texture.

use crate::error::{FieldError, Result};

/// The normal distribution's upper quartile Φ⁻¹(3/4) (Donoho and Johnstone round it to
/// 0.6745, a bias of 3e-5 in σ̂²).
pub(crate) const NORMAL_QUARTILE: f64 = 0.674_489_750_196_081_7;

/// σ̂_θ² from the disjoint 2×2 blocks of `frames` images (row-major height × width), pooled
/// over the frames (an odd last row or column is left out). Blocks with a NaN (missing) or
/// infinite pixel are left out. The median of an even count is the mean of the two middle
/// values (as NumPy's). Errors: an image smaller than 2×2, or no block without a missing
/// pixel.
pub fn haar_mad_noise_var(z: &[f64], frames: usize, height: usize, width: usize) -> Result<f64> {
    if z.len() != frames * height * width {
        return Err(FieldError::Shape(format!(
            "noise level: {} values for {frames}×{height}×{width}",
            z.len()
        )));
    }
    if height < 2 || width < 2 {
        return Err(FieldError::Shape(format!(
            "need an image of at least 2×2 pixels, got {height}×{width}"
        )));
    }
    // |d| as bits: the order of non-negative floats is that of their bit patterns, and
    // integers are quicker to select among than floats through a comparison function
    let mut details = Vec::with_capacity(frames * (height / 2) * (width / 2));
    for frame in z.chunks_exact(height * width) {
        for i in (0..height - 1).step_by(2) {
            let (upper, lower) = (
                &frame[i * width..][..width],
                &frame[(i + 1) * width..][..width],
            );
            for (u, l) in upper.chunks_exact(2).zip(lower.chunks_exact(2)) {
                let d = (u[0] - u[1] - l[0] + l[1]) / 2.0;
                if d.is_finite() {
                    details.push(d.abs().to_bits());
                }
            }
        }
    }
    let sigma = median_of_bits(&mut details).ok_or_else(|| {
        FieldError::NonFinite(
            "no 2×2 block without a NaN (missing) or infinite pixel: cannot estimate the noise"
                .into(),
        )
    })? / NORMAL_QUARTILE;
    Ok(sigma * sigma)
}

/// The median of non-negative finite floats given as bits (reordered); None when empty.
fn median_of_bits(bits: &mut [u64]) -> Option<f64> {
    let n = bits.len();
    if n == 0 {
        return None;
    }
    let (lower, upper, _) = bits.select_nth_unstable(n / 2);
    let upper = f64::from_bits(*upper);
    if n % 2 == 1 {
        return Some(upper);
    }
    let lower = f64::from_bits(*lower.iter().max().expect("n ≥ 2"));
    Some((lower + upper) / 2.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The plain definition: sorted |d| of the blocks without a NaN.
    fn by_sorting(z: &[f64], frames: usize, h: usize, w: usize) -> f64 {
        let mut d = Vec::new();
        for f in 0..frames {
            let at = |i: usize, j: usize| z[(f * h + i) * w + j];
            for i in (0..h / 2 * 2).step_by(2) {
                for j in (0..w / 2 * 2).step_by(2) {
                    let v = (at(i, j) - at(i, j + 1) - at(i + 1, j) + at(i + 1, j + 1)) / 2.0;
                    if v.is_finite() {
                        d.push(v.abs());
                    }
                }
            }
        }
        d.sort_by(f64::total_cmp);
        let n = d.len();
        let median = if n % 2 == 1 {
            d[n / 2]
        } else {
            (d[n / 2 - 1] + d[n / 2]) / 2.0
        };
        (median / NORMAL_QUARTILE).powi(2)
    }

    fn pseudo_random(len: usize, seed: u64) -> Vec<f64> {
        let mut state = seed;
        (0..len)
            .map(|_| {
                state = state
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
            })
            .collect()
    }

    #[test]
    fn equals_the_sorted_median_for_odd_and_even_counts_and_odd_sizes() {
        for (frames, h, w) in [(1, 6, 8), (1, 7, 9), (2, 5, 4), (3, 2, 2), (1, 4, 6)] {
            let mut z = pseudo_random(frames * h * w, (h * w) as u64);
            z[3] = f64::NAN;
            let got = haar_mad_noise_var(&z, frames, h, w).unwrap();
            assert_eq!(got, by_sorting(&z, frames, h, w), "{frames}×{h}×{w}");
        }
    }

    #[test]
    fn a_smooth_ramp_has_no_noise_and_one_block_is_enough() {
        let ramp: Vec<f64> = (0..48)
            .map(|k| 0.5 * (k / 8) as f64 + 0.25 * (k % 8) as f64)
            .collect();
        assert_eq!(haar_mad_noise_var(&ramp, 1, 6, 8).unwrap(), 0.0);
        let block = [1.0, -1.0, -1.0, 1.0];
        let want = (2.0 / NORMAL_QUARTILE).powi(2);
        assert_eq!(haar_mad_noise_var(&block, 1, 2, 2).unwrap(), want);
    }

    #[test]
    fn the_quartile_is_the_normals() {
        use statrs::distribution::{ContinuousCDF, Normal};
        let quartile = Normal::standard().inverse_cdf(0.75);
        assert!((NORMAL_QUARTILE - quartile).abs() < 1e-15, "{quartile}");
    }

    #[test]
    fn bad_input_is_an_error() {
        assert!(haar_mad_noise_var(&[0.0; 4], 1, 1, 4).is_err());
        assert!(haar_mad_noise_var(&[0.0; 5], 1, 2, 2).is_err());
        let holes = [f64::NAN, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, f64::NAN];
        assert!(haar_mad_noise_var(&holes, 1, 2, 4).is_err());
        assert!(haar_mad_noise_var(&[], 0, 4, 4).is_err());
    }
}
