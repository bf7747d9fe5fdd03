//! The adaptive denoiser (`kalmanfield.denoise`; SPEC §2.3 generalised, with per-pixel noise):
//! z = x + θ with x = μ(s) + σ(s) ξ(s), where μ and σ² + σ_θ² are the mean and variance of
//! the (2r+1)² box around each pixel (`local_moments`; σ² floored at SIGNAL_FLOOR σ_θ²) and
//! ξ a unit-variance AR field of the given row model. The normalised residual
//! (z − μ)/σ = ξ + θ/σ is filtered by the quasi-optimal row filter (Toeplitz modes) with the
//! per-pixel weight w = σ²/σ_θ² (1/noise variance of the residual) and x̂ = μ + σ ξ̂.
//! With ρ = 0 this is the adaptive (Lee) Wiener filter; the row model adds the Kalman
//! smoothing along and across the rows. The filter's nominal noise variance is 1/median(w),
//! the median taken over a regular subsample of at most NOMINAL_SAMPLE pixels (it only sets
//! the prediction-error model; the per-pixel weights do the adapting). NaN pixels are
//! missing: left out of the box moments, weight 0 in the filter (its ξ̂ there is predicted
//! from the neighbours), σ kept; where a box holds no observed pixel, it is widened until it
//! holds one.

use super::local_moments::local_moments;
use super::scratch::Scratch;
use crate::error::{check_noise_var, FieldError, Result};
use crate::field::FieldModel;
use crate::rowfilter::row_axes;
use crate::rowfilter::ModeSet;
use crate::rowfilter::{model_ar_order, RowModels, ScalarRowFilter};
use crate::simd::{self, Arith, Kernel};
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
    /// The filter's row models for the per-pixel weights.
    pub row_models: RowModels,
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
    if frames == 1 {
        // on the calling thread (GIL released), which keeps its scratch buffers between calls
        return frame(z, height, width, settings, out);
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
    // a pool thread may hold dirty upper vector halves (see `simd::clear_upper_state`): the median and
    // the final x̂ below are baseline SSE2 code (the box moments and the normalisation run
    // their AVX2 builds where the CPU has them)
    simd::clear_upper_state();
    let noise_var = settings.noise_var;
    // `out` holds μ, then x̂; `scale` the box variance, then σ
    let mut scale = Scratch::zeros(z.len());
    local_moments(z, 1, height, width, settings.radius, out, &mut scale)?;
    widen_empty_boxes(z, (height, width, settings.radius), out, &mut scale)?;
    if !scale.iter().all(|v| v.is_finite()) {
        return Err(overflow());
    }
    let mut residual = Scratch::zeros(z.len());
    let mut weights = Scratch::zeros(z.len());
    normalise(z, out, &mut scale, &mut residual, &mut weights, noise_var);
    let nominal = 1.0 / sample_median(&weights);
    // not the filter's default: every row here is weighted (refitted at O(W m³)), and the
    // detail model's short reach gains nothing from a longer row model
    let m = model_ar_order(row_axes(settings.model)?.1.order());
    let filter = ScalarRowFilter::new(settings.model, nominal, width, Some(m), ModeSet::Toeplitz)?
        .with_row_models(settings.row_models);
    let mut detail = Scratch::zeros(z.len());
    filter.filter_image(
        &residual,
        Some(&weights),
        &mut detail,
        height,
        settings.smooth,
    )?;
    for ((x, s), d) in out.iter_mut().zip(scale.iter()).zip(detail.iter()) {
        *x += s * d;
    }
    Ok(())
}

/// Per pixel, from the box mean μ and variance v: σ² = max(v − σ_θ², SIGNAL_FLOOR σ_θ²),
/// `scale` ← σ, weight σ²/σ_θ² and residual (z − μ)/σ; a missing pixel gets weight 0 and
/// residual 0 (σ is kept for x̂ = μ + σ ξ̂). Four pixels per instruction where AVX2 runs.
fn normalise(
    z: &[f64],
    mean: &[f64],
    scale: &mut [f64],
    residual: &mut [f64],
    weights: &mut [f64],
    noise_var: f64,
) {
    simd::dispatch(Normalise {
        z,
        mean,
        scale,
        residual,
        weights,
        noise_var,
    })
}

/// The arguments of [`normalise_pixels`], a [`Kernel`] of `simd::dispatch`.
struct Normalise<'a> {
    z: &'a [f64],
    mean: &'a [f64],
    scale: &'a mut [f64],
    residual: &'a mut [f64],
    weights: &'a mut [f64],
    noise_var: f64,
}

impl Kernel for Normalise<'_> {
    type Output = ();
    #[inline(always)]
    fn run<A: Arith>(self) {
        let Normalise {
            z,
            mean,
            scale,
            residual,
            weights,
            noise_var,
        } = self;
        normalise_pixels(z, mean, scale, residual, weights, noise_var)
    }
}

#[inline(always)]
fn normalise_pixels(
    z: &[f64],
    mean: &[f64],
    scale: &mut [f64],
    residual: &mut [f64],
    weights: &mut [f64],
    noise_var: f64,
) {
    let floor = SIGNAL_FLOOR * noise_var;
    let n = z.len();
    let (mean, scale) = (&mean[..n], &mut scale[..n]);
    let (residual, weights) = (&mut residual[..n], &mut weights[..n]);
    for k in 0..n {
        let signal = (scale[k] - noise_var).max(floor);
        let sigma = signal.sqrt();
        let observed = !z[k].is_nan();
        scale[k] = sigma;
        weights[k] = if observed { signal / noise_var } else { 0.0 };
        residual[k] = if observed {
            (z[k] - mean[k]) / sigma
        } else {
            0.0
        };
    }
}

