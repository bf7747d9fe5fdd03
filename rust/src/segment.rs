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
use rayon::prelude::*;

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

/// A maximal horizontal run of foreground pixels, columns x0..=x1 of `row`, with its sums
/// over the pixels (dx = column − x0: small numbers, so Σ w dx keeps its precision).
#[derive(Debug, Clone, Copy)]
struct Run {
    row: usize,
    x0: usize,
    x1: usize,
    value: f64,
    weight: f64,
    weight_dx: f64,
}

/// Sums of one segment; first moments relative to the segment's first pixel (ox, oy).
#[derive(Debug, Clone, Copy)]
struct Sums {
    ox: usize,
    oy: usize,
    area: usize,
    value: f64,
    weight: f64,
    weight_u: f64,
    weight_v: f64,
    x0: usize,
    x1: usize,
    y1: usize,
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

/// Pixels per block of the branch-free (vectorised) loops.
const BLOCK: usize = 32;

/// Whether every pixel is finite; blocks are tested without early exit so they vectorise.
fn all_finite<T: Pixel>(frame: &[T]) -> bool {
    frame
        .chunks(BLOCK)
        .all(|block| block.iter().fold(true, |ok, &v| ok & v.into().is_finite()))
}

/// The first column ≥ `x` whose pixel is above `threshold`, or `pixels.len()`. Most of a
/// frame is background: whole blocks of it are passed with one branch-free test each.
fn skip_background<T: Pixel>(pixels: &[T], mut x: usize, threshold: f64) -> usize {
    while let Some(block) = pixels.get(x..x + BLOCK) {
        if block
            .iter()
            .fold(false, |any, &v| any | (v.into() > threshold))
        {
            break;
        }
        x += BLOCK;
    }
    while x < pixels.len() && pixels[x].into() <= threshold {
        x += 1;
    }
    x
}

/// The runs in raster order and their union-find parents (a parent always precedes its
/// child, so every root is the first run of its segment). `reach` = 1 joins runs that touch
/// diagonally (8-connectivity), 0 only those sharing a column (4-connectivity).
fn scan_runs<T: Pixel>(
    frame: &[T],
    width: usize,
    threshold: f64,
    reach: usize,
) -> (Vec<Run>, Vec<usize>) {
    let mut runs = Vec::new();
    let mut parent = Vec::new();
    let mut previous = 0..0;
    for (row, pixels) in frame.chunks_exact(width.max(1)).enumerate() {
        let start = runs.len();
        let mut next_above = previous.start;
        let mut x = 0;
        while let Some(run) = next_run(pixels, &mut x, row, threshold) {
            let id = runs.len();
            runs.push(run);
            parent.push(id);
            while next_above < previous.end && runs[next_above].x1 + reach < run.x0 {
                next_above += 1;
            }
            // Runs above that end before this one are passed for good; the last one that
            // overlaps may also touch the next run of this row, so `next_above` stays on it.
            let mut above = next_above;
            while above < previous.end && runs[above].x0 <= run.x1 + reach {
                union(&mut parent, above, id);
                above += 1;
            }
        }
        previous = start..runs.len();
    }
    (runs, parent)
}

/// The next run of `pixels` at or after column `*x`, with its sums; advances `*x` past it.
fn next_run<T: Pixel>(pixels: &[T], x: &mut usize, row: usize, threshold: f64) -> Option<Run> {
    let width = pixels.len();
    *x = skip_background(pixels, *x, threshold);
    if *x == width {
        return None;
    }
    let x0 = *x;
    let (mut value, mut weight, mut weight_dx) = (0.0, 0.0, 0.0);
    let mut dx = 0.0;
    while *x < width {
        let v: f64 = pixels[*x].into();
        if v <= threshold {
            break;
        }
        let w = v - threshold;
        value += v;
        weight += w;
        weight_dx += w * dx;
        dx += 1.0;
        *x += 1;
    }
    Some(Run {
        row,
        x0,
        x1: *x - 1,
        value,
        weight,
        weight_dx,
    })
}

/// Root of `i`, halving the path on the way.
fn find(parent: &mut [usize], mut i: usize) -> usize {
    while parent[i] != i {
        parent[i] = parent[parent[i]];
        i = parent[i];
    }
    i
}

/// Joins the sets of `a` and `b`; the smaller root (the earlier run) becomes the root.
fn union(parent: &mut [usize], a: usize, b: usize) {
    let (ra, rb) = (find(parent, a), find(parent, b));
    if ra != rb {
        parent[ra.max(rb)] = ra.min(rb);
    }
}

/// Points every run straight at its root (parents precede children, so one forward pass).
fn flatten(parent: &mut [usize]) {
    for i in 0..parent.len() {
        parent[i] = parent[parent[i]];
    }
}

/// Per segment (in raster order of the first pixel) the merged sums, and per run its segment.
fn merge_runs(runs: &[Run], root: &[usize]) -> (Vec<Sums>, Vec<usize>) {
    let mut sums: Vec<Sums> = Vec::new();
    let mut segment_of_run = vec![0; runs.len()];
    for (i, run) in runs.iter().enumerate() {
        let s = if root[i] == i {
            sums.push(Sums {
                ox: run.x0,
                oy: run.row,
                area: 0,
                value: 0.0,
                weight: 0.0,
                weight_u: 0.0,
                weight_v: 0.0,
                x0: run.x0,
                x1: run.x1,
                y1: run.row,
            });
            sums.len() - 1
        } else {
            segment_of_run[root[i]]
        };
        segment_of_run[i] = s;
        add_run(&mut sums[s], run);
    }
    (sums, segment_of_run)
}

fn add_run(s: &mut Sums, run: &Run) {
    // Offsets from the segment's first pixel: small numbers, so Σ w u keeps its precision.
    let shift = run.x0 as f64 - s.ox as f64;
    let rise = (run.row - s.oy) as f64;
    s.area += run.x1 - run.x0 + 1;
    s.value += run.value;
    s.weight += run.weight;
    s.weight_u += run.weight_dx + shift * run.weight;
    s.weight_v += rise * run.weight;
    s.x0 = s.x0.min(run.x0);
    s.x1 = s.x1.max(run.x1);
    s.y1 = run.row;
}

/// Label (1..n, or 0 if dropped) of every segment: those of area ≥ `min_area`, in order.
fn number_segments(sums: &[Sums], min_area: usize) -> Result<Vec<i32>> {
    let mut next = 0i32;
    sums.iter()
        .map(|s| {
            if s.area < min_area {
                return Ok(0);
            }
            next = next.checked_add(1).ok_or_else(|| {
                FieldError::Shape("more than 2³¹ − 1 segments: int32 labels overflow".into())
            })?;
            Ok(next)
        })
        .collect()
}

/// Centroid (x̄, ȳ) of a segment from its merged sums.
fn centroid(s: &Sums) -> (f64, f64) {
    (
        s.ox as f64 + s.weight_u / s.weight,
        s.oy as f64 + s.weight_v / s.weight,
    )
}

/// What the scan found: the runs, each run's segment, the merged sums and the label of
/// every segment (0 = dropped).
struct Scan<'a> {
    runs: &'a [Run],
    segment_of_run: &'a [usize],
    sums: &'a [Sums],
    labels: &'a [i32],
}

