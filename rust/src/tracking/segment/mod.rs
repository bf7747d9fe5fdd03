//! Segmentation of one frame (SPEC §3, [K93]): threshold, connected components, and per
//! segment the intensity-weighted centroid and RMS extent.
//!
//! Definitions: a pixel is foreground iff its value v > t (strictly); its weight is the excess
//! w = v − t > 0. Pixel (row, column) has centre x = column, y = row. Per segment S:
//! x̄ = Σ w x / Σ w, ȳ = Σ w y / Σ w (centroid), amplitude = Σ v / |S| (mean value),
//! area = |S|, extent_x = √(Σ w (x − x̄)² / Σ w), extent_y likewise (RMS half-size), bbox =
//! inclusive min/max column and row. Segments smaller than `min_area` are dropped (their pixels
//! get label 0); the others are labelled 1..n in raster order of their first pixel.
//!
//! Algorithm: one raster scan finds the runs of foreground pixels of each row, accumulates
//! each run's weighted sums and joins it (union-find over runs) to the touching runs of the
//! previous row; a pass over the runs merges their sums into segments (area, amplitude,
//! centroid). The second moments are then summed about the centroid over the runs' pixels
//! (foreground only): the one-pass form Σ w x² − x̄² Σ w loses all digits of a spread that is
//! small against the segment's size, while this costs a few percent of the scan.

use crate::error::{FieldError, Result};
use moments::{finish_segments, label_image, Scan};
use rayon::prelude::*;
use runs::{all_finite, scan_runs};
use sums::{merge_runs, number_segments};
use union_find::flatten;

mod moments;
mod runs;
mod sums;
mod union_find;

/// A pixel type of a frame: converted exactly to f64.
pub trait Pixel: Copy + Into<f64> + Send + Sync {
    /// Whether a value of this type can be NaN or infinite (floats).
    const MAY_BE_NON_FINITE: bool;
}
impl Pixel for u8 {
    const MAY_BE_NON_FINITE: bool = false;
}
impl Pixel for u16 {
    const MAY_BE_NON_FINITE: bool = false;
}
impl Pixel for f32 {
    const MAY_BE_NON_FINITE: bool = true;
}
impl Pixel for f64 {
    const MAY_BE_NON_FINITE: bool = true;
}

/// One connected segment of foreground pixels (definitions in the module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct Segment {
    /// 1..n, in raster order of the segment's first pixel.
    pub label: usize,
    /// Intensity-weighted centroid column Σ w x / Σ w, w = v − threshold.
    pub x: f64,
    /// Intensity-weighted centroid row Σ w y / Σ w.
    pub y: f64,
    /// Mean pixel value Σ v / area.
    pub amplitude: f64,
    /// Number of pixels.
    pub area: usize,
    /// √(Σ w (x − x̄)² / Σ w): the RMS half-size along the columns.
    pub extent_x: f64,
    /// √(Σ w (y − ȳ)² / Σ w): the RMS half-size along the rows.
    pub extent_y: f64,
    /// Smallest column.
    pub bbox_x0: usize,
    /// Smallest row.
    pub bbox_y0: usize,
    /// Largest column (inclusive).
    pub bbox_x1: usize,
    /// Largest row (inclusive).
    pub bbox_y1: usize,
}

/// The segments of a frame and its label image.
#[derive(Debug, Clone, PartialEq)]
pub struct Segmentation {
    /// height × width, row-major: the segment label of each pixel, 0 = background.
    pub labels: Vec<i32>,
    /// The segments in label order.
    pub segments: Vec<Segment>,
}

/// Segments `frame` (height × width, row-major) at `threshold`; see the module docs for the
/// definitions. `connectivity` is 4 (edge neighbours) or 8 (edge and corner neighbours).
pub fn segment<T: Pixel>(
    frame: &[T],
    height: usize,
    width: usize,
    threshold: f64,
    min_area: usize,
    connectivity: u8,
) -> Result<Segmentation> {
    validate(frame, height, width, threshold, min_area, connectivity)?;
    let mut labels = vec![0; frame.len()];
    let segments = segment_into(frame, &mut labels, width, threshold, min_area, connectivity)?;
    Ok(Segmentation { labels, segments })
}

