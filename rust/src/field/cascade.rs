//! The axis-by-axis cascade generator of separable AR fields (SPEC §1.2–1.4).
//!
//! x = σ L_0 L_1 … L_{N-1} ξ, where L_k is the stationary-start recursion of axis k
//! ([`AxisRecursion`]): Σ_k n_k multiply-adds per element instead of the Π_k (n_k+1) of the
//! template recursion, and exactly stationary on the finite grid (the covariance of the output
//! is σ² ⊗_k Toeplitz(R_k)). The grid is produced slice by slice along axis 0: each slice is a
//! field of the remaining axes, then axis 0's recursion combines it with the previous slices.
//! A 2-D field is therefore made row by row in one pass, with the previous rows in cache, and
//! a space–time stream is the same kernel applied one frame at a time.
//!
//! Every element is computed by the same arithmetic in the serial and the parallel paths, so
//! the result does not depend on the number of threads.

use super::driving_noise::DrivingNoise;
use super::field_model::FieldModel;
use super::real::Real;
use super::stationary_start::AxisRecursion;
use crate::error::{try_zeros, FieldError, Result};
use rayon::prelude::*;

/// Grids smaller than this many elements are generated on one thread.
const PARALLEL_MIN: usize = 1 << 16;
/// Width of the column strips that axis-0 recursions are split into across threads.
const STRIP: usize = 512;
/// Chunk length of the slab update (kept in L1 across its passes).
const CHUNK: usize = 256;

/// Fills `out` (C order, `shape`) with one realisation of `model`.
///
/// With `DrivingNoise::Given`, `values` must hold one standard-normal number per element (same shape).
/// A model whose recursions T cannot carry (float32 states of a smooth model drift by up to
/// O(σ), `AxisRecursion::new`) but float64 can is made in float64 and rounded once: the
/// float64 field's values, rounded (a float64 copy of the grid in memory meanwhile).
pub fn sample_into<T: Real>(
    model: &FieldModel,
    out: &mut [T],
    shape: &[usize],
    noise: DrivingNoise,
) -> Result<()> {
    check_grid(model.ndim(), out.len(), shape, "shape")?;
    check_noise(&noise, out.len())?;
    match model.recursions::<T>() {
        Ok(recursions) => generate(out, shape, &recursions, &noise, 0),
        Err(narrow) => {
            let Ok(recursions) = model.recursions::<f64>() else {
                return Err(narrow);
            };
            let mut wide = try_zeros(out.len(), "the float64 field")?;
            generate(&mut wide, shape, &recursions, &noise, 0);
            out.iter_mut()
                .zip(&wide)
                .for_each(|(v, &w)| *v = T::from_f64(w));
        }
    }
    Ok(())
}

/// Frame `t` of a stream whose axis 0 is time: a field of the remaining axes, then the time
/// recursion with `history` (the previous frames, most recent first, at least min(t, n_t)).
pub fn stream_frame_into<T: Real>(
    model: &FieldModel,
    frame: &mut [T],
    frame_shape: &[usize],
    history: &[&[T]],
    t: u64,
    noise: DrivingNoise,
) -> Result<()> {
    if model.ndim() < 2 {
        return Err(FieldError::InvalidParameter(
            "streaming needs a model with a time axis and at least one spatial axis".into(),
        ));
    }
    check_grid(model.ndim() - 1, frame.len(), frame_shape, "frame_shape")?;
    let recursions = model.recursions::<T>()?;
    let needed = (t as usize).min(recursions[0].order());
    if history.len() < needed || history.iter().any(|h| h.len() != frame.len()) {
        return Err(FieldError::Shape(format!(
            "frame {t} needs the {needed} previous frames of {} elements",
            frame.len()
        )));
    }
    let lines = frame.len() / frame_shape[frame_shape.len() - 1];
    let first_line = t.wrapping_mul(lines as u64);
    let noise = match noise {
        DrivingNoise::Given { values, .. } => {
            check_noise(&noise, frame.len())?;
            DrivingNoise::Given { values, first_line }
        }
        seeded => seeded,
    };
    let position = t.min(recursions[0].order() as u64) as usize;
    let history = &history[..needed];
    // the time recursion on the part of the frame that starts at element `lo`
    let time_step = |lo: usize, part: &mut [T]| {
        let prev: Vec<&[T]> = history.iter().map(|h| &h[lo..lo + part.len()]).collect();
        slab_step(&recursions[0], position, part, &prev);
    };
    if use_threads(frame.len()) {
        generate_parallel(frame, frame_shape, &recursions[1..], &noise, first_line);
        let strip = 16 * STRIP;
        frame
            .par_chunks_mut(strip)
            .enumerate()
            .for_each(|(s, part)| time_step(s * strip, part));
    } else {
        let slab = frame.len() / frame_shape[0];
        generate_serial_then(
            frame,
            frame_shape,
            &recursions[1..],
            &noise,
            first_line,
            |i, part| time_step(i * slab, part),
        );
    }
    Ok(())
}

