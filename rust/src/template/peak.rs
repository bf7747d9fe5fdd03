//! The highest entry of a correlation surface and its sub-pixel refinement.
//!
//! Refinement: one Newton step on the 3 × 3 neighbourhood of the integer peak — gradient and
//! Hessian by central differences, g = ((f₊ₓ − f₋ₓ)/2, (f₊ᵧ − f₋ᵧ)/2), Hₓₓ = f₊ₓ − 2f₀ + f₋ₓ,
//! Hₓᵧ = (f₊₊ − f₊₋ − f₋₊ + f₋₋)/4, offset = −H⁻¹g — exact for a quadratic surface. When H is
//! not negative definite, a corner is missing or the step leaves [−1, 1]², each axis takes its
//! own parabola (−gₓ/Hₓₓ when Hₓₓ < 0, else 0). An axis whose neighbour is off the surface or
//! NaN is not refined.

/// The integer peak (row-major indices into the surface) and the refined offsets.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Peak {
    /// Column of the highest entry.
    pub ix: usize,
    /// Row of the highest entry.
    pub iy: usize,
    /// Its value.
    pub score: f64,
    /// Sub-pixel offset along x (0 without refinement).
    pub dx: f64,
    /// Sub-pixel offset along y.
    pub dy: f64,
}

/// The first highest non-NaN entry of `chunk`: eight lanes keep their own first maximum
/// (vector registers), then the lanes are merged (largest value, then smallest index).
#[inline(always)]
pub(crate) fn highest(chunk: &[f64]) -> Option<(usize, f64)> {
    const LANES: usize = 8;
    let mut best = [f64::NEG_INFINITY; LANES];
    let mut at = [usize::MAX; LANES];
    let mut blocks = chunk.chunks_exact(LANES);
    for (b, block) in (&mut blocks).enumerate() {
        for k in 0..LANES {
            // NaN compares false: never taken; ties keep the first
            let take = block[k] > best[k];
            best[k] = if take { block[k] } else { best[k] };
            at[k] = if take { b * LANES + k } else { at[k] };
        }
    }
    let tail = chunk.len() - blocks.remainder().len();
    for (j, &v) in blocks.remainder().iter().enumerate() {
        if v > best[0] || (v == best[0] && at[0] == usize::MAX) {
            best[0] = v;
            at[0] = tail + j;
        }
    }
    (0..LANES)
        .filter(|&k| at[k] != usize::MAX)
        .map(|k| (at[k], best[k]))
        .reduce(|a, b| {
            if b.1 > a.1 || (b.1 == a.1 && b.0 < a.0) {
                b
            } else {
                a
            }
        })
}

/// The sub-pixel offset (dx, dy) of the peak at (ix, iy) of a rows × cols surface.
pub fn refine_peak(
    surface: &[f64],
    (rows, cols): (usize, usize),
    ix: usize,
    iy: usize,
) -> (f64, f64) {
    let at = |dx: isize, dy: isize| -> Option<f64> {
        let x = ix.checked_add_signed(dx).filter(|&x| x < cols)?;
        let y = iy.checked_add_signed(dy).filter(|&y| y < rows)?;
        Some(surface[y * cols + x]).filter(|v| !v.is_nan())
    };
    let f0 = surface[iy * cols + ix];
    // (gradient, curvature) along an axis
    let axis = |minus: Option<f64>, plus: Option<f64>| {
        Some(((plus? - minus?) / 2.0, plus? - 2.0 * f0 + minus?))
    };
    let x_axis = axis(at(-1, 0), at(1, 0));
    let y_axis = axis(at(0, -1), at(0, 1));
    let parabola = |a: Option<(f64, f64)>| match a {
        Some((g, c)) if c < 0.0 => (-g / c).clamp(-1.0, 1.0),
        _ => 0.0,
    };
    if let (Some((gx, hxx)), Some((gy, hyy))) = (x_axis, y_axis) {
        let corners = (at(1, 1), at(1, -1), at(-1, 1), at(-1, -1));
        if let (Some(pp), Some(pm), Some(mp), Some(mm)) = corners {
            let hxy = (pp - pm - mp + mm) / 4.0;
            let det = hxx * hyy - hxy * hxy;
            if hxx < 0.0 && det > 0.0 {
                let dx = -(hyy * gx - hxy * gy) / det;
                let dy = -(hxx * gy - hxy * gx) / det;
                if dx.abs() <= 1.0 && dy.abs() <= 1.0 {
                    return (dx, dy);
                }
            }
        }
    }
    (parabola(x_axis), parabola(y_axis))
}