/// The kept segments: centroids from the merged sums, then the second moments
/// Σ w (x − x̄)² and Σ w (y − ȳ)² over the pixels of their runs.
fn finish_segments<T: Pixel>(
    scan: &Scan<'_>,
    frame: &[T],
    width: usize,
    threshold: f64,
) -> Vec<Segment> {
    let centroids: Vec<(f64, f64)> = scan.sums.iter().map(centroid).collect();
    let mut moments = vec![(0.0, 0.0); scan.sums.len()];
    for (run, &s) in scan.runs.iter().zip(scan.segment_of_run) {
        if scan.labels[s] == 0 {
            continue;
        }
        let (cx, cy) = centroids[s];
        let pixels = &frame[run.row * width + run.x0..=run.row * width + run.x1];
        for (x, &v) in (run.x0..).zip(pixels) {
            let dx = x as f64 - cx;
            moments[s].0 += (v.into() - threshold) * dx * dx;
        }
        let dy = run.row as f64 - cy;
        moments[s].1 += run.weight * dy * dy;
    }
    scan.sums
        .iter()
        .zip(scan.labels)
        .zip(centroids.into_iter().zip(moments))
        .filter(|((_, &label), _)| label != 0)
        .map(|((s, &label), ((x, y), (mxx, myy)))| Segment {
            label: label as usize,
            x,
            y,
            amplitude: s.value / s.area as f64,
            area: s.area,
            extent_x: (mxx / s.weight).sqrt(),
            extent_y: (myy / s.weight).sqrt(),
            bbox_x0: s.x0,
            bbox_y0: s.oy,
            bbox_x1: s.x1,
            bbox_y1: s.y1,
        })
        .collect()
}