fn check_grid(ndim: usize, len: usize, shape: &[usize], what: &str) -> Result<()> {
    if shape.len() != ndim {
        return Err(FieldError::Shape(format!(
            "{what} has {} axes but the model has {ndim}",
            shape.len()
        )));
    }
    if shape.contains(&0) {
        return Err(FieldError::Shape(format!(
            "{what} {shape:?} has an empty axis"
        )));
    }
    let total = shape.iter().try_fold(1usize, |acc, &s| acc.checked_mul(s));
    if total != Some(len) {
        return Err(FieldError::Shape(format!(
            "{what} {shape:?} does not match an output of {len} elements"
        )));
    }
    Ok(())
}

fn check_noise(noise: &DrivingNoise, len: usize) -> Result<()> {
    if let DrivingNoise::Given { values, .. } = noise {
        if values.len() != len {
            return Err(FieldError::Shape(format!(
                "noise has {} elements but the grid has {len}",
                values.len()
            )));
        }
        if values.iter().any(|v| !v.is_finite()) {
            return Err(FieldError::NonFinite(
                "noise contains NaN or infinite values".into(),
            ));
        }
    }
    Ok(())
}

/// Generates the grid `out` of `shape` whose first line has global index `first_line`.
fn generate<T: Real>(
    out: &mut [T],
    shape: &[usize],
    recs: &[AxisRecursion<T>],
    noise: &DrivingNoise,
    first_line: u64,
) {
    if use_threads(out.len()) {
        generate_parallel(out, shape, recs, noise, first_line);
    } else {
        generate_serial(out, shape, recs, noise, first_line);
    }
}

fn use_threads(len: usize) -> bool {
    rayon::current_num_threads() > 1 && len >= PARALLEL_MIN
}

fn lines_per_slice(shape: &[usize]) -> u64 {
    shape[1..shape.len() - 1].iter().product::<usize>() as u64
}

fn generate_serial<T: Real>(
    out: &mut [T],
    shape: &[usize],
    recs: &[AxisRecursion<T>],
    noise: &DrivingNoise,
    first_line: u64,
) {
    generate_serial_then(out, shape, recs, noise, first_line, |_, _| {});
}

/// [`generate_serial`], calling `finish(i, slice_i)` on each slice of axis 0 as soon as the
/// axis-0 recursion no longer reads it (n slices later), while it is still in cache.
fn generate_serial_then<T: Real>(
    out: &mut [T],
    shape: &[usize],
    recs: &[AxisRecursion<T>],
    noise: &DrivingNoise,
    first_line: u64,
    mut finish: impl FnMut(usize, &mut [T]),
) {
    if shape.len() == 1 {
        lines_into(out, out.len(), &recs[0], noise, first_line);
        finish(0, out);
        return;
    }
    let slab = out.len() / shape[0];
    let lines = lines_per_slice(shape);
    let n = recs[0].order();
    for i in 0..shape[0] {
        let (done, rest) = out.split_at_mut(i * slab);
        let line = first_line + i as u64 * lines;
        if shape.len() > 2 {
            generate_serial(&mut rest[..slab], &shape[1..], &recs[1..], noise, line);
        } else if i % 2 == 0 {
            // slices are single lines: make them two at a time
            let count = 2.min(shape[0] - i);
            lines_into(&mut rest[..count * slab], slab, &recs[1], noise, line);
        }
        let cur = &mut rest[..slab];
        let prev: Vec<&[T]> = (1..=i.min(n))
            .map(|j| &done[(i - j) * slab..(i - j + 1) * slab])
            .collect();
        slab_step(&recs[0], i, cur, &prev);
        if i >= n {
            finish(i - n, &mut done[(i - n) * slab..(i - n + 1) * slab]);
        }
    }
    for k in shape[0].saturating_sub(n)..shape[0] {
        finish(k, &mut out[k * slab..(k + 1) * slab]);
    }
}

