//! The lines of an N-D C-ordered array along one axis, visited in fixed blocks of lanes.
//!
//! Statistics kernels sum over every line along an axis. They walk the lines in blocks whose
//! layout depends only on the array shape, compute one partial sum per block (in parallel)
//! and add the partials in block order, so the result is the same bits on any number of
//! threads.

use crate::error::{FieldError, Result};
use rayon::prelude::*;

/// Lines per block when lines are contiguous (last axis).
const LINES_PER_BLOCK: usize = 32;
/// Lanes per block when lines interleave (earlier axes): a few cache lines of one row.
const LANES_PER_BLOCK: usize = 256;

/// An array seen as (outer, len, inner): lines of length `len` along the chosen axis.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct AxisLines {
    outer: usize,
    len: usize,
    inner: usize,
}

/// A set of lanes (lines) visited together: element `i` of lane `j` is at
/// `base + i * elem_step + j * lane_step`.
#[derive(Debug, Clone, Copy)]
pub(crate) struct LaneBlock {
    pub base: usize,
    pub lanes: usize,
    pub lane_step: usize,
    pub elem_step: usize,
}

impl LaneBlock {
    /// Flat index of element `i` of lane `j`.
    #[inline(always)]
    pub fn at(&self, i: usize, j: usize) -> usize {
        self.base + i * self.elem_step + j * self.lane_step
    }
}

impl AxisLines {
    /// Lines along `axis` of an array of `shape` holding `size` elements.
    pub fn new(shape: &[usize], axis: usize, size: usize) -> Result<Self> {
        if axis >= shape.len() {
            return Err(FieldError::Shape(format!(
                "axis {axis} is out of range for an array with {} axes",
                shape.len()
            )));
        }
        if shape.iter().product::<usize>() != size {
            return Err(FieldError::Shape(format!(
                "the data hold {size} values, not the {} of shape {shape:?}",
                shape.iter().product::<usize>()
            )));
        }
        Ok(Self {
            outer: shape[..axis].iter().product(),
            len: shape[axis],
            inner: shape[axis + 1..].iter().product(),
        })
    }

    /// Length of every line.
    pub fn len(&self) -> usize {
        self.len
    }

    /// True when the lines are empty.
    pub fn is_empty(&self) -> bool {
        self.len == 0 || self.outer == 0 || self.inner == 0
    }

    /// The blocks covering every line once, in a fixed order.
    pub fn blocks(&self) -> Vec<LaneBlock> {
        if self.is_empty() {
            return Vec::new();
        }
        if self.inner == 1 {
            (0..self.outer)
                .step_by(LINES_PER_BLOCK)
                .map(|o| LaneBlock {
                    base: o * self.len,
                    lanes: LINES_PER_BLOCK.min(self.outer - o),
                    lane_step: self.len,
                    elem_step: 1,
                })
                .collect()
        } else {
            (0..self.outer)
                .flat_map(|o| {
                    (0..self.inner)
                        .step_by(LANES_PER_BLOCK)
                        .map(move |j| (o, j))
                })
                .map(|(o, j)| LaneBlock {
                    base: o * self.len * self.inner + j,
                    lanes: LANES_PER_BLOCK.min(self.inner - j),
                    lane_step: 1,
                    elem_step: self.inner,
                })
                .collect()
        }
    }

    /// Σ over blocks of `partial(block)`, added in block order (deterministic).
    pub fn sum_blocks<A, F>(&self, zero: A, partial: F, add: impl Fn(&mut A, &A)) -> A
    where
        A: Send,
        F: Fn(&LaneBlock) -> A + Sync + Send,
    {
        let partials: Vec<A> = self.blocks().par_iter().map(partial).collect();
        partials.iter().fold(zero, |mut acc, p| {
            add(&mut acc, p);
            acc
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn blocks_cover_every_element_once() {
        for (shape, axis) in [
            (vec![5usize, 7, 300], 0usize),
            (vec![5, 7, 300], 1),
            (vec![5, 7, 300], 2),
            (vec![70, 3], 1),
        ] {
            let size: usize = shape.iter().product();
            let lines = AxisLines::new(&shape, axis, size).unwrap();
            let mut seen = vec![0u8; size];
            for b in lines.blocks() {
                for j in 0..b.lanes {
                    for i in 0..lines.len() {
                        seen[b.at(i, j)] += 1;
                    }
                }
            }
            assert!(seen.iter().all(|&s| s == 1), "{shape:?} axis {axis}");
        }
    }

    #[test]
    fn bad_axis_or_size_is_an_error() {
        assert!(AxisLines::new(&[3, 4], 2, 12).is_err());
        assert!(AxisLines::new(&[3, 4], 1, 11).is_err());
    }
}