/// The peak at `best` = (ix, iy, score) of a rows × cols surface, refined when `subpixel`.
pub fn peak_at(
    surface: &[f64],
    (rows, cols): (usize, usize),
    (ix, iy, score): (usize, usize, f64),
    subpixel: bool,
) -> Peak {
    let (dx, dy) = if subpixel {
        refine_peak(surface, (rows, cols), ix, iy)
    } else {
        (0.0, 0.0)
    };
    Peak {
        ix,
        iy,
        score,
        dx,
        dy,
    }
}

/// Points per axis of the subsample whose median and MAD measure a surface's spread.
pub const SPREAD_SAMPLES: usize = 64;

/// How far `score` stands out of a rows × cols surface: (score − median) / (1.4826·MAD), the
/// median and the median absolute deviation taken over the non-NaN entries at rows
/// k·⌊rows/64⌋ and columns l·⌊cols/64⌋ (k, l < 64). +∞ when MAD = 0 and score > median, 0
/// when MAD = 0 otherwise or no entry is usable.
pub fn distinctness(surface: &[f64], (rows, cols): (usize, usize), score: f64) -> f64 {
    let step = |n: usize| (n / SPREAD_SAMPLES).max(1);
    let mut sample: Vec<f64> = (0..rows)
        .step_by(step(rows))
        .take(SPREAD_SAMPLES)
        .flat_map(|r| {
            (0..cols)
                .step_by(step(cols))
                .take(SPREAD_SAMPLES)
                .map(move |c| surface[r * cols + c])
        })
        .filter(|v| !v.is_nan())
        .collect();
    if sample.is_empty() {
        return 0.0;
    }
    let centre = median(&mut sample);
    let mut deviations: Vec<f64> = sample.iter().map(|v| (v - centre).abs()).collect();
    let mad = median(&mut deviations);
    if mad > 0.0 {
        (score - centre) / (1.4826 * mad)
    } else if score > centre {
        f64::INFINITY
    } else {
        0.0
    }
}

/// The median (mean of the two middle values for an even count) of non-empty `v`.
fn median(v: &mut [f64]) -> f64 {
    v.sort_unstable_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        (v[n / 2 - 1] + v[n / 2]) / 2.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn find_peak(s: &[f64], (rows, cols): (usize, usize), subpixel: bool) -> Option<Peak> {
        let (k, v) = highest(s)?;
        Some(peak_at(s, (rows, cols), (k % cols, k / cols, v), subpixel))
    }

    fn sampled(rows: usize, cols: usize, f: impl Fn(f64, f64) -> f64) -> Vec<f64> {
        (0..rows * cols)
            .map(|k| f((k % cols) as f64, (k / cols) as f64))
            .collect()
    }

    #[test]
    fn quadratic_peak_is_exact() {
        let (x0, y0) = (4.37, 5.81);
        let s = sampled(11, 9, |x, y| {
            let (u, v) = (x - x0, y - y0);
            3.0 - 0.8 * u * u - 0.5 * v * v - 0.3 * u * v
        });
        let p = find_peak(&s, (11, 9), true).unwrap();
        assert!((p.ix as f64 + p.dx - x0).abs() < 1e-12);
        assert!((p.iy as f64 + p.dy - y0).abs() < 1e-12);
    }

    #[test]
    fn border_peak_is_not_refined_across_the_border() {
        let s = sampled(5, 5, |x, y| -(x - 0.2).powi(2) - (y - 2.3).powi(2));
        let p = find_peak(&s, (5, 5), true).unwrap();
        assert_eq!((p.ix, p.dx), (0, 0.0));
        assert!((p.iy as f64 + p.dy - 2.3).abs() < 1e-12);
    }

    #[test]
    fn nan_entries_are_never_the_peak() {
        let s = [f64::NAN, 1.0, 3.0, f64::NAN, 3.0, 2.0];
        assert_eq!(highest(&s), Some((2, 3.0)));
        assert_eq!(highest(&[f64::NAN; 4]), None);
        // the lanes: the first of equal maxima wins wherever it sits
        let mut long = vec![0.5; 37];
        long[29] = 2.0;
        long[13] = 2.0;
        long[36] = 2.0;
        assert_eq!(highest(&long), Some((13, 2.0)));
    }
}