fn generate_parallel<T: Real>(
    out: &mut [T],
    shape: &[usize],
    recs: &[AxisRecursion<T>],
    noise: &DrivingNoise,
    first_line: u64,
) {
    if shape.len() == 1 {
        generate_serial(out, shape, recs, noise, first_line);
        return;
    }
    let slab = out.len() / shape[0];
    let lines = lines_per_slice(shape);
    if shape.len() == 2 {
        out.par_chunks_mut(2 * slab)
            .enumerate()
            .for_each(|(k, block)| {
                lines_into(block, slab, &recs[1], noise, first_line + 2 * k as u64)
            });
    } else {
        // many slices: one task each; few large ones: parallel inside each slice
        let nested = shape[0] < 4 * rayon::current_num_threads() && slab >= PARALLEL_MIN;
        let make_slice = |(i, cur): (usize, &mut [T])| {
            let line = first_line + i as u64 * lines;
            if nested {
                generate_parallel(cur, &shape[1..], &recs[1..], noise, line);
            } else {
                generate_serial(cur, &shape[1..], &recs[1..], noise, line);
            }
        };
        if nested {
            out.chunks_mut(slab).enumerate().for_each(make_slice);
        } else {
            out.par_chunks_mut(slab).enumerate().for_each(make_slice);
        }
    }
    recurse_in_strips(out, shape[0], slab, &recs[0]);
}

/// A raw pointer that may cross threads: tasks built on it touch disjoint element ranges.
#[derive(Clone, Copy)]
struct SharedOut<T>(*mut T);
unsafe impl<T: Send> Send for SharedOut<T> {}
unsafe impl<T: Send> Sync for SharedOut<T> {}

/// Axis-0 recursion over `len` slices of `slab` elements, one task per column strip.
fn recurse_in_strips<T: Real>(out: &mut [T], len: usize, slab: usize, rec: &AxisRecursion<T>) {
    let base = SharedOut(out.as_mut_ptr());
    let n = rec.order();
    (0..slab.div_ceil(STRIP))
        .into_par_iter()
        .for_each(move |s| {
            let base = base;
            let lo = s * STRIP;
            let width = STRIP.min(slab - lo);
            let mut prev: Vec<&[T]> = Vec::with_capacity(n);
            for i in 0..len {
                // SAFETY: this task alone touches columns lo..lo+width of every slice; `cur` (slice
                // i) and `prev` (slices i-1..i-n) are disjoint, and all lie inside `out`.
                let cur =
                    unsafe { std::slice::from_raw_parts_mut(base.0.add(i * slab + lo), width) };
                prev.clear();
                for j in 1..=i.min(n) {
                    prev.push(unsafe {
                        std::slice::from_raw_parts(base.0.add((i - j) * slab + lo), width)
                    });
                }
                slab_step(rec, i, cur, &prev);
            }
        });
}

/// cur ← g·cur + Σ_j a_j prev_j at `position` along the axis (prev[0] = the slice before).
/// Terms are added oldest first, as in [`filter_line`].
pub(crate) fn slab_step<T: Real>(
    rec: &AxisRecursion<T>,
    position: usize,
    cur: &mut [T],
    prev: &[&[T]],
) {
    let (a, g) = rec.at(position);
    let len = cur.len();
    match *a {
        [] => cur.iter_mut().for_each(|v| *v = *v * g),
        [a0] => {
            let p0 = &prev[0][..len];
            cur.iter_mut()
                .zip(p0)
                .for_each(|(v, &x0)| *v = *v * g + a0 * x0);
        }
        [a0, a1] => {
            let (p0, p1) = (&prev[0][..len], &prev[1][..len]);
            for ((v, &x0), &x1) in cur.iter_mut().zip(p0).zip(p1) {
                *v = *v * g + a1 * x1 + a0 * x0;
            }
        }
        _ => {
            for (c, start) in cur.chunks_mut(CHUNK).zip((0..).step_by(CHUNK)) {
                c.iter_mut().for_each(|v| *v = *v * g);
                for (j, &aj) in a.iter().enumerate().rev() {
                    let p = &prev[j][start..start + c.len()];
                    c.iter_mut().zip(p).for_each(|(v, &pv)| *v = *v + aj * pv);
                }
            }
        }
    }
}

