//! Correlation through the 2-D discrete Fourier transform, for templates large enough that the
//! transforms cost less than the direct sums (the choice is `surface::use_fft`).
//!
//! The region (rows × cols) and the template are zero-padded to ph × pw with ph ≥ rows and
//! pw ≥ cols; the circular correlation IDFT(A · conj(T)) then equals the linear one at every
//! valid position (y ≤ rows − h, x ≤ cols − w never wraps). A spectrum is stored one line per
//! frequency column: (pw/2 + 1) lines of ph complex values, so both passes run on contiguous
//! lines, in parallel over fixed blocks of lines (the result does not depend on the threads).

use super::tasks::{for_each_chunk, for_each_index};
use crate::image::Scratch;
use realfft::num_complex::Complex;
use realfft::{ComplexToReal, RealFftPlanner, RealToComplex};
use rustfft::{Fft, FftPlanner};
use std::collections::HashMap;
use std::sync::{Arc, Mutex, OnceLock};

type C64 = Complex<f64>;

/// A reused buffer of complex values (stored as interleaved re, im).
pub(crate) struct ComplexScratch(Scratch);

impl ComplexScratch {
    /// `len` zeros, reused per thread.
    fn zeros(len: usize) -> Self {
        Self(Scratch::zeros(2 * len))
    }

    /// `len` values that the caller writes before reading (see `Scratch::to_overwrite`).
    fn to_overwrite(len: usize) -> Self {
        Self(Scratch::to_overwrite(2 * len))
    }

    pub(crate) fn values(&self) -> &[C64] {
        // SAFETY: `Complex<f64>` is `repr(C)` {re, im}: two f64, alignment that of f64, so
        // 2·len f64 are exactly len complex values.
        unsafe { std::slice::from_raw_parts(self.0.as_ptr().cast(), self.0.len() / 2) }
    }

    fn values_mut(&mut self) -> &mut [C64] {
        // SAFETY: as in `values`, and the borrow is unique.
        unsafe { std::slice::from_raw_parts_mut(self.0.as_mut_ptr().cast(), self.0.len() / 2) }
    }
}

/// Lines per parallel task (and per transposed block).
const LINES_PER_TASK: usize = 16;

/// Plans kept per process (sizes of a tracker's windows vary a little from frame to frame).
const MAX_PLANS: usize = 64;

/// The four 1-D transforms of a ph × pw real 2-D transform.
pub(crate) struct Plan {
    ph: usize,
    pw: usize,
    /// pw / 2 + 1 frequency columns.
    nf: usize,
    row_forward: Arc<dyn RealToComplex<f64>>,
    row_inverse: Arc<dyn ComplexToReal<f64>>,
    column_forward: Arc<dyn Fft<f64>>,
    column_inverse: Arc<dyn Fft<f64>>,
}

/// The smallest n' ≥ n whose prime factors are 2, 3, 5 and 7 (even when `even`).
pub(crate) fn fast_len(n: usize, even: bool) -> usize {
    (n.max(1)..)
        .find(|&m| {
            if even && m % 2 == 1 {
                return false;
            }
            let mut r = m;
            for p in [2, 3, 5, 7] {
                while r % p == 0 {
                    r /= p;
                }
            }
            r == 1
        })
        .expect("an unbounded range has such a number")
}

/// The plan of a ph × pw transform (built once per size and process).
pub(crate) fn plan(ph: usize, pw: usize) -> Arc<Plan> {
    type Plans = HashMap<(usize, usize), Arc<Plan>>;
    static PLANS: OnceLock<Mutex<Plans>> = OnceLock::new();
    let mut plans = PLANS
        .get_or_init(Default::default)
        .lock()
        .unwrap_or_else(|poisoned| poisoned.into_inner());
    if let Some(p) = plans.get(&(ph, pw)) {
        return p.clone();
    }
    if plans.len() >= MAX_PLANS {
        plans.clear();
    }
    let mut real = RealFftPlanner::<f64>::new();
    let mut complex = FftPlanner::<f64>::new();
    let p = Arc::new(Plan {
        ph,
        pw,
        nf: pw / 2 + 1,
        row_forward: real.plan_fft_forward(pw),
        row_inverse: real.plan_fft_inverse(pw),
        column_forward: complex.plan_fft_forward(ph),
        column_inverse: complex.plan_fft_inverse(ph),
    });
    plans.insert((ph, pw), p.clone());
    p
}