/// The error of pixels whose local moments overflow float64.
fn overflow() -> FieldError {
    FieldError::NonFinite(
        "the pixels' local moments overflow float64 (squares of |z| ≳ 1e154): rescale the image"
            .into(),
    )
}

/// Where a box holds no observed pixel (its moments are NaN), the moments of the box widened
/// to radius 2r + 1, then 2(2r + 1) + 1, … until it holds one (at the latest when it covers
/// the frame). An error if the frame has no observed pixel.
fn widen_empty_boxes(
    z: &[f64],
    (height, width, radius): (usize, usize, usize),
    mean: &mut [f64],
    var: &mut [f64],
) -> Result<()> {
    if !mean.iter().any(|m| m.is_nan()) {
        return Ok(());
    }
    if z.iter().all(|v| v.is_nan()) {
        return Err(FieldError::NonFinite(
            "a frame has no observed pixel: every pixel is NaN".into(),
        ));
    }
    let (mut wide_mean, mut wide_var) = (Scratch::zeros(z.len()), Scratch::zeros(z.len()));
    let (mut radius, whole) = (radius, height.max(width)); // (a box of radius `whole`: the frame)
    while mean.iter().any(|m| m.is_nan()) {
        if radius >= whole {
            // every box held an observed pixel, so the moments overflowed float64
            return Err(overflow());
        }
        radius = (2 * radius + 1).min(whole);
        local_moments(z, 1, height, width, radius, &mut wide_mean, &mut wide_var)?;
        for ((m, v), (wm, wv)) in mean
            .iter_mut()
            .zip(&mut *var)
            .zip(wide_mean.iter().zip(wide_var.iter()))
        {
            if m.is_nan() {
                (*m, *v) = (*wm, *wv);
            }
        }
    }
    Ok(())
}

/// The upper median of the observed (> 0) values among values[0], values[s], values[2s], …
/// with s = ⌈len / NOMINAL_SAMPLE⌉; of all the observed values if that sample holds none.
/// The caller has made sure that some value is observed.
fn sample_median(values: &[f64]) -> f64 {
    let stride = values.len().div_ceil(NOMINAL_SAMPLE);
    let observed = |v: &f64| *v > 0.0;
    let mut sample: Vec<f64> = values
        .iter()
        .step_by(stride)
        .copied()
        .filter(observed)
        .collect();
    if sample.is_empty() {
        sample = values.iter().copied().filter(observed).collect();
    }
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
            row_models: RowModels::Nominal,
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
    fn missing_pixels_of_a_flat_image_are_filled_flat() {
        let model = FieldModel::new(&[0.7, 0.7], &[1, 1], 1.0).unwrap();
        let (h, w) = (16, 14);
        let mut z = vec![3.0; h * w];
        z[17] = f64::NAN;
        // a hole wider than the 5 × 5 window: its centre's boxes are widened
        for i in 4..12 {
            z[i * w + 3..i * w + 11].fill(f64::NAN);
        }
        let mut out = vec![0.0; h * w];
        adaptive_denoise(&z, 1, h, w, &settings(0.1, &model, 2), &mut out).unwrap();
        assert!(out.iter().all(|v| (v - 3.0).abs() < 1e-12), "{out:?}");
    }

    #[test]
    fn median_of_a_sample() {
        assert_eq!(sample_median(&[3.0, 1.0, 2.0]), 2.0);
        assert_eq!(sample_median(&[4.0, 1.0, 3.0, 2.0]), 3.0);
        let many: Vec<f64> = (0..3 * NOMINAL_SAMPLE).map(|k| k as f64).collect();
        // every third value, 3, 6, … (0 counts as unobserved): the upper median of the sample
        assert_eq!(sample_median(&many), (3 * (NOMINAL_SAMPLE / 2)) as f64);
        // the unobserved (0) values are left out; if the sample holds none observed, all are used
        assert_eq!(sample_median(&[0.0, 5.0, 0.0, 1.0, 2.0]), 2.0);
        let mut sparse = vec![0.0; 3 * NOMINAL_SAMPLE];
        sparse[1] = 7.0;
        assert_eq!(sample_median(&sparse), 7.0);
    }

    #[test]
    fn bad_input_is_an_error() {
        let model = FieldModel::new(&[0.7, 0.7], &[1, 1], 1.0).unwrap();
        let mut out = vec![0.0; 12];
        let z = vec![1.0; 12];
        assert!(adaptive_denoise(&z, 1, 3, 4, &settings(0.0, &model, 1), &mut out).is_err());
        assert!(adaptive_denoise(&z[..11], 1, 3, 4, &settings(0.1, &model, 1), &mut out).is_err());
        let mut inf = z.clone();
        inf[5] = f64::INFINITY;
        assert!(adaptive_denoise(&inf, 1, 3, 4, &settings(0.1, &model, 1), &mut out).is_err());
        let nan = vec![f64::NAN; 12];
        assert!(adaptive_denoise(&nan, 1, 3, 4, &settings(0.1, &model, 1), &mut out).is_err());
        let line = FieldModel::new(&[0.7], &[1], 1.0).unwrap();
        assert!(adaptive_denoise(&z, 1, 3, 4, &settings(0.1, &line, 1), &mut out).is_err());
    }
}
