//! Search-recurrent fragment tracker (SPEC §5, source [F]; method page *Template tracker*): a template is found in each frame
//! by a correlation-extreme search, and a Kalman filter steers the search window.
//!
//! Conventions shared by every item of the domain (the method page *Template tracker* states
//! them for users):
//! - a position (x, y) is the column and row of the template's **top-left** pixel in the frame
//!   (OpenCV's `minMaxLoc` on a `matchTemplate` surface, skimage's surface index);
//! - a window `(x0, y0, x1, y1)` is the half-open frame region `frame[y0:y1, x0:x1]` the whole
//!   template must lie in, so the surface of an h × w template over it has
//!   (y1 − y0 − h + 1) × (x1 − x0 − w + 1) positions, entry (0, 0) at position (x0, y0);
//! - NaN pixels are missing: every position whose template footprint covers one scores NaN and
//!   is never a peak; ±inf pixels are an error.
//!
//! The twin is `python/kalmanfield/reference/template/`.

mod box_sums;
mod direct;
mod fft;
mod fragment;
mod frame;
mod gate;
mod peak;
mod region;
mod surface;
mod tasks;
mod tracker;

#[cfg(test)]
mod tests;

pub use fragment::Template;
pub use frame::{Frame, Window};
pub use peak::{refine_peak, Peak};
pub use region::Region;
pub use surface::{match_template, Match, Method, Surface};
pub use tracker::{Motion, Step, Target, TemplateTracker, TrackerConfig};
