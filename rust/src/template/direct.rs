//! Direct correlation c[y, x] = Σ_{i<h, j<w} a[y + i, x + j] · t[i, j], for small templates:
//! a strip of output columns is accumulated in registers over the template's pixels, so each
//! product costs one load of `a` (no load or store of the output).

use super::tasks::for_each_chunk;
use crate::image::Scratch;
use crate::simd::{dispatch, Arith, Kernel};

/// Output columns per register strip (eight 4-lane registers).
const STRIP: usize = 32;

/// Output rows per parallel task (fixed: the sums do not depend on the threads).
const ROWS_PER_TASK: usize = 4;

/// The (rows − h + 1) × (cols − w + 1) valid correlation of the rows × cols array `a`.
pub(crate) fn correlate(
    a: &[f64],
    cols: usize,
    t: &[f64],
    (h, w): (usize, usize),
    (oh, parallel): (usize, bool),
) -> Scratch {
    let ow = cols + 1 - w;
    let mut out = Scratch::to_overwrite(oh * ow);
    for_each_chunk(&mut out, ow * ROWS_PER_TASK, parallel, |task, block| {
        for (k, row) in block.chunks_mut(ow).enumerate() {
            let y = task * ROWS_PER_TASK + k;
            let lines = Lines {
                a,
                cols,
                y,
                t,
                h,
                w,
            };
            dispatch(OutputRow { lines, row });
        }
    });
    out
}

/// What an output row reads: `a` from row `y` on, the template.
pub(super) struct Lines<'a> {
    pub(super) a: &'a [f64],
    pub(super) cols: usize,
    pub(super) y: usize,
    pub(super) t: &'a [f64],
    pub(super) h: usize,
    pub(super) w: usize,
}

/// One output row: the kernel of the runtime SIMD dispatch.
pub(super) struct OutputRow<'a, 'r> {
    pub(super) lines: Lines<'a>,
    pub(super) row: &'r mut [f64],
}

impl Kernel for OutputRow<'_, '_> {
    type Output = ();
    #[inline(always)]
    fn run<A: Arith>(self) {
        let (lines, row) = (&self.lines, self.row);
        let mut x0 = 0;
        while x0 + STRIP <= row.len() {
            row[x0..x0 + STRIP].copy_from_slice(&strip::<A, STRIP>(lines, x0));
            x0 += STRIP;
        }
        while x0 + 4 <= row.len() {
            row[x0..x0 + 4].copy_from_slice(&strip::<A, 4>(lines, x0));
            x0 += 4;
        }
        for (x, out) in row.iter_mut().enumerate().skip(x0) {
            *out = strip::<A, 1>(lines, x)[0];
        }
    }
}

/// c[y, x0..x0 + S].
#[inline(always)]
fn strip<A: Arith, const S: usize>(lines: &Lines<'_>, x0: usize) -> [f64; S] {
    let Lines {
        a,
        cols,
        y,
        t,
        h,
        w,
    } = *lines;
    let mut acc = [0.0; S];
    for i in 0..h {
        let start = (y + i) * cols + x0;
        let source = &a[start..start + S + w - 1];
        for (j, &tij) in t[i * w..(i + 1) * w].iter().enumerate() {
            let values: &[f64; S] = source[j..j + S].try_into().expect("S values");
            for (s, &v) in acc.iter_mut().zip(values) {
                *s = A::add_product(*s, tij, v);
            }
        }
    }
    acc
}
