//! The correlation surface of a template over a region, and the search for its peak.
//!
//! With a = frame − shift over the region, t̄ the template's mean, n = h·w, per position:
//! - `Method::Ncc` (OpenCV's TM_CCOEFF_NORMED): num = Σ a·(t − t̄), S₁ = Σ a, S₂ = Σ a²,
//!   V = S₂ − S₁²/n (n times the window's variance), score = num / √(V · Σ (t − t̄)²), clamped
//!   to [−1, 1]; a flat window (V ≤ 1e-12 · S₂, which holds every constant window) scores 0.
//! - `Method::Correlation` (the source's uᵀ Q⁻¹ s with white noise): score = Σ frame · t =
//!   Σ a·t + shift · Σ t.
//!
//! Positions whose footprint covers a NaN pixel score NaN. The correlation sums are direct for
//! small templates and through the FFT where that costs less ([`use_fft`]).

use super::box_sums::RowWindows;
use super::direct;
use super::fft::{self, ComplexScratch, Plan};
use super::fragment::Template;
use super::frame::{Frame, Window};
use super::peak::{highest, peak_at, Peak};
use super::region::Region;
use super::tasks::map_chunks;
use crate::image::Pixel;
use crate::image::Scratch;
use crate::simd::{dispatch, Arith, Kernel};
use crate::{FieldError, Result};
use std::sync::Arc;

/// A window whose V = S₂ − S₁²/n is at most this fraction of S₂ is flat: its NCC is 0.
pub const FLAT_WINDOW: f64 = 1e-12;

/// Cost of one product of the direct sums, in the unit of [`FFT_COST`].
const DIRECT_COST: f64 = 1.0;

/// Cost of one ph·pw·log₂(ph·pw) unit of a 2-D transform (2.5 transforms per correlation):
/// measured on the benchmarks' 2-core Xeon, one thread, 512 × 512 float32 frames (8 × 8 and
/// 9 × 9 templates direct, 10 × 10 by FFT: 0.047 ns per product, 0.15 ns per unit).
const FFT_COST: f64 = 3.2;

/// Fixed cost of the FFT route (plans, allocations), in products.
const FFT_OVERHEAD: f64 = 2.0e4;

/// Which score the surface holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Method {
    /// Zero-mean normalised cross-correlation (OpenCV's TM_CCOEFF_NORMED), in [−1, 1].
    Ncc,
    /// Plain correlation Σ frame · template (the source's correlation-extreme statistic).
    Correlation,
}

impl Method {
    /// "ncc" or "correlation".
    pub fn parse(name: &str) -> Result<Self> {
        match name {
            "ncc" => Ok(Self::Ncc),
            "correlation" => Ok(Self::Correlation),
            other => Err(FieldError::InvalidParameter(format!(
                "method must be 'ncc' or 'correlation', got {other:?}"
            ))),
        }
    }
}

/// Scores of every template position in a window: entry (r, c) is the template at top-left
/// (window.x0 + c, window.y0 + r).
#[derive(Debug)]
pub struct Surface {
    /// Row-major scores.
    pub(crate) values: Scratch,
    /// Positions along y.
    pub rows: usize,
    /// Positions along x.
    pub cols: usize,
    /// The searched region.
    pub window: Window,
    /// (column, row, score) of the first (raster order) highest non-NaN score.
    best: Option<(usize, usize, f64)>,
}

impl Surface {
    /// The row-major scores, `rows` × `cols`.
    pub fn values(&self) -> &[f64] {
        &self.values
    }

    /// The highest non-NaN score and its (refined) frame position; None when all are NaN.
    pub fn peak(&self, subpixel: bool) -> Option<Match> {
        let p = peak_at(&self.values, (self.rows, self.cols), self.best?, subpixel);
        Some(Match::at(&p, &self.window))
    }