/// The whole lines of length `width` in `block`, the first being line `first_line` of the
/// grid: their noise, then the recursion of their axis run over them in place, two lines at a
/// time so that their independent dependency chains overlap. (Drawing a line's normals in a
/// tight loop before the recursion measured faster than drawing them inside it.)
pub(crate) fn lines_into<T: Real>(
    block: &mut [T],
    width: usize,
    rec: &AxisRecursion<T>,
    noise: &DrivingNoise,
    first_line: u64,
) {
    for (k, line) in block.chunks_mut(width).enumerate() {
        noise.fill(line, first_line + k as u64);
    }
    for pair in block.chunks_mut(2 * width) {
        if pair.len() == 2 * width {
            let (a, b) = pair.split_at_mut(width);
            filter_pair(a, b, rec);
        } else {
            filter_line(pair, rec);
        }
    }
}

/// x_l = g_l ξ_l + Σ_j a_{l,j} x_{l-1-j} along a line holding ξ on entry; terms are added
/// oldest first, as in [`slab_step`].
fn filter_line<T: Real>(line: &mut [T], rec: &AxisRecursion<T>) {
    filter_head(line, rec);
    let n = rec.order();
    if line.len() <= n {
        return;
    }
    let (a, g) = rec.at(n);
    match n {
        1 => steady::<T, 1>(line, a, g),
        2 => steady::<T, 2>(line, a, g),
        3 => steady::<T, 3>(line, a, g),
        4 => steady::<T, 4>(line, a, g),
        _ => steady_any(line, a, g),
    }
}

/// [`filter_line`] on two lines of equal length at once (same arithmetic per element).
fn filter_pair<T: Real>(first: &mut [T], second: &mut [T], rec: &AxisRecursion<T>) {
    let n = rec.order();
    if !T::PAIRED_LINES || first.len() <= n || n > 4 {
        filter_line(first, rec);
        filter_line(second, rec);
        return;
    }
    filter_head(first, rec);
    filter_head(second, rec);
    let (a, g) = rec.at(n);
    match n {
        1 => steady_pair::<T, 1>(first, second, a, g),
        2 => steady_pair::<T, 2>(first, second, a, g),
        3 => steady_pair::<T, 3>(first, second, a, g),
        _ => steady_pair::<T, 4>(first, second, a, g),
    }
}

/// The first n positions of a line, each with its own boundary model (SPEC §1.3).
fn filter_head<T: Real>(line: &mut [T], rec: &AxisRecursion<T>) {
    for l in 0..rec.order().min(line.len()) {
        let (a, g) = rec.at(l);
        let mut x = g * line[l];
        for (j, &aj) in a.iter().enumerate().rev() {
            x = x + aj * line[l - 1 - j];
        }
        line[l] = x;
    }
}

/// One step of the steady recursion: x = g ξ + Σ_j a_j w_j (oldest first); w shifts.
#[inline(always)]
fn step<T: Real, const N: usize>(xi: T, a: &[T; N], g: T, w: &mut [T; N]) -> T {
    let mut x = g * xi;
    for j in (0..N).rev() {
        x = x + a[j] * w[j];
    }
    for j in (1..N).rev() {
        w[j] = w[j - 1];
    }
    w[0] = x;
    x
}

fn steady_pair<T: Real, const N: usize>(first: &mut [T], second: &mut [T], a: &[T], g: T) {
    let a: [T; N] = std::array::from_fn(|j| a[j]);
    let mut w1: [T; N] = std::array::from_fn(|j| first[N - 1 - j]);
    let mut w2: [T; N] = std::array::from_fn(|j| second[N - 1 - j]);
    for (v1, v2) in first[N..].iter_mut().zip(&mut second[N..]) {
        // both loads before both stores (the lines' stride is often a multiple of 4 KiB)
        let (xi1, xi2) = (*v1, *v2);
        let x1 = step(xi1, &a, g, &mut w1);
        let x2 = step(xi2, &a, g, &mut w2);
        *v1 = x1;
        *v2 = x2;
    }
}

