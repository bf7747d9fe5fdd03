//! The kept segments' centroids and second moments about them, and the label image.

use super::runs::Run;
use super::sums::{centroid, Sums};
use super::{Pixel, Segment};

/// What the scan found: the runs, each run's segment, the merged sums and the label of
/// every segment (0 = dropped).
pub(super) struct Scan<'a> {
    pub(super) runs: &'a [Run],
    pub(super) segment_of_run: &'a [usize],
    pub(super) sums: &'a [Sums],
    pub(super) labels: &'a [i32],
}

/// The kept segments: centroids from the merged sums, then the second moments
/// Σ w (x − x̄)² and Σ w (y − ȳ)² over the pixels of their runs.
pub(super) fn finish_segments<T: Pixel>(
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
pub(super) fn label_image(scan: &Scan<'_>, width: usize, image: &mut [i32]) {
    for (run, &s) in scan.runs.iter().zip(scan.segment_of_run) {
        let start = run.row * width;
        image[start + run.x0..=start + run.x1].fill(scan.labels[s]);
    }
}