/// Lines of a spectrum written by several tasks at once, each to its own rows.
struct SharedLines(*mut C64);

// SAFETY: the tasks that share it write disjoint entries (see `Plan::forward`).
unsafe impl Sync for SharedLines {}

impl Plan {
    /// The spectrum of the rows × cols array `a` (row-major), zero-padded to ph × pw: the row
    /// transforms are written transposed, one entry per line, then each line is transformed.
    pub(crate) fn forward(
        &self,
        a: &[f64],
        (rows, cols): (usize, usize),
        parallel: bool,
    ) -> ComplexScratch {
        let (ph, pw, nf) = (self.ph, self.pw, self.nf);
        assert!(rows <= ph && cols <= pw && a.len() == rows * cols);
        let mut spectrum = ComplexScratch::to_overwrite(nf * ph);
        let shared = SharedLines(spectrum.values_mut().as_mut_ptr());
        let shared = &shared;
        for_each_index(rows.div_ceil(LINES_PER_TASK), parallel, |task| {
            let r0 = task * LINES_PER_TASK;
            let height = LINES_PER_TASK.min(rows - r0);
            let mut line = Scratch::zeros(pw);
            let mut spectra = ComplexScratch::zeros(height * nf);
            let spectra = spectra.values_mut();
            let mut scratch = ComplexScratch::zeros(self.row_forward.get_scratch_len());
            for (k, row_spectrum) in spectra.chunks_mut(nf).enumerate() {
                let r = r0 + k;
                line[..cols].copy_from_slice(&a[r * cols..(r + 1) * cols]);
                line[cols..].fill(0.0);
                self.row_forward
                    .process_with_scratch(&mut line, row_spectrum, scratch.values_mut())
                    .expect("buffer lengths come from the plan");
            }
            for f in 0..nf {
                for k in 0..height {
                    // SAFETY: f·ph + r0 + k < nf·ph, the buffer's length; rows r0..r0 + height
                    // are written by this task only, and nothing reads the buffer until the
                    // loop has ended.
                    unsafe { *shared.0.add(f * ph + r0 + k) = spectra[k * nf + f] };
                }
            }
        });
        for_each_chunk(
            spectrum.values_mut(),
            ph * LINES_PER_TASK,
            parallel,
            |_, block| {
                let len = self.column_forward.get_inplace_scratch_len();
                let mut scratch = ComplexScratch::zeros(len);
                for line in block.chunks_mut(ph) {
                    line[rows..].fill(C64::default());
                    self.column_forward
                        .process_with_scratch(line, scratch.values_mut());
                }
            },
        );
        spectrum
    }

    /// The top-left oh × ow block of the real array whose column-transformed lines are
    /// `lines` (the row transforms are inverted here), scaled by 1/(ph·pw).
    fn gather_rows(&self, lines: &[C64], (oh, ow): (usize, usize), parallel: bool) -> Scratch {
        let (ph, pw, nf) = (self.ph, self.pw, self.nf);
        let scale = 1.0 / (ph * pw) as f64;
        let mut out = Scratch::to_overwrite(oh * ow);
        for_each_chunk(&mut out, ow * LINES_PER_TASK, parallel, |task, block| {
            let r0 = task * LINES_PER_TASK;
            let height = block.len() / ow;
            let mut spectra = ComplexScratch::to_overwrite(height * nf);
            let spectra = spectra.values_mut();
            for f in 0..nf {
                let source = &lines[f * ph + r0..f * ph + r0 + height];
                for (k, &v) in source.iter().enumerate() {
                    spectra[k * nf + f] = v;
                }
            }
            let mut line = Scratch::to_overwrite(pw);
            let mut scratch = ComplexScratch::zeros(self.row_inverse.get_scratch_len());
            let rows = spectra.chunks_mut(nf).zip(block.chunks_mut(ow));
            for (row_spectrum, out_row) in rows {
                // real up to rounding (Hermitian symmetry of a real array's spectrum)
                row_spectrum[0].im = 0.0;
                if pw % 2 == 0 {
                    row_spectrum[nf - 1].im = 0.0;
                }
                self.row_inverse
                    .process_with_scratch(row_spectrum, &mut line, scratch.values_mut())
                    .expect("buffer lengths come from the plan");
                for (o, &v) in out_row.iter_mut().zip(line.iter()) {
                    *o = v * scale;
                }
            }
        });
        out
    }

