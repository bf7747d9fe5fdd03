//! Frame preparation of the detector (SPEC §3.4, method page *Extended objects*): the box
//! mean before thresholding and the background level (median) of the automatic threshold.
//! The twin is `kalmanfield.reference.extended.frames` (same summation order).

/// Frames beyond this many pixels take the median of every 4th row and column.
const FULL_MEDIAN_PIXELS: usize = 65536;

/// Mean over a `width` × `width` box centred on each pixel of an `h` × `w` row-major image,
/// edges repeated (the box spans `width / 2` before and `width − 1 − width / 2` after): per
/// output row, a column sum of `width` image rows, then a row sum over the edge-padded column
/// sums times `1 / width²`, each summing its terms in order (two passes over a row-long,
/// cache-resident buffer per output row for `width` ≤ 3; one allocation besides the output).
pub fn box_smooth(image: &[f64], h: usize, w: usize, width: usize) -> Vec<f64> {
    let mut out = vec![0.0; h * w];
    box_smooth_into(image, h, w, width, &mut out);
    out
}

/// `box_smooth` into `out` (`h * w` values): a buffer reused frame after frame is written
/// without the page faults of a fresh allocation (most of the cost of a new 512² output).
pub fn box_smooth_into(image: &[f64], h: usize, w: usize, width: usize, out: &mut [f64]) {
    if width <= 1 {
        out.copy_from_slice(image);
        return;
    }
    let lo = width / 2;
    let inv = 1.0 / (width * width) as f64;
    let mut padded = vec![0.0; w + width - 1];
    for (i, row) in out.chunks_exact_mut(w).enumerate() {
        sum_scaled(&mut padded[lo..lo + w], width, 1.0, |k| {
            &image[(i + k).saturating_sub(lo).min(h - 1) * w..][..w]
        });
        let (first, last) = (padded[lo], padded[lo + w - 1]);
        padded[..lo].fill(first);
        padded[lo + w..].fill(last);
        sum_scaled(row, width, inv, |k| &padded[k..k + w]);
    }
}

/// `dst = (term(0) + term(1) + … + term(n − 1)) · scale` element-wise, summed in order, for
/// n ≥ 2: the first three terms and the scaling share a pass (x · 1.0 is exact).
fn sum_scaled<'a>(dst: &mut [f64], n: usize, scale: f64, term: impl Fn(usize) -> &'a [f64]) {
    let (a, b) = (term(0), term(1));
    let first = if n <= 3 { scale } else { 1.0 };
    if n == 2 {
        for ((d, x), y) in dst.iter_mut().zip(a).zip(b) {
            *d = (x + y) * first;
        }
    } else {
        for (((d, x), y), z) in dst.iter_mut().zip(a).zip(b).zip(term(2)) {
            *d = (x + y + z) * first;
        }
    }
    for k in 3..n {
        let s = if k + 1 == n { scale } else { 1.0 };
        for (d, x) in dst.iter_mut().zip(term(k)) {
            *d = (*d + x) * s;
        }
    }
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
