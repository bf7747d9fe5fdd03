//! Image buffers shared by the domains: the pixel types frames come in (uint8, uint16,
//! float32, float64) and the per-thread frame-sized scratch buffers.

mod pixel;
mod scratch;

pub use pixel::Pixel;
pub(crate) use scratch::Scratch;
