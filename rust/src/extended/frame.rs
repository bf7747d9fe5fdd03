//! Frame preparation of the detector (SPEC §3.4, method page *Extended objects*): the box
//! mean before thresholding and the background level (median) of the automatic threshold.
//! The twin is `kalmanfield.reference.extended.frames` (same summation order).

/// Frames beyond this many pixels take the median of every 4th row and column.
const FULL_MEDIAN_PIXELS: usize = 65536;

/// Mean over a `width` × `width` box centred on each pixel of an `h` × `w` row-major image,
/// edges repeated (the box spans `width / 2` before and `width − 1 − width / 2` after): per
/// output row, a column sum then a row sum over the edge-padded column sums, each summing its
/// `width` terms in order (one allocation, no index arithmetic in the inner loops).
pub fn box_smooth(image: &[f64], h: usize, w: usize, width: usize) -> Vec<f64> {
    if width <= 1 {
        return image.to_vec();
    }
    let lo = width / 2;
    let clamp = |i: usize, n: usize| i.saturating_sub(lo).min(n - 1);
    let scale = (width * width) as f64;
    let mut out = vec![0.0; h * w];
    let mut column = vec![0.0; w];
    let mut padded = vec![0.0; w + width - 1];
    for i in 0..h {
        column.copy_from_slice(&image[clamp(i, h) * w..][..w]);
        for k in 1..width {
            let src = &image[clamp(i + k, h) * w..][..w];
            for (c, s) in column.iter_mut().zip(src) {
                *c += s;
            }
        }
        padded[..lo].fill(column[0]);
        padded[lo..lo + w].copy_from_slice(&column);
        padded[lo + w..].fill(column[w - 1]);
        let row = &mut out[i * w..(i + 1) * w];
        row.copy_from_slice(&padded[..w]);
        for k in 1..width {
            for (o, s) in row.iter_mut().zip(&padded[k..k + w]) {
                *o += s;
            }
        }
        for o in row.iter_mut() {
            *o /= scale;
        }
    }
    out
}

/// Median of the image (of every 4th row and column beyond 65536 pixels); the mean of the
/// two middle values for an even count, as NumPy. NaN-free input; 0 for an empty image.
pub fn background_level(image: &[f64], h: usize, w: usize) -> f64 {
    let step = if h * w <= FULL_MEDIAN_PIXELS { 1 } else { 4 };
    let mut values: Vec<f64> = (0..h)
        .step_by(step)
        .flat_map(|i| (0..w).step_by(step).map(move |j| image[i * w + j]))
        .collect();
    let n = values.len();
    if n == 0 {
        return 0.0;
    }
    let (_, upper, _) = values.select_nth_unstable_by(n / 2, f64::total_cmp);
    let upper = *upper;
    if n % 2 == 1 {
        return upper;
    }
    let lower = values[..n / 2]
        .iter()
        .copied()
        .fold(f64::NEG_INFINITY, f64::max);
    (lower + upper) / 2.0
}