    /// The highest non-NaN score among the positions whose frame top-left (x, y) `admits`
    /// accepts (the first in raster order on ties), refined on the whole surface; None when
    /// no such position has a score.
    pub(crate) fn peak_where(
        &self,
        subpixel: bool,
        admits: impl Fn(f64, f64) -> bool,
    ) -> Option<Match> {
        let mut best: Option<(usize, usize, f64)> = None;
        for (r, row) in self.values.chunks(self.cols).enumerate() {
            let y = (self.window.y0 + r) as f64;
            for (c, &v) in row.iter().enumerate() {
                let higher = !v.is_nan() && best.is_none_or(|(_, _, b)| v > b);
                if higher && admits((self.window.x0 + c) as f64, y) {
                    best = Some((c, r, v));
                }
            }
        }
        let p = peak_at(&self.values, (self.rows, self.cols), best?, subpixel);
        Some(Match::at(&p, &self.window))
    }
}

/// A found position: the template's top-left (x, y) in the frame and its score.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Match {
    /// Column of the template's top-left pixel (sub-pixel when refined).
    pub x: f64,
    /// Row of the template's top-left pixel.
    pub y: f64,
    /// The surface's value at the integer peak.
    pub score: f64,
}

impl Match {
    fn at(p: &Peak, window: &Window) -> Self {
        Self {
            x: (window.x0 + p.ix) as f64 + p.dx,
            y: (window.y0 + p.iy) as f64 + p.dy,
            score: p.score,
        }
    }
}

/// Whether the FFT route costs less than the direct sums for an h × w template over a
/// rows × cols region.
pub(crate) fn use_fft(rows: usize, cols: usize, h: usize, w: usize) -> bool {
    let products = ((rows + 1 - h) * (cols + 1 - w) * h * w) as f64 * DIRECT_COST;
    let n = (fft::fast_len(rows, false) * fft::fast_len(cols, true)) as f64;
    FFT_OVERHEAD + FFT_COST * 2.5 * n * n.log2() < products
}

/// The correlation sums of one region with any number of same-region templates; the region's
/// spectrum is computed once, on the first template that takes the FFT route.
pub struct Correlator<'a> {
    region: &'a Region,
    spectrum: Option<(Arc<Plan>, ComplexScratch)>,
}

impl<'a> Correlator<'a> {
    pub fn new(region: &'a Region) -> Self {
        Self {
            region,
            spectrum: None,
        }
    }

    /// Σ a[y + i, x + j] · t[i, j] over the valid positions.
    fn correlate(&mut self, t: &[f64], h: usize, w: usize) -> Scratch {
        let Region {
            values,
            rows,
            cols,
            parallel,
            ..
        } = self.region;
        let (rows, cols, parallel) = (*rows, *cols, *parallel);
        let (oh, ow) = (rows + 1 - h, cols + 1 - w);
        if !use_fft(rows, cols, h, w) {
            return direct::correlate(values, cols, t, (h, w), (oh, parallel));
        }
        let (plan, spectrum) = self.spectrum.get_or_insert_with(|| {
            let plan = fft::plan_for(rows, cols);
            let spectrum = plan.forward(values, (rows, cols), parallel);
            (plan, spectrum)
        });
        fft::correlate_spectrum(plan, spectrum.values(), t, (h, w), (oh, ow), parallel)
    }

    /// The surface of `template` (the region must hold it).
    pub fn surface(&mut self, template: &Template, method: Method) -> Result<Surface> {
        let (h, w) = (template.h, template.w);
        let region = self.region;
        if h > region.rows || w > region.cols {
            return Err(FieldError::Shape(format!(
                "the ({h}, {w}) template is larger than the ({}, {}) search region",
                region.rows, region.cols
            )));
        }
        if method == Method::Ncc && template.constant {
            return Err(FieldError::InvalidParameter(
                "the template is constant (every pixel equal): its normalised \
                 cross-correlation is undefined; use method='correlation'"
                    .into(),
            ));
        }
        let (rows, cols) = (region.rows + 1 - h, region.cols + 1 - w);
        let t = match method {
            Method::Ncc => &template.centred,
            Method::Correlation => &template.raw,
        };
        let mut values = self.correlate(t, h, w);
        let best = score(&mut values, region, template, method);
        Ok(Surface {
            values,
            rows,
            cols,
            window: region.window,
            best: best.map(|(k, v)| (k % cols, k / cols, v)),
        })
    }
}

/// Output rows per parallel task of the scoring pass.
const ROWS_PER_TASK: usize = 32;