/// The steady part of a line (positions ≥ N) with the window of past values in registers.
fn steady<T: Real, const N: usize>(line: &mut [T], a: &[T], g: T) {
    let a: [T; N] = std::array::from_fn(|j| a[j]);
    let mut w: [T; N] = std::array::from_fn(|j| line[N - 1 - j]);
    for v in &mut line[N..] {
        *v = step(*v, &a, g, &mut w);
    }
}

fn steady_any<T: Real>(line: &mut [T], a: &[T], g: T) {
    let n = a.len();
    for l in n..line.len() {
        let mut x = g * line[l];
        for (j, &aj) in a.iter().enumerate().rev() {
            x = x + aj * line[l - 1 - j];
        }
        line[l] = x;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample(model: &FieldModel, shape: &[usize], seed: u64, threads: usize) -> Vec<f64> {
        let mut out = vec![0.0; shape.iter().product()];
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| sample_into(model, &mut out, shape, DrivingNoise::Seeded(seed)))
            .unwrap();
        out
    }

    #[test]
    fn thread_count_does_not_change_the_field() {
        let model = FieldModel::new(&[0.9, 0.7, 0.8], &[1, 2, 3], 1.5).unwrap();
        let shape = [5, 70, 300];
        assert_eq!(sample(&model, &shape, 3, 1), sample(&model, &shape, 3, 2));
        let model = FieldModel::new(&[0.9, 0.8], &[2, 2], 1.0).unwrap();
        assert_eq!(
            sample(&model, &[700, 600], 9, 1),
            sample(&model, &[700, 600], 9, 3)
        );
    }

    #[test]
    fn one_dimensional_variance_at_every_position() {
        // Each position of a short line must have variance σ² (edges included).
        let reps = 20_000;
        let model = FieldModel::new(&[0.95], &[3], 2.0).unwrap();
        let mut acc = [0.0; 5];
        for s in 0..reps {
            let line = sample(&model, &[5], s as u64, 1);
            for (a, x) in acc.iter_mut().zip(&line) {
                *a += x * x;
            }
        }
        let se = 4.0 * (2.0f64 / reps as f64).sqrt() * 5.0; // 5 standard errors of s² (σ²=4)
        for a in acc {
            assert!(
                (a / reps as f64 - 4.0).abs() < se,
                "variance {}",
                a / reps as f64
            );
        }
    }

    #[test]
    fn stream_equals_one_shot() {
        let model = FieldModel::new(&[0.8, 0.6, 0.9], &[2, 1, 2], 1.0).unwrap();
        let shape = [6, 9, 11];
        let whole = sample(&model, &shape, 5, 1);
        let frame_len = 99;
        let mut frames: Vec<Vec<f64>> = Vec::new();
        for t in 0..6u64 {
            let mut frame = vec![0.0; frame_len];
            let history: Vec<&[f64]> = frames.iter().rev().take(2).map(|f| f.as_slice()).collect();
            stream_frame_into(
                &model,
                &mut frame,
                &shape[1..],
                &history,
                t,
                DrivingNoise::Seeded(5),
            )
            .unwrap();
            frames.push(frame);
        }
        assert_eq!(frames.concat(), whole);
    }

    #[test]
    fn rejects_bad_grids() {
        let model = FieldModel::new(&[0.5, 0.5], &[1, 1], 1.0).unwrap();
        let mut out = vec![0.0f64; 6];
        assert!(sample_into(&model, &mut out, &[2, 3, 1], DrivingNoise::Seeded(0)).is_err());
        assert!(sample_into(&model, &mut out, &[2, 4], DrivingNoise::Seeded(0)).is_err());
        let bad = [0.0, 1.0, f64::NAN, 0.0, 0.0, 0.0];
        let given = DrivingNoise::Given {
            values: &bad,
            first_line: 0,
        };
        assert!(sample_into(&model, &mut out, &[2, 3], given).is_err());
        let mut empty: Vec<f64> = vec![];
        assert!(sample_into(&model, &mut empty, &[0, 3], DrivingNoise::Seeded(0)).is_err());
    }
}
