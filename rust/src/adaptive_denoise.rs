//! The adaptive denoiser (README "denoise"; SPEC §2.3 generalised, with per-pixel noise):
//! z = x + θ with x = μ(s) + σ(s) ξ(s), where μ and σ² + σ_θ² are the mean and variance of
//! the (2r+1)² box around each pixel (`local_moments`; σ² floored at SIGNAL_FLOOR σ_θ²) and
//! ξ a unit-variance AR field of the given row model. The normalised residual
//! (z − μ)/σ = ξ + θ/σ is filtered by the quasi-optimal row filter (Toeplitz modes) with the
//! per-pixel weight w = σ²/σ_θ² (1/noise variance of the residual) and x̂ = μ + √(w σ_θ²) ξ̂.
//! With ρ = 0 this is the adaptive (Lee) Wiener filter; the row model adds the Kalman
//! smoothing along and across the rows. The filter's nominal noise variance is 1/median(w),
//! the median taken over a regular subsample of at most NOMINAL_SAMPLE pixels (it only sets
//! the prediction-error model; the per-pixel weights do the adapting).

use crate::error::{check_noise_var, FieldError, Result};
use crate::field_model::FieldModel;
use crate::local_moments::local_moments;
use crate::row_modes::ModeSet;
use crate::scalar_row_filter::ScalarRowFilter;
use crate::vector_row_filter::row_axes;
use rayon::prelude::*;

/// Floor of the local signal variance σ², in units of the noise variance.
pub const SIGNAL_FLOOR: f64 = 0.01;
/// Most pixels in the sample of the nominal noise variance's median.
pub const NOMINAL_SAMPLE: usize = 1 << 14;

/// What the adaptive denoiser needs besides the pixels.
#[derive(Debug, Clone, Copy)]
pub struct AdaptiveSettings<'a> {
    /// σ_θ².
    pub noise_var: f64,
    /// The row model of ξ (2 axes).
    pub model: &'a FieldModel,
    /// Half-width r of the (2r+1)² box.
    pub radius: usize,
    /// Run the RTS pass over the rows.
    pub smooth: bool,
}

/// Denoises `frames` images (row-major height × width) into `out`, frames in parallel.
pub fn adaptive_denoise(
    z: &[f64],
    frames: usize,
    height: usize,
    width: usize,
    settings: &AdaptiveSettings,
    out: &mut [f64],
) -> Result<()> {
    let size = height * width;
    if z.len() != frames * size || out.len() != z.len() {
        return Err(FieldError::Shape(format!(
            "adaptive_denoise: {} values for {frames}×{height}×{width}",
            z.len()
        )));
    }
    check_noise_var(settings.noise_var)?;
    row_axes(settings.model)?;
    if size == 0 {
        return Ok(());
    }
    out.par_chunks_mut(size)
        .zip(z.par_chunks(size))
        .try_for_each(|(o, f)| frame(f, height, width, settings, o))
}

fn frame(
    z: &[f64],
    height: usize,
    width: usize,
    settings: &AdaptiveSettings,
    out: &mut [f64],
) -> Result<()> {
    let noise_var = settings.noise_var;
    // `out` holds μ, then x̂; `var` the box variance, then ξ̂
    let mut var = vec![0.0; z.len()];
    local_moments(z, 1, height, width, settings.radius, out, &mut var)?;
    let mut residual = vec![0.0; z.len()];
    let mut weights = vec![0.0; z.len()];
    for (((r, w), (x, mu)), v) in residual
        .iter_mut()
        .zip(&mut weights)
        .zip(z.iter().zip(&*out))
        .zip(&var)
    {
        let signal = (v - noise_var).max(SIGNAL_FLOOR * noise_var);
        *w = signal / noise_var;
        *r = (x - mu) / signal.sqrt();
    }
    let nominal = 1.0 / sample_median(&weights);
    let filter = ScalarRowFilter::new(settings.model, nominal, width, None, ModeSet::Toeplitz)?;
    filter.filter_image(&residual, Some(&weights), &mut var, height, settings.smooth)?;
    for ((x, w), detail) in out.iter_mut().zip(&weights).zip(&var) {
        *x += (w * noise_var).sqrt() * detail;
    }
    Ok(())
}

