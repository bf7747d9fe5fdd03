//! The runs of foreground pixels of each row, found in one raster scan with their sums and
//! joined to the touching runs of the row above.

use super::union_find::union;
use super::Pixel;

/// A maximal horizontal run of foreground pixels, columns x0..=x1 of `row`, with its sums
/// over the pixels (dx = column − x0: small numbers, so Σ w dx keeps its precision).
#[derive(Debug, Clone, Copy)]
pub(super) struct Run {
    pub(super) row: usize,
    pub(super) x0: usize,
    pub(super) x1: usize,
    pub(super) value: f64,
    pub(super) weight: f64,
    pub(super) weight_dx: f64,
}

/// Pixels per block of the branch-free (vectorised) loops.
pub(super) const BLOCK: usize = 32;

/// Whether every pixel is finite; blocks are tested without early exit so they vectorise.
pub(super) fn all_finite<T: Pixel>(frame: &[T]) -> bool {
    frame
        .chunks(BLOCK)
        .all(|block| block.iter().fold(true, |ok, &v| ok & v.into().is_finite()))
}

/// The first column ≥ `x` whose pixel is above `threshold`, or `pixels.len()`. Most of a
/// frame is background: whole blocks of it are passed with one branch-free test each.
pub(super) fn skip_background<T: Pixel>(pixels: &[T], mut x: usize, threshold: f64) -> usize {
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
pub(super) fn scan_runs<T: Pixel>(
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
pub(super) fn next_run<T: Pixel>(
    pixels: &[T],
    x: &mut usize,
    row: usize,
    threshold: f64,
) -> Option<Run> {
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