/// `segment` of a validated frame, writing the label image into `labels` (zeros on entry).
fn segment_into<T: Pixel>(
    frame: &[T],
    labels: &mut [i32],
    width: usize,
    threshold: f64,
    min_area: usize,
    connectivity: u8,
) -> Result<Vec<Segment>> {
    let reach = usize::from(connectivity == 8);
    let (runs, mut parent) = scan_runs(frame, width, threshold, reach);
    flatten(&mut parent);
    let (sums, segment_of_run) = merge_runs(&runs, &parent);
    let labels_of_segment = number_segments(&sums, min_area)?;
    let scan = Scan {
        runs: &runs,
        segment_of_run: &segment_of_run,
        sums: &sums,
        labels: &labels_of_segment,
    };
    let segments = finish_segments(&scan, frame, width, threshold);
    label_image(&scan, width, labels);
    Ok(segments)
}

/// Segments every frame of a stack (frames × height × width, row-major) in parallel over the
/// frames (rayon); the result is the same whatever the number of threads.
pub fn segment_stack<T: Pixel>(
    stack: &[T],
    frames: usize,
    height: usize,
    width: usize,
    threshold: f64,
    min_area: usize,
    connectivity: u8,
) -> Result<StackSegmentation> {
    let size = height.saturating_mul(width);
    if frames.checked_mul(size) != Some(stack.len()) {
        return Err(FieldError::Shape(format!(
            "stack has {} values, expected {frames} × {height} × {width}",
            stack.len()
        )));
    }
    let mut labels = vec![0; stack.len()];
    if size == 0 {
        validate(stack, height, width, threshold, min_area, connectivity)?;
        let segments = vec![Vec::new(); frames];
        return Ok(StackSegmentation { labels, segments });
    }
    stack
        .par_chunks(size)
        .try_for_each(|frame| validate(frame, height, width, threshold, min_area, connectivity))?;
    let segments = stack
        .par_chunks(size)
        .zip(labels.par_chunks_mut(size))
        .map(|(frame, out)| segment_into(frame, out, width, threshold, min_area, connectivity))
        .collect::<Result<Vec<_>>>()?;
    Ok(StackSegmentation { labels, segments })
}

/// The segmentation of a stack: the label images (frames × height × width) and the segments
/// of each frame.
#[derive(Debug, Clone, PartialEq)]
pub struct StackSegmentation {
    pub labels: Vec<i32>,
    pub segments: Vec<Vec<Segment>>,
}

fn validate<T: Pixel>(
    frame: &[T],
    height: usize,
    width: usize,
    threshold: f64,
    min_area: usize,
    connectivity: u8,
) -> Result<()> {
    let size = height
        .checked_mul(width)
        .ok_or_else(|| FieldError::Shape(format!("frame shape {height} × {width} is too large")))?;
    if frame.len() != size {
        return Err(FieldError::Shape(format!(
            "frame has {} values, expected height × width = {height} × {width} = {size}",
            frame.len()
        )));
    }
    if connectivity != 4 && connectivity != 8 {
        return Err(FieldError::InvalidParameter(format!(
            "connectivity must be 4 or 8, got {connectivity}"
        )));
    }
    if min_area < 1 {
        return Err(FieldError::InvalidParameter(
            "min_area must be a positive integer, got 0".into(),
        ));
    }
    if !threshold.is_finite() {
        return Err(FieldError::InvalidParameter(format!(
            "threshold must be a finite number, got {threshold}"
        )));
    }
    if T::MAY_BE_NON_FINITE && !all_finite(frame) {
        let i = frame
            .iter()
            .position(|&v| !v.into().is_finite())
            .unwrap_or(0);
        return Err(FieldError::NonFinite(format!(
            "frame contains NaN or infinite values (first at row {}, column {})",
            i / width,
            i % width
        )));
    }
    Ok(())
}

#[cfg(test)]
mod tests;