    /// The row transforms of the h × w array `t`, zero-padded to pw: h rows of nf values.
    fn row_spectra(&self, t: &[f64], (h, w): (usize, usize)) -> Vec<C64> {
        let mut spectra = vec![C64::default(); h * self.nf];
        let mut line = Scratch::zeros(self.pw);
        let mut scratch = ComplexScratch::zeros(self.row_forward.get_scratch_len());
        for (row, spectrum) in t.chunks(w).zip(spectra.chunks_mut(self.nf)) {
            line[..w].copy_from_slice(row);
            line[w..].fill(0.0);
            self.row_forward
                .process_with_scratch(&mut line, spectrum, scratch.values_mut())
                .expect("buffer lengths come from the plan");
        }
        spectra
    }
}

/// c[y, x] = Σ_{i<h, j<w} a[y + i, x + j] · t[i, j] over the oh × ow valid positions, with the
/// spectrum `a_spectrum` of `a` under `plan` given. Per line of the template's transform: the
/// column transform, the product A · conj(T) and the inverse column transform run while the
/// line is in cache.
pub(crate) fn correlate_spectrum(
    plan: &Plan,
    a_spectrum: &[C64],
    t: &[f64],
    (h, w): (usize, usize),
    (oh, ow): (usize, usize),
    parallel: bool,
) -> Scratch {
    let (ph, nf) = (plan.ph, plan.nf);
    let t_rows = plan.row_spectra(t, (h, w));
    let mut lines = ComplexScratch::to_overwrite(nf * ph);
    let block_len = ph * LINES_PER_TASK;
    for_each_chunk(lines.values_mut(), block_len, parallel, |task, block| {
        let forward = plan.column_forward.get_inplace_scratch_len();
        let inverse = plan.column_inverse.get_inplace_scratch_len();
        let mut scratch = ComplexScratch::zeros(forward.max(inverse));
        let scratch = scratch.values_mut();
        for (k, line) in block.chunks_mut(ph).enumerate() {
            let f = task * LINES_PER_TASK + k;
            for (v, row) in line.iter_mut().zip(t_rows.chunks(nf)) {
                *v = row[f];
            }
            line[h..].fill(C64::default());
            plan.column_forward
                .process_with_scratch(line, &mut scratch[..forward]);
            for (p, &a) in line.iter_mut().zip(&a_spectrum[f * ph..(f + 1) * ph]) {
                *p = a * p.conj();
            }
            plan.column_inverse
                .process_with_scratch(line, &mut scratch[..inverse]);
        }
    });
    plan.gather_rows(lines.values(), (oh, ow), parallel)
}

/// The plan of a rows × cols region (padded to fast sizes).
pub(crate) fn plan_for(rows: usize, cols: usize) -> Arc<Plan> {
    plan(fast_len(rows, false), fast_len(cols, true))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fast_lengths() {
        assert_eq!(fast_len(509, false), 512);
        assert_eq!(fast_len(11, false), 12);
        assert_eq!(fast_len(11, true), 12);
        assert_eq!(fast_len(7, true), 8);
        assert_eq!(fast_len(1, false), 1);
        assert_eq!(fast_len(121, true), 126);
    }

    #[test]
    fn correlation_equals_direct_sum() {
        let (rows, cols, h, w) = (13, 17, 4, 6);
        let a: Vec<f64> = (0..rows * cols)
            .map(|k| ((k * 37 % 11) as f64).sin())
            .collect();
        let t: Vec<f64> = (0..h * w).map(|k| ((k * 5 % 7) as f64).cos()).collect();
        let p = plan_for(rows, cols);
        let (oh, ow) = (rows - h + 1, cols - w + 1);
        let spectrum = p.forward(&a, (rows, cols), false);
        let c = correlate_spectrum(&p, spectrum.values(), &t, (h, w), (oh, ow), true);
        for y in 0..oh {
            for x in 0..ow {
                let mut s = 0.0;
                for i in 0..h {
                    for j in 0..w {
                        s += a[(y + i) * cols + x + j] * t[i * w + j];
                    }
                }
                assert!((c[y * ow + x] - s).abs() < 1e-12, "{y} {x}");
            }
        }
    }
}