/// The upper median of values[0], values[s], values[2s], … with s = ⌈len / NOMINAL_SAMPLE⌉.
fn sample_median(values: &[f64]) -> f64 {
    let stride = values.len().div_ceil(NOMINAL_SAMPLE);
    let mut sample: Vec<f64> = values.iter().step_by(stride).copied().collect();
    let middle = sample.len() / 2;
    *sample.select_nth_unstable_by(middle, f64::total_cmp).1
}

#[cfg(test)]
mod tests {
    use super::*;

    fn test_image(h: usize, w: usize) -> Vec<f64> {
        (0..h * w)
            .map(|k| {
                let (i, c) = ((k / w) as f64, (k % w) as f64);
                (0.3 * i).sin()
                    + if c > w as f64 / 2.0 { 2.0 } else { 0.0 }
                    + 0.3 * ((k * 7919 % 101) as f64 / 101.0 - 0.5)
            })
            .collect()
    }

    fn settings(noise_var: f64, model: &FieldModel, radius: usize) -> AdaptiveSettings<'_> {
        AdaptiveSettings {
            noise_var,
            model,
            radius,
            smooth: true,
        }
    }

    #[test]
    fn a_flat_image_stays_flat_and_frames_match_single_calls() {
        let model = FieldModel::new(&[0.7, 0.7], &[1, 1], 1.0).unwrap();
        let (h, w) = (12, 15);
        let flat = vec![3.0; h * w];
        let mut out = vec![0.0; h * w];
        adaptive_denoise(&flat, 1, h, w, &settings(0.1, &model, 2), &mut out).unwrap();
        assert!(out.iter().all(|v| (v - 3.0).abs() < 1e-12));
        let image = test_image(h, w);
        let stack: Vec<f64> = flat.iter().chain(&image).copied().collect();
        let mut both = vec![0.0; 2 * h * w];
        adaptive_denoise(&stack, 2, h, w, &settings(0.1, &model, 2), &mut both).unwrap();
        let mut single = vec![0.0; h * w];
        adaptive_denoise(&image, 1, h, w, &settings(0.1, &model, 2), &mut single).unwrap();
        assert_eq!(&both[h * w..], &single[..]);
    }

    #[test]
    fn median_of_a_sample() {
        assert_eq!(sample_median(&[3.0, 1.0, 2.0]), 2.0);
        assert_eq!(sample_median(&[4.0, 1.0, 3.0, 2.0]), 3.0);
        let many: Vec<f64> = (0..3 * NOMINAL_SAMPLE).map(|k| k as f64).collect();
        // every third value, 0, 3, …: the upper median of the sample
        assert_eq!(sample_median(&many), (3 * (NOMINAL_SAMPLE / 2)) as f64);
    }

    #[test]
    fn bad_input_is_an_error() {
        let model = FieldModel::new(&[0.7, 0.7], &[1, 1], 1.0).unwrap();
        let mut out = vec![0.0; 12];
        let z = vec![1.0; 12];
        assert!(adaptive_denoise(&z, 1, 3, 4, &settings(0.0, &model, 1), &mut out).is_err());
        assert!(adaptive_denoise(&z[..11], 1, 3, 4, &settings(0.1, &model, 1), &mut out).is_err());
        let mut nan = z.clone();
        nan[5] = f64::NAN;
        assert!(adaptive_denoise(&nan, 1, 3, 4, &settings(0.1, &model, 1), &mut out).is_err());
        let line = FieldModel::new(&[0.7], &[1], 1.0).unwrap();
        assert!(adaptive_denoise(&z, 1, 3, 4, &settings(0.1, &line, 1), &mut out).is_err());
    }
}
