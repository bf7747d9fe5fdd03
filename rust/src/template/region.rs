//! The searched region as float64, shifted by its mean: the one copy every correlation and
//! window sum of a search reads.

use super::frame::{Frame, Window};
use super::tasks::{map_chunks, PARALLEL_PIXELS};
use crate::image::Pixel;
use crate::image::Scratch;
use crate::simd::{dispatch, Arith, Kernel};
use crate::{FieldError, Result};

/// Rows per parallel task of the conversion (fixed: the sums do not depend on the threads).
const ROWS_PER_TASK: usize = 32;

/// The largest |pixel − mean| accepted: the window sums square it, and sums of up to 2⁶⁴
/// such squares stay finite.
pub(crate) const MAX_DEVIATION: f64 = 1e130;

/// `frame[y0:y1, x0:x1] − shift` as float64, NaN pixels set to 0 and flagged in `missing`.
///
/// `shift` is the mean of a regular subsample of the region's observed pixels (rounded to an
/// integer for integer pixels, so that integer regions stay exact): it removes the level
/// before the window sums square the pixels, which would otherwise cancel digits on a bright
/// background. Any value within the pixels' range would do as well; a subsample saves a pass.
#[derive(Debug)]
pub struct Region {
    pub(crate) values: Scratch,
    pub(crate) rows: usize,
    pub(crate) cols: usize,
    pub(crate) shift: f64,
    /// 1.0 where the pixel is NaN, 0.0 elsewhere; None when no pixel is NaN.
    pub(crate) missing: Option<Vec<f64>>,
    pub(crate) window: Window,
    /// Large enough for the loops to run on rayon's pool.
    pub(crate) parallel: bool,
}

impl Region {
    /// Copies `frame[window]`; an error if the window is not inside the frame or a pixel is
    /// infinite. The window must hold an h × w template.
    pub fn new<T: Pixel>(frame: &Frame<'_, T>, window: Window, h: usize, w: usize) -> Result<Self> {
        window.check(frame.height, frame.width, h, w)?;
        let (rows, cols) = (window.rows(), window.cols());
        let row = |r: usize| {
            let start = (window.y0 + r) * frame.width + window.x0;
            &frame.pixels[start..start + cols]
        };
        let shift = subsample_mean(rows, cols, &row, !T::MAY_BE_NON_FINITE);
        let mut values = Scratch::to_overwrite(rows * cols);
        let parallel = rows * cols >= PARALLEL_PIXELS;
        let tasks: Vec<Task> = map_chunks(
            &mut values,
            cols * ROWS_PER_TASK,
            parallel,
            |task, chunk| {
                let mut t = Task::default();
                for (k, out) in chunk.chunks_mut(cols).enumerate() {
                    let r = task * ROWS_PER_TASK + k;
                    let (spread, non_finite) = dispatch(ShiftedRow {
                        line: row(r),
                        shift,
                        out,
                    });
                    t.spread = t.spread.max(spread);
                    if T::MAY_BE_NON_FINITE && non_finite {
                        let infinite = out.iter().position(|v| v.is_infinite());
                        if let Some(c) = infinite {
                            t.infinite.get_or_insert((window.x0 + c, window.y0 + r));
                        }
                        for v in out.iter_mut().filter(|v| v.is_nan()) {
                            *v = 0.0;
                            t.missing += 1;
                        }
                    }
                }
                t
            },
        );
        if let Some((x, y)) = tasks.iter().find_map(|t| t.infinite) {
            return Err(FieldError::NonFinite(format!(
                "the frame has an infinite pixel at (x, y) = ({x}, {y}); NaN marks a missing \
                 pixel, infinity is refused"
            )));
        }
        if tasks.iter().any(|t| t.spread > MAX_DEVIATION) {
            return Err(FieldError::InvalidParameter(format!(
                "the frame's pixels spread beyond ±{MAX_DEVIATION:e} (the window sums square \
                 them); rescale the frame"
            )));
        }
        let missing = tasks.iter().any(|t| t.missing > 0).then(|| {
            (0..rows)
                .flat_map(|r| {
                    row(r)
                        .iter()
                        .map(|&p| f64::from(u8::from(Into::<f64>::into(p).is_nan())))
                })
                .collect()
        });
        Ok(Self {
            values,
            rows,
            cols,
            shift,
            missing,
            window,
            parallel,
        })
    }
}

/// out = line − shift; returns the largest |out| and whether a pixel is NaN or infinite (then
/// the caller redoes the row's bookkeeping). Eight independent lanes, so that the loop runs on
/// vector registers.
#[inline(always)]
fn shifted_row<T: Pixel>(line: &[T], shift: f64, out: &mut [f64]) -> (f64, bool) {
    const LANES: usize = 8;
    let mut spread = [0.0f64; LANES];
    // 0·d is 0 for finite d and NaN otherwise; NaN stays NaN in the sum
    let mut non_finite = [0.0f64; LANES];
    let mut step = |o: &mut f64, p: T, k: usize| {
        let d = Into::<f64>::into(p) - shift;
        *o = d;
        spread[k] = if d.abs() > spread[k] {
            d.abs()
        } else {
            spread[k]
        };
        non_finite[k] += 0.0 * d;
    };
    let mut outs = out.chunks_exact_mut(LANES);
    let mut pixels = line.chunks_exact(LANES);
    for (o, p) in (&mut outs).zip(&mut pixels) {
        for k in 0..LANES {
            step(&mut o[k], p[k], k);
        }
    }
    for (o, &p) in outs.into_remainder().iter_mut().zip(pixels.remainder()) {
        step(o, p, 0);
    }
    let largest = spread.iter().fold(0.0f64, |a, &b| a.max(b));
    (largest, non_finite.iter().any(|v| v.is_nan()))
}

/// [`shifted_row`] as a kernel of the runtime SIMD dispatch (4-lane registers with AVX2).
struct ShiftedRow<'a, T> {
    line: &'a [T],
    shift: f64,
    out: &'a mut [f64],
}

impl<T: Pixel> Kernel for ShiftedRow<'_, T> {
    type Output = (f64, bool);
    #[inline(always)]
    fn run<A: Arith>(self) -> (f64, bool) {
        shifted_row(self.line, self.shift, self.out)
    }
}

/// Per task of the conversion: NaN count, largest |pixel − shift|, first infinite pixel.
#[derive(Default)]
struct Task {
    missing: usize,
    spread: f64,
    infinite: Option<(usize, usize)>,
}

/// Pixels per axis of the subsample whose mean is the shift.
pub const SHIFT_SAMPLES: usize = 64;

/// The mean of the observed pixels at rows k·⌊rows/64⌋ and columns l·⌊cols/64⌋ (every row or
/// column when there are fewer than 64), k, l < 64; rounded (half away from zero) for integer
/// pixels; 0 when none is observed.
fn subsample_mean<'a, T: Pixel + 'a>(
    rows: usize,
    cols: usize,
    row: &impl Fn(usize) -> &'a [T],
    integer: bool,
) -> f64 {
    let step = |n: usize| (n / SHIFT_SAMPLES).max(1);
    let (mut sum, mut count) = (0.0, 0usize);
    for r in (0..rows).step_by(step(rows)).take(SHIFT_SAMPLES) {
        let line = row(r);
        for c in (0..cols).step_by(step(cols)).take(SHIFT_SAMPLES) {
            let v: f64 = line[c].into();
            if v.is_finite() {
                sum += v;
                count += 1;
            }
        }
    }
    let mean = if count > 0 { sum / count as f64 } else { 0.0 };
    if integer {
        mean.round()
    } else {
        mean
    }
}