/// Turns the correlation sums `num` into the method's scores (module docs), NaN where a
/// window covers a missing pixel; returns the first highest score (index, value).
fn score(
    num: &mut [f64],
    region: &Region,
    template: &Template,
    method: Method,
) -> Option<(usize, f64)> {
    let ow = region.cols + 1 - template.w;
    let bests = map_chunks(num, ow * ROWS_PER_TASK, region.parallel, |task, block| {
        let y0 = task * ROWS_PER_TASK;
        dispatch(ScoreBlock {
            block,
            y0,
            inputs: (region, template, method),
        })
    });
    // the first highest over the tasks (in order)
    bests
        .into_iter()
        .flatten()
        .reduce(|a, b| if b.1 > a.1 { b } else { a })
}

/// [`score`] on the output rows y0.. held by `block`: a kernel of the runtime SIMD dispatch.
struct ScoreBlock<'a> {
    block: &'a mut [f64],
    y0: usize,
    inputs: (&'a Region, &'a Template, Method),
}

impl Kernel for ScoreBlock<'_> {
    type Output = Option<(usize, f64)>;
    #[inline(always)]
    fn run<A: Arith>(self) -> Option<(usize, f64)> {
        score_block(self.block, self.y0, self.inputs)
    }
}

#[inline(always)]
fn score_block(
    block: &mut [f64],
    y0: usize,
    (region, template, method): (&Region, &Template, Method),
) -> Option<(usize, f64)> {
    let (h, w) = (template.h, template.w);
    let ow = region.cols + 1 - w;
    let n = (h * w) as f64;
    let offset = region.shift * template.sum;
    let windows = |a| RowWindows::new(a, region.cols, (h, w), y0);
    let mut sums = (method == Method::Ncc).then(|| windows(&region.values));
    let mut missing = region.missing.as_deref().map(windows);
    let (mut s1, mut s2) = (Scratch::to_overwrite(ow), Scratch::to_overwrite(ow));
    let mut best: Option<(usize, f64)> = None;
    for (k, row) in block.chunks_mut(ow).enumerate() {
        match sums.as_mut() {
            Some(sums) => {
                sums.next_row(&mut s1, &mut s2);
                ncc_row(row, (&s1, &s2), n, template.centred_norm2);
            }
            None => row.iter_mut().for_each(|v| *v += offset),
        }
        if let Some(missing) = missing.as_mut() {
            missing.next_row(&mut s1, &mut s2);
            for (v, &m) in row.iter_mut().zip(s1.iter()) {
                *v = if m > 0.0 { f64::NAN } else { *v };
            }
        }
        if let Some((j, v)) = highest(row) {
            if best.is_none_or(|(_, b)| v > b) {
                best = Some(((y0 + k) * ow + j, v));
            }
        }
    }
    best
}

/// num / √(V · Σ(t − t̄)²) along a row (the module's rule for flat windows).
#[inline(always)]
fn ncc_row(num: &mut [f64], (s1, s2): (&[f64], &[f64]), n: f64, template_norm2: f64) {
    let inverse_n = 1.0 / n;
    for ((v, &s1), &s2) in num.iter_mut().zip(s1).zip(s2) {
        let spread = s2 - s1 * s1 * inverse_n;
        let score = (*v / (spread * template_norm2).sqrt()).clamp(-1.0, 1.0);
        *v = if spread <= FLAT_WINDOW * s2 {
            0.0
        } else {
            score
        };
    }
}

/// The surface of `template` over `window` (default: the whole frame) and its peak.
///
/// Errors: the window not inside the frame or smaller than the template, an infinite pixel,
/// a constant template with `Method::Ncc`, every position covering a NaN pixel.
pub fn match_template<T: Pixel>(
    frame: &Frame<'_, T>,
    template: &Template,
    window: Option<Window>,
    method: Method,
    subpixel: bool,
) -> Result<(Match, Surface)> {
    let window = window.unwrap_or(Window::full(frame.height, frame.width));
    let region = Region::new(frame, window, template.h, template.w)?;
    let surface = Correlator::new(&region).surface(template, method)?;
    let found = surface.peak(subpixel).ok_or_else(|| {
        FieldError::NonFinite(
            "every template position in the window covers a NaN (missing) pixel".into(),
        )
    })?;
    Ok((found, surface))
}