/// The label image (zeros on entry): each run's pixels get its segment's label.
fn label_image(scan: &Scan<'_>, width: usize, image: &mut [i32]) {
    for (run, &s) in scan.runs.iter().zip(scan.segment_of_run) {
        let start = run.row * width;
        image[start + run.x0..=start + run.x1].fill(scan.labels[s]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const H: usize = 6;
    const W: usize = 7;

    /// Seven 4-connected segments; (1,4)–(2,3) and (4,6)–(5,5) touch only diagonally.
    #[rustfmt::skip]
    const FRAME: [f64; H * W] = [
        0., 5., 5., 0., 0., 0., 0.,
        0., 5., 0., 0., 3., 0., 0.,
        0., 0., 0., 3., 0., 0., 0.,
        2., 0., 0., 0., 0., 0., 9.,
        0., 0., 7., 4., 0., 0., 9.,
        0., 0., 7., 0., 0., 9., 0.,
    ];

    fn run(connectivity: u8, min_area: usize) -> Segmentation {
        segment(&FRAME, H, W, 1.0, min_area, connectivity).unwrap()
    }

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() < 1e-14
    }

    #[test]
    fn four_connectivity_labels_in_raster_order() {
        let s = run(4, 1);
        #[rustfmt::skip]
        let expected = [
            0, 1, 1, 0, 0, 0, 0,
            0, 1, 0, 0, 2, 0, 0,
            0, 0, 0, 3, 0, 0, 0,
            4, 0, 0, 0, 0, 0, 5,
            0, 0, 6, 6, 0, 0, 5,
            0, 0, 6, 0, 0, 7, 0,
        ];
        assert_eq!(s.labels, expected);
        let areas: Vec<usize> = s.segments.iter().map(|g| g.area).collect();
        assert_eq!(areas, [3, 1, 1, 1, 2, 3, 1]);
        assert!(s.segments.iter().enumerate().all(|(i, g)| g.label == i + 1));
    }

    #[test]
    fn eight_connectivity_joins_diagonal_neighbours() {
        let s = run(8, 1);
        #[rustfmt::skip]
        let expected = [
            0, 1, 1, 0, 0, 0, 0,
            0, 1, 0, 0, 2, 0, 0,
            0, 0, 0, 2, 0, 0, 0,
            3, 0, 0, 0, 0, 0, 4,
            0, 0, 5, 5, 0, 0, 4,
            0, 0, 5, 0, 0, 4, 0,
        ];
        assert_eq!(s.labels, expected);
        let g = &s.segments[3];
        assert!(close(g.x, 17.0 / 3.0) && close(g.y, 4.0));
        assert!(close(g.extent_x, (2.0f64 / 9.0).sqrt()));
        assert!(close(g.extent_y, (2.0f64 / 3.0).sqrt()));
        assert_eq!((g.bbox_x0, g.bbox_y0, g.bbox_x1, g.bbox_y1), (5, 3, 6, 5));
    }

    #[test]
    fn min_area_drops_and_renumbers() {
        let s = run(8, 2);
        let areas: Vec<usize> = s.segments.iter().map(|g| g.area).collect();
        assert_eq!(areas, [3, 2, 3, 3]);
        assert_eq!(s.labels[3 * W], 0);
        assert_eq!(s.labels[4 * W + 2], 4);
        let s = run(4, 3);
        assert_eq!(s.segments.len(), 2);
        assert_eq!(s.labels.iter().filter(|&&l| l == 2).count(), 3);
        assert_eq!(s.labels[4 * W + 6], 0);
    }

    #[test]
    fn weighted_centroid_and_extent() {
        // Segment 6 of 4-connectivity: weights 6 at (2,4), 3 at (3,4), 6 at (2,5).
        let g = run(4, 1).segments[5].clone();
        assert!(close(g.x, 2.2) && close(g.y, 4.4));
        assert!(close(g.amplitude, 6.0));
        assert!(close(g.extent_x, 0.4));
        assert!(close(g.extent_y, 0.24f64.sqrt()));
        // Segment 1: equal weights at (1,0), (2,0), (1,1).
        let g = run(4, 1).segments[0].clone();
        assert!(close(g.x, 4.0 / 3.0) && close(g.y, 1.0 / 3.0));
        assert!(close(g.extent_x, (2.0f64 / 9.0).sqrt()));
        assert_eq!((g.bbox_x0, g.bbox_y0, g.bbox_x1, g.bbox_y1), (1, 0, 2, 1));
    }

    #[test]
    fn u_shape_is_one_segment_labelled_from_its_first_pixel() {
        #[rustfmt::skip]
        let frame: [u8; 20] = [
            1, 0, 0, 1, 1,
            1, 0, 1, 0, 1,
            1, 0, 1, 0, 1,
            1, 1, 1, 1, 1,
        ];
        let s = segment(&frame, 4, 5, 0.0, 1, 4).unwrap();
        assert_eq!(s.segments.len(), 1);
        assert!(s
            .labels
            .iter()
            .zip(&frame)
            .all(|(&l, &v)| l == i32::from(v)));
        assert_eq!(s.segments[0].area, 14);
    }

    #[test]
    fn pixel_types_agree() {
        let as_f32: Vec<f32> = FRAME.iter().map(|&v| v as f32).collect();
        let as_u16: Vec<u16> = FRAME.iter().map(|&v| v as u16).collect();
        let reference = run(8, 1);
        assert_eq!(segment(&as_f32, H, W, 1.0, 1, 8).unwrap(), reference);
        assert_eq!(segment(&as_u16, H, W, 1.0, 1, 8).unwrap(), reference);
    }

    #[test]
    fn empty_and_uniform_frames() {
        let s = segment::<f32>(&[], 0, 5, 0.0, 1, 8).unwrap();
        assert!(s.labels.is_empty() && s.segments.is_empty());
        let s = segment(&[0u8; 12], 3, 4, 0.0, 1, 4).unwrap();
        assert!(s.segments.is_empty() && s.labels.iter().all(|&l| l == 0));
        let s = segment(&[2.0; 12], 3, 4, 1.0, 1, 4).unwrap();
        assert_eq!(s.segments.len(), 1);
        let g = &s.segments[0];
        assert!(close(g.x, 1.5) && close(g.y, 1.0));
        assert!(close(g.extent_x, 1.25f64.sqrt()) && close(g.extent_y, (2.0f64 / 3.0).sqrt()));
    }

    #[test]
    fn runs_found_across_block_boundaries() {
        let width = 3 * BLOCK + 5;
        for x in 0..width {
            let mut row = vec![0u16; width];
            row[x] = 1;
            row[(x + 2).min(width - 1)] = 1;
            let s = segment(&row, 1, width, 0.5, 1, 8).unwrap();
            assert_eq!(s.segments[0].bbox_x0, x);
            let on = row.iter().filter(|&&v| v > 0).count();
            assert_eq!(s.labels.iter().filter(|&&l| l > 0).count(), on);
        }
    }

    #[test]
    fn small_spread_keeps_its_digits() {
        // Weights 1e-9 and 1 one pixel apart: extent² = w₁w₂ / (w₁ + w₂)² ≈ 1e-9.
        let g = segment(&[1e-9, 1.0], 1, 2, 0.0, 1, 4).unwrap().segments[0].clone();
        let exact = 1e-9f64.sqrt() / (1.0 + 1e-9);
        assert!((g.extent_x - exact).abs() < 1e-12 * exact);
        assert_eq!(g.extent_y, 0.0);
    }

    #[test]
    fn bad_input_is_an_error() {
        let err = |r: Result<Segmentation>| r.unwrap_err().to_string();
        assert!(err(segment(&FRAME, H, W, 1.0, 1, 6)).contains("connectivity"));
        assert!(err(segment(&FRAME, H, W, 1.0, 0, 8)).contains("min_area"));
        assert!(err(segment(&FRAME, H, W, f64::NAN, 1, 8)).contains("threshold"));
        assert!(err(segment(&FRAME, H, W + 1, 1.0, 1, 8)).contains("values"));
        assert!(err(segment(&[0.0, f64::INFINITY], 1, 2, 1.0, 1, 8)).contains("column 1"));
        assert!(matches!(
            segment(&[f32::NAN], 1, 1, 1.0, 1, 8),
            Err(FieldError::NonFinite(_))
        ));
        assert!(segment(&[0u8], usize::MAX, 2, 1.0, 1, 8).is_err());
    }

    #[test]
    fn a_stack_is_segmented_frame_by_frame() {
        let frames: Vec<f64> = (0..5 * 12 * 9).map(|v| ((v * 7919) % 97) as f64).collect();
        let stack = segment_stack(&frames, 5, 12, 9, 60.0, 1, 8).unwrap();
        for (f, s) in stack.segments.iter().enumerate() {
            let one = segment(&frames[f * 108..(f + 1) * 108], 12, 9, 60.0, 1, 8).unwrap();
            assert_eq!(stack.labels[f * 108..(f + 1) * 108], one.labels);
            assert_eq!(*s, one.segments);
        }
        assert!(segment_stack(&frames, 4, 12, 9, 60.0, 1, 8).is_err());
    }
}
