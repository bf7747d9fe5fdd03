//! The sums of each segment, merged from its runs, and the labels of the segments kept.

use super::runs::Run;
use crate::error::{FieldError, Result};

/// Sums of one segment; first moments relative to the segment's first pixel (ox, oy).
#[derive(Debug, Clone, Copy)]
pub(super) struct Sums {
    pub(super) ox: usize,
    pub(super) oy: usize,
    pub(super) area: usize,
    pub(super) value: f64,
    pub(super) weight: f64,
    pub(super) weight_u: f64,
    pub(super) weight_v: f64,
    pub(super) x0: usize,
    pub(super) x1: usize,
    pub(super) y1: usize,
}

/// Per segment (in raster order of the first pixel) the merged sums, and per run its segment.
pub(super) fn merge_runs(runs: &[Run], root: &[usize]) -> (Vec<Sums>, Vec<usize>) {
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

pub(super) fn add_run(s: &mut Sums, run: &Run) {
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
pub(super) fn number_segments(sums: &[Sums], min_area: usize) -> Result<Vec<i32>> {
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
pub(super) fn centroid(s: &Sums) -> (f64, f64) {
    (
        s.ox as f64 + s.weight_u / s.weight,
        s.oy as f64 + s.weight_v / s.weight,
    )
}
