//! A frame (row-major pixels of any supported type) and a search window on it.

use crate::image::Pixel;
use crate::{FieldError, Result};

/// A row-major image borrowed from the caller; uint8, uint16, float32 or float64 pixels.
#[derive(Debug, Clone, Copy)]
pub struct Frame<'a, T> {
    pub(crate) pixels: &'a [T],
    pub(crate) height: usize,
    pub(crate) width: usize,
}

impl<'a, T: Pixel> Frame<'a, T> {
    /// Wraps `pixels` (height × width, row-major); an error if the length does not match or
    /// the frame is empty.
    pub fn new(pixels: &'a [T], height: usize, width: usize) -> Result<Self> {
        if height == 0 || width == 0 {
            return Err(FieldError::Shape(format!(
                "the frame is empty (shape ({height}, {width}))"
            )));
        }
        if height.checked_mul(width) != Some(pixels.len()) {
            return Err(FieldError::Shape(format!(
                "a ({height}, {width}) frame needs {} pixels, got {}",
                height.saturating_mul(width),
                pixels.len()
            )));
        }
        Ok(Self {
            pixels,
            height,
            width,
        })
    }

    /// Rows.
    pub fn height(&self) -> usize {
        self.height
    }

    /// Columns.
    pub fn width(&self) -> usize {
        self.width
    }
}

/// The half-open frame region `frame[y0:y1, x0:x1]` searched: the whole template lies in it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Window {
    /// First column.
    pub x0: usize,
    /// First row.
    pub y0: usize,
    /// One past the last column.
    pub x1: usize,
    /// One past the last row.
    pub y1: usize,
}

impl Window {
    /// The whole frame.
    pub fn full(height: usize, width: usize) -> Self {
        Self {
            x0: 0,
            y0: 0,
            x1: width,
            y1: height,
        }
    }

    /// Columns of the region.
    pub fn cols(&self) -> usize {
        self.x1 - self.x0
    }

    /// Rows of the region.
    pub fn rows(&self) -> usize {
        self.y1 - self.y0
    }

    /// Ok when the window is a non-empty region inside a height × width frame that holds an
    /// h × w template.
    pub fn check(&self, height: usize, width: usize, h: usize, w: usize) -> Result<()> {
        let Self { x0, y0, x1, y1 } = *self;
        if x0 >= x1 || y0 >= y1 {
            return Err(FieldError::InvalidParameter(format!(
                "window (x0, y0, x1, y1) = ({x0}, {y0}, {x1}, {y1}) is empty: it needs \
                 x0 < x1 and y0 < y1 (x1, y1 exclusive)"
            )));
        }
        if x1 > width || y1 > height {
            return Err(FieldError::InvalidParameter(format!(
                "window (x0, y0, x1, y1) = ({x0}, {y0}, {x1}, {y1}) reaches outside the \
                 ({height}, {width}) frame (x1 ≤ {width}, y1 ≤ {height}); clip it to the frame"
            )));
        }
        if h > self.rows() || w > self.cols() {
            return Err(FieldError::Shape(format!(
                "the ({h}, {w}) template is larger than the ({}, {}) search region",
                self.rows(),
                self.cols()
            )));
        }
        Ok(())
    }

    /// The window cut to a height × width frame (None when nothing is left).
    pub fn clipped(
        x0: f64,
        y0: f64,
        x1: f64,
        y1: f64,
        height: usize,
        width: usize,
    ) -> Option<Self> {
        let clip = |v: f64, n: usize| v.clamp(0.0, n as f64) as usize;
        let window = Self {
            x0: clip(x0.floor(), width),
            y0: clip(y0.floor(), height),
            x1: clip(x1.ceil(), width),
            y1: clip(y1.ceil(), height),
        };
        (window.x0 < window.x1 && window.y0 < window.y1).then_some(window)
    }
}
